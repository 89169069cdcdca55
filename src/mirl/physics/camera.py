"""Cameras as cones with a line of sight: L's Kinect + blob finder, the patrollers' cameras.

A target is seen when its centre is within ``range`` of the camera, within ``fov/2`` of the
camera's yaw, and a ray from the camera to it (cast with ``mujoco.mj_ray`` at 0.3 m above the
floor, against the walls only) reaches it. Robots do not occlude each other (their bases are
lower than the ray). An *overhead* view (``cells``) sees a robot whose centre lies in one of
the given cells, for observability degrees beyond what the door camera can reach.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from mirl.physics.config import PhysicsConfig
from mirl.physics.control import wrap
from mirl.physics.world import Frame

__all__ = ["Cone", "Sighting", "line_of_sight", "observer_camera", "RAY_HEIGHT", "WALL_GROUP"]

RAY_HEIGHT = 0.3
WALL_GROUP = 1  # MJCF geom group of the walls (rays test only this group)
_GROUPS = np.zeros(6, dtype=np.uint8)
_GROUPS[WALL_GROUP] = 1


@dataclass(frozen=True)
class Cone:
    fov_deg: float
    range: float

    def inside(self, cx, cy, cyaw, px, py) -> np.ndarray:
        """Whether points (px, py) lie inside cones at (cx, cy, cyaw) (broadcast)."""
        dx, dy = np.asarray(px) - cx, np.asarray(py) - cy
        ang = np.abs(wrap(np.arctan2(dy, dx) - cyaw))
        return (np.hypot(dx, dy) <= self.range) & (ang <= np.radians(self.fov_deg) / 2)


def line_of_sight(model, data, x0: float, y0: float, x1: float, y1: float) -> bool:
    """No wall between (x0, y0) and (x1, y1)."""
    pnt = np.array([x0, y0, RAY_HEIGHT])
    vec = np.array([x1 - x0, y1 - y0, 0.0])
    if not vec.any():
        return True
    geomid = np.array([-1], dtype=np.int32)
    dist = mujoco.mj_ray(model, data, pnt, vec, _GROUPS, 1, -1, geomid)
    return not (0.0 <= dist < 1.0)


@dataclass(frozen=True)
class Sighting:
    """A patroller seeing L: time (s), step, robot index, both true poses (x, y, yaw)."""

    time: float
    step: int
    robot: int
    robot_pose: tuple[float, float, float]
    observer_pose: tuple[float, float, float]


def observer_camera(scenario, config: PhysicsConfig, frame: Frame, degree: float):
    """L's view at observability ``degree``: (camera pose (x, y, yaw) or None, Cone or None,
    overhead cells as a (rows, cols) bool mask).

    Degree 1 is an overhead view of every hallway. Otherwise the camera sits at the centre of
    L's start cell looking at the first cell of the map's visibility order (east, through the
    door, on boyd2), with the configured field of view; its range reaches the farthest visible
    cell (the first round(degree·n) cells of the visibility order) that lies inside the cone,
    plus half a cell — on boyd2 at 0.14: cells (0,1)-(0,4), range 4.5 m. Visible cells outside
    the cone (around a corner) are watched by an overhead camera over just those cells.
    """
    gm = scenario.map
    mask = gm.visible_mask(degree)
    if degree >= 1.0:
        return None, None, mask
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
    return (float(cx), float(cy), float(cyaw)), cone, overhead
