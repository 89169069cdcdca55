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

from mirl.physics.control import wrap

__all__ = ["Cone", "line_of_sight", "RAY_HEIGHT", "WALL_GROUP"]

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
