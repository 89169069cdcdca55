"""What the physics makes of the grid's actions: effective success rates, speeds, turn rates.

The physical world has no success probabilities; :func:`calibrate` measures them. Patrollers
patrol with the ground-truth actions known (those their controllers executed), and a step
(s_t, a_t → s_{t+1}) succeeds when the robot's true pose at t+1 discretises to ψ(s_t, a_t),
s_t being the discretised true pose at t. Rates are reported for every step and for steps with
no other robot within ``alone`` cells (the robot's own physics, without waiting and slow
passing). Speeds are the true distance per forward step; turn rates the peak yaw rate over the
control ticks of a turn step. A failed step ends where the robot stayed, in another action's
intended state (what Eq. 5's uniform error model says), or elsewhere (``failure_ends``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mirl.physics.patrol import PhysicalWorld
from mirl.physics.records import Records
from mirl.world.domain import ACTIONS

MOVING = ("forward", "turn_left", "turn_right")

__all__ = [
    "Calibration",
    "Meeting",
    "calibrate",
    "head_on_meeting",
    "open_loop",
    "FORWARD_SUCCESS_RATIO",
    "wheel_success",
    "damaged_wheels",
    "weakened_wheels",
]

FORWARD_SUCCESS_RATIO = {
    0.5: 0.450, 0.6: 0.566, 0.7: 0.703, 0.75: 0.866, 0.8: 0.965, 0.85: 0.988, 0.9: 1.0, 0.95: 1.0,
}  # fmt: skip
"""Motor strength -> a robot's forward steps' success driving alone over a healthy robot's in the
same runs: what the weak wheel's success probability is, in ξ's terms, over its healthy level
(forward steps need both wheels). Measured with ``python benchmarks/calibrate_strength.py``
(boyd2-healthy, each robot's either motor in turn, seeds 100–101, 300 steps; MuJoCo 3.17.0;
docs/results.md, "Fault verdicts")."""


def wheel_success(strength: float, healthy: float) -> float:
    """The success probability, in ξ's terms, of a wheel whose motor has ``strength``.

    Parameters
    ----------
    strength : float
        The motor's strength, a fraction of a full motor's torque in [0, 1] (values outside
        are clamped to the ends by the interpolation).
    healthy : float
        The wheel's healthy success probability.

    Returns
    -------
    float
        ``healthy`` × the measured ratio (:data:`FORWARD_SUCCESS_RATIO`), interpolated linearly
        between the strengths measured: 0 for a dead motor and ``healthy`` for a full one.
    """
    known = sorted(FORWARD_SUCCESS_RATIO.items())
    x = [0.0, *(k for k, _ in known), 1.0]
    y = [0.0, *(v for _, v in known), 1.0]
    return float(healthy * np.interp(float(strength), x, np.minimum(y, 1.0)))


def damaged_wheels(scenario) -> dict[str, tuple[str, ...]]:
    """Per robot, the wheels damaged by their effect.

    A wheel is damaged when its motor's strength makes its success probability
    (:func:`wheel_success`) lie below its healthy level by more than the scenario's margin
    (``scenario.faults``) — as on the grid, not whenever a motor is weaker than a full one.

    Parameters
    ----------
    scenario : Scenario
        A scenario of the physical world (its ``[physics]`` section sets the motors'
        strengths; its ``[faults]`` the healthy levels and margin).

    Returns
    -------
    dict of str to tuple of str
        Each robot's name -> its damaged wheels, of :data:`~mirl.world.faults.WHEELS`, in that
        order (empty for a healthy robot).
    """
    from mirl.physics.config import WHEELS, scenario_physics

    cfg, faults = scenario_physics(scenario), scenario.faults
    return {
        r: tuple(
            w for w in WHEELS
            if faults.damaged(w, wheel_success(cfg.strength(r, w), faults.healthy_level(w)))
        )
        for r in scenario.robot_names
    }  # fmt: skip


def weakened_wheels(scenario) -> dict[str, tuple[str, ...]]:
    """Per robot, the wheels whose motor is weaker than a full one yet not damaged by its effect.

    Parameters
    ----------
    scenario : Scenario
        A scenario of the physical world.

    Returns
    -------
    dict of str to tuple of str
        Each robot's name -> its wheels whose strength is below 1 but which
        :func:`damaged_wheels` does not count as damaged: weakened, their moves unaffected.
    """
    from mirl.physics.config import WHEELS, scenario_physics

    cfg, damaged = scenario_physics(scenario), damaged_wheels(scenario)
    return {
        r: tuple(w for w in WHEELS if cfg.strength(r, w) < 1.0 and w not in damaged[r])
        for r in scenario.robot_names
    }


@dataclass
class Calibration:
    """What :func:`calibrate` counted over its patrols.

    Parameters
    ----------
    robot_names : tuple of str
        The scenario's robots, in its order (the first axis of the arrays below).
    counts : ndarray of int, shape (n_robots, n_actions, 2)
        Per robot and action (in :data:`~mirl.world.actions.ACTIONS`' order), the steps taken
        and those that succeeded.
    counts_alone : ndarray of int, shape (n_robots, n_actions, 2)
        The same over the steps with no other robot within ``alone`` cells at either end.
    failure_ends : ndarray of int, shape (n_robots, n_actions, 3)
        Per robot and action, the failed steps that stayed put, that reached another action's
        intended state, and that ended elsewhere.
    forward_speed : list of list of float
        Per robot, the true speed (m/s) of each forward step taken alone.
    turn_rate : list of dict of str to list of float
        Per robot and turn (``"turn_left"``, ``"turn_right"``), the peak yaw rate (deg/s) of
        each turn step taken alone.
    contacts : int, default 0
        Robot-robot contact events over all patrols.
    wall_contacts : int, default 0
        Robot-wall contact events over all patrols.
    steps : int, default 0
        Decision steps simulated, summed over patrols.
    sim_seconds : float, default 0.0
        Simulated time (s), summed over patrols.
    cpu_seconds : float, default 0.0
        Process CPU time (s) the patrols took.
    transitions : list of ndarray of int, shape (steps - 1, 3)
        What a learner with the true actions gets: per patrol and robot, (s, a, s') of every
        step, in true discretised states.
    records : list of Records
        Each patrol's record (true and believed states, actions, what L's camera saw).
    """

    robot_names: tuple[str, ...]
    # [robot][action] -> [trials, successes] (all steps) and (steps alone)
    counts: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 2), dtype=int))
    counts_alone: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 2), dtype=int))
    # [robot][action] -> failed steps that [stayed put, reached another action's intended state,
    # ended elsewhere]
    failure_ends: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 3), dtype=int))
    forward_speed: list[list[float]] = field(default_factory=list)  # m/s, alone forward steps
    turn_rate: list[dict[str, list[float]]] = field(default_factory=list)  # deg/s peak per turn
    contacts: int = 0
    wall_contacts: int = 0
    steps: int = 0
    sim_seconds: float = 0.0
    cpu_seconds: float = 0.0
    # what a learner with the true actions gets: (t, robot, s, a, s') of every step
    transitions: list[np.ndarray] = field(default_factory=list)
    # each patrol's record (true and believed states, actions, what L's camera saw)
    records: list[Records] = field(default_factory=list)

    def rate(self, robot: int, action: str, *, alone: bool = False) -> tuple[float, int]:
        """A robot's success rate at an action, and the number of steps it is of.

        Parameters
        ----------
        robot : int
            The robot's index in :attr:`robot_names`.
        action : str
            An action's name, one of :data:`~mirl.world.actions.ACTIONS`.
        alone : bool, default False
            Count only the steps the robot took alone (:attr:`counts_alone`).

        Returns
        -------
        rate : float
            Successes over steps; NaN when there were no such steps.
        steps : int
            The number of such steps.

        Raises
        ------
        ValueError
            ``action`` is not an action's name.
        """
        c = (self.counts_alone if alone else self.counts)[robot, ACTIONS.index(action)]
        return (c[1] / c[0] if c[0] else float("nan")), int(c[0])

    def stayed(self, action: str | None = None) -> tuple[float, int]:
        """The share of failed steps whose robot stayed put, and how many failed steps it is of.

        Parameters
        ----------
        action : str or None, default None
            Count the failed steps of this action; None: of every moving action (forward and
            the two turns), over every robot.

        Returns
        -------
        share : float
            The failed steps that stayed put over all failed steps; NaN when none failed.
        failed : int
            The number of failed steps.
        """
        moving = [ACTIONS.index(action)] if action else [ACTIONS.index(a) for a in MOVING]
        ends = self.failure_ends[:, moving].sum(axis=(0, 1))
        return (ends[0] / ends.sum() if ends.sum() else float("nan")), int(ends.sum())


def calibrate(scenario, *, steps: int = 750, seeds=range(4), alone: int = 2, config=None,
              observability: float = 1.0) -> Calibration:  # fmt: skip
    """Run ``len(seeds)`` patrols of ``steps`` steps (random starts) and count.

    Parameters
    ----------
    scenario : Scenario
        A scenario to patrol in the physical world.
    steps : int, default 750
        The length of each patrol in states (``steps - 1`` decision steps are taken).
    seeds : sequence of int, default range(4)
        One patrol per seed.
    alone : int, default 2
        A step counts as alone when every other robot is more than this many cells away
        (Manhattan distance) at both its ends.
    config : PhysicsConfig or None, default None
        The physics; None: the scenario's own.
    observability : float, default 1.0
        The share of the map the observer sees, passed to the world.

    Returns
    -------
    Calibration
        The counts, speeds, turn rates, contacts, transitions and records of all patrols.
    """
    import time

    n = len(scenario.robots)
    dom = scenario.domain
    cal = Calibration(scenario.robot_names)
    cal.counts = np.zeros((n, len(ACTIONS), 2), dtype=int)
    cal.counts_alone = np.zeros_like(cal.counts)
    cal.failure_ends = np.zeros((n, len(ACTIONS), 3), dtype=int)
    cal.forward_speed = [[] for _ in range(n)]
    cal.turn_rate = [{"turn_left": [], "turn_right": []} for _ in range(n)]
    for seed in seeds:
        cpu = time.process_time()
        w = PhysicalWorld(scenario, config=config, seed=seed, random_starts=True,
                          observability=observability)  # fmt: skip
        for _ in range(steps - 1):
            w.step()
        cal.cpu_seconds += time.process_time() - cpu
        cal.sim_seconds += (steps - 1) * w.cfg.step_seconds
        cal.steps += steps - 1
        cal.records.append(w.records)
        cal.contacts += w.contacts
        cal.wall_contacts += w.wall_contacts
        T = w.true_states()
        A = np.asarray(w.records.actions)
        ok = dom.intended[T[:-1], A] == T[1:]
        cells = dom.states[T][:, :, :2]
        times, poses = w.tick_poses()
        k = w.cfg.ticks_per_step
        for i in range(n):
            cal.transitions.append(np.column_stack([T[:-1, i], A[:, i], T[1:, i]]))
            others = [j for j in range(n) if j != i]
            d = np.min([np.abs(cells[:, i] - cells[:, j]).sum(-1) for j in others], axis=0)
            lonely = np.minimum(d[:-1], d[1:]) > alone
            s, s_next = T[:-1, i], T[1:, i]
            end = np.where(
                s_next == s, 0, np.where((dom.intended[s] == s_next[:, None]).any(1), 1, 2)
            )
            for a in range(len(ACTIONS)):
                m = A[:, i] == a
                cal.counts[i, a] += [m.sum(), ok[m, i].sum()]
                cal.failure_ends[i, a] += np.bincount(end[m & ~ok[:, i]], minlength=3)
                cal.counts_alone[i, a] += [(m & lonely).sum(), ok[m & lonely, i].sum()]
            # ticks of step t: t*k .. (t+1)*k - 1 (tick j ends at (j + 1) / control_hz)
            P = poses[:, i].reshape(-1, k, 3)
            start = np.concatenate([poses[:1, i], poses[k - 1 :: k, i][:-1]])
            for t in np.flatnonzero(lonely):
                act = ACTIONS[A[t, i]]
                if act == "forward":
                    dist = np.hypot(*(P[t, -1, :2] - start[t, :2]))
                    cal.forward_speed[i].append(dist / w.cfg.step_seconds)
                elif act in ("turn_left", "turn_right"):
                    yaw = np.unwrap(np.concatenate([[start[t, 2]], P[t, :, 2]]))
                    rate = np.abs(np.diff(yaw)).max() * w.cfg.control_hz
                    cal.turn_rate[i][act].append(np.degrees(rate))
    return cal


def open_loop(scenario, robot: str, *, config=None) -> dict[str, float]:
    """A robot's physical abilities at full command (20 rad/s), after 1 s.

    The robot pivots on a clear stretch of the long hallway, first with only the left wheel
    driving (a right turn), then with only the right one (a left turn); the other robots are
    moved out of the way.

    Parameters
    ----------
    scenario : Scenario
        A scenario on the boyd2 map (the clear stretch is placed in its long hallway).
    robot : str
        The robot's name.
    config : PhysicsConfig or None, default None
        The physics; None: the scenario's own.

    Returns
    -------
    dict of str to float
        ``left_wheel_speed`` and ``right_wheel_speed``: the driving wheel's rim speed (m/s);
        ``turn_right_rate`` and ``turn_left_rate``: the turn rate (deg/s) over the second
        second.
    """
    import mujoco

    from mirl.physics.robot import KOBUKI

    i = scenario.robot_index(robot)
    out = {}
    for what, cmd in (("left", (1, 0)), ("right", (0, 1))):
        w = PhysicalWorld(scenario, config=config, seed=0, observer=False)
        # a clear stretch: the long hallway's middle, facing south
        a = w._qadr[i]
        w.data.qpos[a : a + 7] = [1.0, -3.0, KOBUKI.wheel_radius, np.sqrt(0.5), 0, 0,
                                  -np.sqrt(0.5)]  # fmt: skip
        for j in range(len(scenario.robots)):
            if j != i:
                b = w._qadr[j]
                w.data.qpos[b : b + 2] = [6.0 + j, -16.0]
        mujoco.mj_forward(w.model, w.data)
        w.data.ctrl[:] = 0
        w.data.ctrl[2 * i : 2 * i + 2] = np.asarray(cmd, float) * KOBUKI.max_wheel_speed
        n = int(round(1.0 / w.cfg.timestep))
        mujoco.mj_step(w.model, w.data, nstep=n)  # 1 s to reach steady state
        p0 = w.poses()[i]
        yaws = []
        for _ in range(10):
            mujoco.mj_step(w.model, w.data, nstep=n // 10)
            yaws.append(w.poses()[i, 2])
        d = w._dadr[i] + 6 + (what == "right")  # the wheel hinges follow the free joint
        out[f"{what}_wheel_speed"] = float(w.data.qvel[d] * KOBUKI.wheel_radius)
        yaw = np.unwrap(np.concatenate([[p0[2]], yaws]))
        turn = "turn_right" if what == "left" else "turn_left"
        out[f"{turn}_rate"] = float(np.degrees(abs(yaw[-1] - yaw[0])))
    return out


@dataclass(frozen=True)
class Meeting:
    """How a head-on meeting of two patrollers went (:func:`head_on_meeting`).

    Parameters
    ----------
    got_past : bool
        Whether the robots ended past each other.
    contacts : int
        Robot-robot contact events.
    wall_contacts : int
        Robot-wall contact events.
    """

    got_past: bool  # the robots ended past each other
    contacts: int  # robot-robot contact events
    wall_contacts: int

    @property
    def passed(self) -> bool:
        """Past each other without touching.

        Returns
        -------
        bool
            ``got_past`` and no robot-robot contact.
        """
        return self.got_past and self.contacts == 0


HEAD_ON_STARTS = [(4, 1, 3), (12, 1, 1)]
"""boyd2's long hallway: the first patroller at (4, 1) facing south, the second at (12, 1) facing
north, eight cells apart."""


def head_on_meeting(scenario, seed: int, *, config=None, steps: int = 10) -> Meeting:
    """Two patrollers of a boyd2-map ``scenario`` driving at each other along the long hallway
    (:data:`HEAD_ON_STARTS`) for ``steps`` decision steps: whether they got past each other, and
    the contacts on the way.

    Parameters
    ----------
    scenario : Scenario
        A scenario on the boyd2 map with at least two robots; its first two meet.
    seed : int
        The world's seed.
    config : PhysicsConfig or None, default None
        The physics; None: the scenario's own.
    steps : int, default 10
        The decision steps to drive.

    Returns
    -------
    Meeting
        Whether they got past each other and the contacts. A meeting that has not got past
        within the steps (the robots still facing each other) counts as not passed, like one
        that touched.
    """
    w = PhysicalWorld(scenario, config=config, seed=seed, starts=HEAD_ON_STARTS, observer=False,
                      record_ticks=False)  # fmt: skip
    for _ in range(steps):
        w.step()
    ys = w.poses()[:2, 1]
    return Meeting(bool(ys[0] < ys[1]), w.contacts, w.wall_contacts)
