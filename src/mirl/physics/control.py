"""The ``move_base`` analogue: a feedback controller from a pose estimate to wheel speeds.

Vectorised over robots. Per robot a *mode* and a target, set once per decision step:

- ``DRIVE`` (forward): pursue a target point: the intended cell's centre on the hallway's
  centre line, moved ``lane`` to the right of the heading while another robot is near (keep
  right in company, so robots meeting head-on pass side by side; alone, the middle of the
  hallway, as a costmap inflated around both walls keeps a real robot there). The
  speed is the lesser of the cruise speed and what still lets the robot stop on the point
  (v = √(2·a·d)), times 1 − (e / ``turn_first``)² of the bearing error e (it turns in place
  while e exceeds ``turn_first``, 20°); the turn rate is proportional to the bearing error.
  Within ``arrive`` of the point the robot aligns its heading with the target heading.
- ``PIVOT`` (turn_left / turn_right): rotate towards the target heading by pivoting on the
  inner wheel (turning left the left wheel stands still and the right wheel drives), as the
  paper's ξ has it (turn_left uses the right wheel, turn_right the left).
- ``HOLD`` (stop): both wheels commanded to zero.

The forward speed is acceleration-limited (``max_accel``) like move_base's velocity smoother,
and capped at ``pass_speed`` for robots :func:`crowded` by another. Nothing here knows a motor's
strength: a weak wheel shows up only through the pose feedback.
"""

from __future__ import annotations

import numpy as np

from mirl.physics.robot import KOBUKI, Kobuki
from mirl.world.game import KEEP_RIGHT_BEARING

__all__ = ["DRIVE", "PIVOT", "HOLD", "Controller", "crowded", "in_company", "wrap"]

DRIVE, PIVOT, HOLD = 0, 1, 2

AHEAD_BEARING = 70.0
"""Degrees either side of a robot's heading within which another robot is ahead of it."""
FOLLOW_DISTANCE = 0.8
"""Cells: a robot going the same way closer ahead than this slows the one behind."""
STOP_SHORT = 0.02
"""Metres short of its target point a driving robot plans to stop (it coasts the rest)."""
MAX_DRIVE_TURN = 2.0
"""Rad/s: the turn rate a driving robot steers with at most."""
ALIGNED = 0.05
"""Radians: a robot that has arrived stops turning within this of its target heading."""
PIVOTED = 0.03
"""Radians: a pivot ends within this of its target heading."""


try:  # the clip ufunc without numpy's Python wrappers around it (same loop, same results)
    from numpy._core.umath import clip as _clip  # type: ignore[attr-defined]
except ImportError:  # numpy < 2
    from numpy.core.umath import clip as _clip  # type: ignore[no-redef]


def wrap(a):
    """Angles wrapped into [-π, π).

    Parameters
    ----------
    a : float or array_like
        Radians.

    Returns
    -------
    ndarray
        The same angles in [-π, π).
    """
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _others(p: np.ndarray, cell_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For every pair (i, j) of true poses ``p`` (x, y, yaw; one row a robot): the distance
    (cells; inf for i = j), the bearing of j from i's heading (rad) and whether j faces the
    other way (a real robot's bumper and laser see the other robot directly)."""
    dx = p[None, :, 0] - p[:, None, 0]
    dy = p[None, :, 1] - p[:, None, 1]
    dist = np.hypot(dx, dy) / cell_size
    np.fill_diagonal(dist, np.inf)
    bearing = np.abs(wrap(np.arctan2(dy, dx) - p[:, None, 2]))
    oncoming = np.abs(wrap(p[None, :, 2] - p[:, None, 2])) > np.pi / 2
    return dist, bearing, oncoming


def crowded(p: np.ndarray, cell_size: float, pass_distance: float) -> np.ndarray:
    """Robots that must go slowly.

    Another robot coming the other way within ``pass_distance`` cells ahead (within
    :data:`AHEAD_BEARING`, ±70°: pass slowly), or one going the same way less than
    :data:`FOLLOW_DISTANCE` (0.8 cell) ahead (do not run into it).

    Parameters
    ----------
    p : ndarray of shape (n, 3)
        True poses (x, y, yaw), one row a robot.
    cell_size : float
        Metres a cell.
    pass_distance : float
        Cells.

    Returns
    -------
    ndarray of bool, shape (n,)
        True for the robots that must go slowly.
    """
    if len(p) < 2 or not (_nearest(p) / cell_size < max(pass_distance, FOLLOW_DISTANCE)):
        return np.zeros(len(p), dtype=bool)  # the usual tick: nobody near anybody
    dist, bearing, oncoming = _others(p, cell_size)
    ahead = bearing < np.radians(AHEAD_BEARING)
    return (ahead & np.where(oncoming, dist < pass_distance, dist < FOLLOW_DISTANCE)).any(axis=1)


def in_company(p: np.ndarray, cell_size: float, distance: float) -> np.ndarray:
    """Robots that keep right.

    Another robot coming the other way less than ``distance`` cells ahead or alongside (within
    :data:`~mirl.world.game.KEEP_RIGHT_BEARING`, so that it keeps right until they have passed).
    A robot followed or led by another stays in the middle.

    Parameters
    ----------
    p : ndarray of shape (n, 3)
        True poses (x, y, yaw), one row a robot.
    cell_size : float
        Metres a cell.
    distance : float
        Cells.

    Returns
    -------
    ndarray of bool, shape (n,)
        True for the robots that keep right.
    """
    if len(p) < 2 or not (_nearest(p) / cell_size < distance):
        return np.zeros(len(p), dtype=bool)
    dist, bearing, oncoming = _others(p, cell_size)
    return ((bearing < np.radians(KEEP_RIGHT_BEARING)) & oncoming & (dist < distance)).any(axis=1)


def _nearest(p: np.ndarray) -> float:
    """The smallest distance between two of the poses ``p`` (m)."""
    d = np.hypot(p[None, :, 0] - p[:, None, 0], p[None, :, 1] - p[:, None, 1])
    np.fill_diagonal(d, np.inf)
    return float(d.min())


class Controller:
    """Wheel speeds for ``n`` differential-drive robots from their estimated poses (module doc).

    Parameters
    ----------
    n : int
        The number of robots.
    robot : Kobuki, default KOBUKI
        The robots' build: their wheels' separation and radius and a wheel's speed limit
        (a command beyond it is scaled down, both wheels alike).
    max_speed : float
        Cruise speed, m/s.
    max_accel : float
        Acceleration limit, m/s².
    turn_speed : float
        Pivot rate limit, rad/s.
    dt : float
        Seconds a control tick.
    arrive : float, default 0.06
        Metres from the target point within which a driving robot aligns its heading.
    k_heading : float, default 2.5
        The turn rate's gain on the heading error, 1/s.
    pass_speed : float, default 0.2
        The speed cap (m/s) on a robot :func:`crowded` by another.
    turn_first : float, default radians(20)
        Radians of bearing error beyond which a driving robot turns in place.
    """

    def __init__(
        self,
        n: int,
        robot: Kobuki = KOBUKI,
        *,
        max_speed: float,
        max_accel: float,
        turn_speed: float,
        dt: float,
        arrive: float = 0.06,
        k_heading: float = 2.5,
        pass_speed: float = 0.2,
        turn_first: float = np.radians(20),
    ) -> None:
        self.turn_first = turn_first
        self.pass_speed = pass_speed
        self.n = n
        self.sep, self.r = robot.wheel_separation, robot.wheel_radius
        self.vmax, self.amax, self.wturn = max_speed, max_accel, turn_speed
        self.wheel_max = robot.max_wheel_speed * robot.wheel_radius  # m/s at the rim
        self.dt, self.arrive, self.kh = dt, arrive, k_heading
        self.mode = np.full(n, HOLD)
        self.tx = np.zeros(n)
        self.ty = np.zeros(n)
        self.tyaw = np.zeros(n)
        self.lane = np.zeros(n)  # m to the right of the target while in company
        self.v = np.zeros(n)  # commanded forward speed (acceleration-limited)

    def set_targets(self, idx, mode, tx, ty, tyaw, lane=0.0) -> None:
        """Targets of robots ``idx`` for this decision step.

        Parameters
        ----------
        idx : int, slice or array_like of int
            The robots.
        mode : int or array_like of int
            ``DRIVE``, ``PIVOT`` or ``HOLD`` (this module's constants).
        tx : float or array_like
            The target point's x on the centre line (m).
        ty : float or array_like
            Its y (m).
        tyaw : float or array_like
            The target heading (rad).
        lane : float or array_like, default 0.0
            Metres to the right of the target point that the robot keeps while in company.
        """
        self.mode[idx], self.tx[idx], self.ty[idx], self.tyaw[idx] = mode, tx, ty, tyaw
        self.lane[idx] = lane

    def wheel_speeds(self, x, y, yaw, slow=None, company=None) -> np.ndarray:
        """Wheel angular velocities for the estimated poses, one control tick.

        Parameters
        ----------
        x : ndarray of shape (n,)
            Estimated x (m).
        y : ndarray of shape (n,)
            Estimated y (m).
        yaw : ndarray of shape (n,)
            Estimated yaw (rad).
        slow : ndarray of bool, shape (n,), optional
            Caps the forward speed at ``pass_speed`` (another robot close ahead).
        company : ndarray of bool, shape (n,), optional
            Moves the target point into the keep-right lane.

        Returns
        -------
        ndarray of shape (n, 2)
            (left, right) wheel angular velocities, rad/s.
        """
        lane = 0.0 if company is None else np.where(company, self.lane, 0.0)  # None: nobody near
        tx = self.tx + lane * np.sin(self.tyaw)
        ty = self.ty - lane * np.cos(self.tyaw)
        dx, dy = tx - x, ty - y
        d = np.hypot(dx, dy)
        bearing = wrap(np.arctan2(dy, dx) - yaw)
        arrived = d < self.arrive
        e = np.where(arrived, wrap(self.tyaw - yaw), bearing)
        drive = self.mode == DRIVE
        v_des = np.minimum(self.vmax, np.sqrt(2 * self.amax * np.maximum(d - STOP_SHORT, 0.0)))
        # heading first: slow down in proportion to the bearing error, turn in place beyond
        # ``turn_first`` (20 degrees) (a robot whose wheel cannot follow is slowed, not sent astray)
        v_des = np.where(
            drive & ~arrived, v_des * _clip(1.0 - (bearing / self.turn_first) ** 2, 0.0, 1.0), 0.0
        )
        if slow is not None:
            v_des = np.where(slow, np.minimum(v_des, self.pass_speed), v_des)
        # accelerate gently, brake as hard as needed
        self.v = np.where(v_des > self.v, np.minimum(v_des, self.v + self.amax * self.dt), v_des)
        w_drive = _clip(self.kh * e, -MAX_DRIVE_TURN, MAX_DRIVE_TURN)
        w_drive = np.where(arrived & (np.abs(e) < ALIGNED), 0.0, w_drive)
        pivot = self.mode == PIVOT
        e_turn = wrap(self.tyaw - yaw)
        w_turn = _clip(self.kh * e_turn, -self.wturn, self.wturn)
        w_turn = np.where(np.abs(e_turn) < PIVOTED, 0.0, w_turn)
        half = self.sep / 2
        vl = np.where(drive, self.v - w_drive * half, 0.0)
        vr = np.where(drive, self.v + w_drive * half, 0.0)
        # pivot on the inner wheel: left turn -> right wheel drives, right turn -> left wheel
        vl = np.where(pivot, np.where(w_turn < 0, -w_turn * self.sep, 0.0), vl)
        vr = np.where(pivot, np.where(w_turn > 0, w_turn * self.sep, 0.0), vr)
        self.v = np.where(drive, self.v, 0.0)
        big = np.maximum(np.maximum(np.abs(vl), np.abs(vr)) / self.wheel_max, 1.0)
        return np.stack((vl / big, vr / big), axis=1) / self.r
