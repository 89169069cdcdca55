"""Cameras as cones with a line of sight: L's Kinect + blob finder (:class:`ObserverCamera`),
the patrollers' cameras (:class:`PatrollerCameras`).

A target is seen when its centre is within ``range`` of the camera, within ``fov/2`` of the
camera's yaw, and a ray from the camera to it (cast with ``mujoco.mj_ray`` at 0.3 m above the
floor, against the walls only) reaches it. Robots do not occlude each other (their bases are
lower than the ray). An *overhead* view (``cells``) sees a robot whose centre lies in one of
the given cells, for observability degrees beyond what the door camera can reach.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from mirl.physics.config import PhysicsConfig
from mirl.physics.control import wrap
from mirl.world.maps import GridMap, MapFrame

__all__ = [
    "Cone",
    "Sighting",
    "ObserverCamera",
    "PatrollerCameras",
    "line_of_sight",
    "observer_camera",
    "RAY_HEIGHT",
    "WALL_GROUP",
]

RAY_HEIGHT = 0.3
WALL_GROUP = 1  # MJCF geom group of the walls (rays test only this group)
_GROUPS = np.zeros(6, dtype=np.uint8)
_GROUPS[WALL_GROUP] = 1


@dataclass(frozen=True)
class Cone:
    """A camera's view: a field of view and a range.

    Parameters
    ----------
    fov_deg : float
        The field of view, degrees, centred on the camera's yaw.
    range : float
        Metres.
    """

    fov_deg: float
    range: float

    def inside(self, cx, cy, cyaw, px, py) -> np.ndarray:
        """Whether points (px, py) lie inside cones at (cx, cy, cyaw) (broadcast).

        Parameters
        ----------
        cx : float or ndarray
            The cameras' x (m).
        cy : float or ndarray
            Their y (m).
        cyaw : float or ndarray
            Their yaw (rad).
        px : float or ndarray
            The points' x (m).
        py : float or ndarray
            Their y (m).

        Returns
        -------
        ndarray of bool
            Within range and within half the field of view of the yaw.
        """
        dx, dy = np.asarray(px) - cx, np.asarray(py) - cy
        ang = np.abs(wrap(np.arctan2(dy, dx) - cyaw))
        return (np.hypot(dx, dy) <= self.range) & (ang <= np.radians(self.fov_deg) / 2)


def line_of_sight(model, data, x0: float, y0: float, x1: float, y1: float) -> bool:
    """No wall between (x0, y0) and (x1, y1).

    A ray cast with ``mujoco.mj_ray`` at :data:`RAY_HEIGHT` against the walls only.

    Parameters
    ----------
    model : mujoco.MjModel
        The world's model.
    data : mujoco.MjData
        Its state.
    x0 : float
        The viewer's x (m).
    y0 : float
        Its y (m).
    x1 : float
        The target's x (m).
    y1 : float
        Its y (m).

    Returns
    -------
    bool
        True when no wall lies between them.
    """
    pnt = np.array([x0, y0, RAY_HEIGHT])
    vec = np.array([x1 - x0, y1 - y0, 0.0])
    if not vec.any():
        return True
    geomid = np.array([-1], dtype=np.int32)
    dist = mujoco.mj_ray(model, data, pnt, vec, _GROUPS, 1, -1, geomid)
    return not (0.0 <= dist < 1.0)


@dataclass(frozen=True)
class Sighting:
    """A patroller seeing L.

    Parameters
    ----------
    time : float
        Seconds of simulated time.
    step : int
        The decision step.
    robot : int
        The patroller's index.
    robot_pose : (float, float, float)
        Its true pose (x, y, yaw).
    observer_pose : (float, float, float)
        L's true pose.
    """

    time: float
    step: int
    robot: int
    robot_pose: tuple[float, float, float]
    observer_pose: tuple[float, float, float]


class ObserverCamera(NamedTuple):
    """L's view: a door camera and the cells watched from overhead.

    Parameters
    ----------
    pose : (float, float, float) or None
        The door camera's pose (x, y, yaw); None when everything L may see is watched from
        overhead.
    cone : Cone or None
        Its view; None with ``pose``.
    overhead : ndarray of bool, shape (rows, cols)
        The cells watched from overhead.
    """

    pose: tuple[float, float, float] | None
    cone: Cone | None
    overhead: np.ndarray

    def sees(self, model, data, frame: MapFrame, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """Which of the robots at (px, py) L sees now.

        Those on an overhead cell, and those in the cone with a line of sight.

        Parameters
        ----------
        model : mujoco.MjModel
            The world's model.
        data : mujoco.MjData
            Its state.
        frame : MapFrame
            The map's frame.
        px : ndarray of shape (n,)
            The robots' x (m).
        py : ndarray of shape (n,)
            Their y (m).

        Returns
        -------
        ndarray of bool, shape (n,)
            Whether L sees each.
        """
        r, c = frame.cell_of(px, py)
        rows, cols = self.overhead.shape
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        seen = inside & self.overhead[np.clip(r, 0, rows - 1), np.clip(c, 0, cols - 1)]
        if self.cone is not None and self.pose is not None:
            cx, cy, cyaw = self.pose
            cand = self.cone.inside(cx, cy, cyaw, px, py) & ~seen
            for i in np.flatnonzero(cand):
                seen[i] = line_of_sight(model, data, cx, cy, px[i], py[i])
        return seen


def observer_camera(
    scenario, config: PhysicsConfig, frame: MapFrame, degree: float
) -> ObserverCamera:
    """L's view at observability ``degree``.

    Degree 1 is an overhead view of every hallway. Otherwise the camera sits at the centre of
    L's start cell looking at the first cell of the map's visibility order (east, through the
    door, on boyd2), with the configured field of view; its range reaches the farthest visible
    cell (the first round(degree·n) cells of the visibility order) that lies inside the cone,
    plus half a cell — on boyd2 at 0.14: cells (0,1)-(0,4), range 4.5 m. Visible cells outside
    the cone (around a corner) are watched by an overhead camera over just those cells.

    Parameters
    ----------
    scenario : Scenario
        The scenario: its map and L's start.
    config : PhysicsConfig
        The camera's field of view, and its range and pose if set.
    frame : MapFrame
        The map's frame.
    degree : float
        The observability, in [0, 1].

    Returns
    -------
    ObserverCamera
        L's view.
    """
    gm = scenario.map
    mask = gm.visible_mask(degree)
    if degree >= 1.0:
        return ObserverCamera(None, None, mask)
    r0, c0 = scenario.observer_start
    if config.camera_pose is not None:
        cx, cy, cyaw = config.camera_pose
        cyaw = np.radians(cyaw)
    else:
        cx, cy = frame.cell_centre(r0, c0)
        fr, fc = gm.visibility_order[0]
        fx, fy = frame.cell_centre(fr, fc)
        cyaw = float(np.arctan2(fy - cy, fx - cx))
    cells = np.argwhere(mask)
    px, py = frame.cell_centre(cells[:, 0], cells[:, 1])
    wide = Cone(config.camera_fov_deg, np.inf)
    in_cone = wide.inside(cx, cy, cyaw, px, py)
    if config.camera_range is not None:
        rng = config.camera_range
    elif in_cone.any():
        rng = float(np.hypot(px[in_cone] - cx, py[in_cone] - cy).max()) + frame.cell_size / 2
    else:
        rng = 0.0
    cone = Cone(config.camera_fov_deg, rng)
    overhead = np.zeros_like(mask)
    inside = cone.inside(cx, cy, cyaw, px, py)
    overhead[cells[~inside, 0], cells[~inside, 1]] = True
    return ObserverCamera((float(cx), float(cy), float(cyaw)), cone, overhead)


class PatrollerCameras:
    """The patrollers' cameras, looking for L once it has left its room, and what they saw.

    Parameters
    ----------
    cone : Cone
        Every patroller's view, centred on its heading.
    gridmap : GridMap
        The map; L is in its room while on one of its ``observer_only`` cells (or off the map).
    n : int
        Number of patrollers: poses ``0 .. n-1`` are theirs, pose ``n`` is L's.
    """

    def __init__(self, cone: Cone, gridmap: GridMap, n: int) -> None:
        self.cone = cone
        self.map = gridmap
        self.n = n
        self.sightings: list[Sighting] = []
        self.observer_out = False  # L outside its room at the last look

    def look(self, model, data, p: np.ndarray, step: int) -> None:
        """Look for L with true poses ``p`` at decision step ``step``.

        Every patroller with L inside its cone and a line of sight adds a :class:`Sighting`.

        Parameters
        ----------
        model : mujoco.MjModel
            The world's model.
        data : mujoco.MjData
            Its state.
        p : ndarray of shape (n+1, 3)
            True poses (x, y, yaw), the patrollers' then L's.
        step : int
            The decision step.
        """
        L = p[self.n]
        r, c = self.map.frame.cell_of(L[0], L[1])
        rows, cols = self.map.shape
        in_room = not (0 <= r < rows and 0 <= c < cols) or bool(self.map.observer_only[r, c])
        self.observer_out = not in_room
        if in_room:
            return
        P = p[: self.n]
        cand = self.cone.inside(P[:, 0], P[:, 1], P[:, 2], L[0], L[1])
        for i in np.flatnonzero(cand):
            if line_of_sight(model, data, P[i, 0], P[i, 1], L[0], L[1]):
                rx, ry, ryaw = map(float, P[i])
                lx, ly, lyaw = map(float, L)
                self.sightings.append(
                    Sighting(float(data.time), step, int(i), (rx, ry, ryaw), (lx, ly, lyaw))
                )
