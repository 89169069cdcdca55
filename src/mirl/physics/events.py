"""What happens between two decisions of a :class:`~mirl.physics.patrol.PhysicalWorld`, at every
control tick: which robots must slow down for another, contact events (robot–robot and
robot–wall, counted when a pair starts touching), and the patrollers' cameras looking for L once
it has left its room."""

from __future__ import annotations

import mujoco
import numpy as np

from mirl.physics.camera import Cone, Sighting, line_of_sight
from mirl.physics.config import PhysicsConfig
from mirl.physics.control import wrap
from mirl.physics.world import Frame
from mirl.world.maps import GridMap

__all__ = ["TickEvents"]


class TickEvents:
    """Mixin of :class:`~mirl.physics.patrol.PhysicalWorld` (its attributes are set there)."""

    n: int
    t: int
    map: GridMap
    frame: Frame
    cfg: PhysicsConfig
    model: mujoco.MjModel
    data: mujoco.MjData
    contacts: int
    wall_contacts: int
    contact_pairs: list[tuple[int, int, int]]
    sightings: list[Sighting]
    observer_out: bool
    _touching: set[tuple[int, int]]
    _geom_robot: np.ndarray
    _is_wall: np.ndarray
    _patrol_cone: Cone

    def poses(self) -> np.ndarray:  # pragma: no cover - provided by PhysicalWorld
        raise NotImplementedError

    def _crowded(self, p: np.ndarray) -> np.ndarray:
        """Robots that must go slowly: another robot coming the other way within
        ``pass_distance`` ahead (±70°: pass slowly), or one going the same way less than 0.8
        cell ahead (do not run into it). True poses: a real robot's bumper and laser see the
        other robot directly."""
        dx = p[None, :, 0] - p[:, None, 0]
        dy = p[None, :, 1] - p[:, None, 1]
        dist = np.hypot(dx, dy) / self.frame.cell_size
        np.fill_diagonal(dist, np.inf)
        if not (dist < max(self.cfg.pass_distance, 0.8)).any():
            return np.zeros(len(p), dtype=bool)  # the usual tick: nobody near anybody
        ahead = np.abs(wrap(np.arctan2(dy, dx) - p[:, None, 2])) < np.radians(70)
        oncoming = np.abs(wrap(p[None, :, 2] - p[:, None, 2])) > np.pi / 2
        slow = ahead & np.where(oncoming, dist < self.cfg.pass_distance, dist < 0.8)
        return slow.any(axis=1)

    def _contacts(self) -> None:
        d = self.data
        if d.ncon == 0:
            self._touching = set()
            return
        g = d.contact.geom[: d.ncon]
        ra, rb = self._geom_robot[g[:, 0]], self._geom_robot[g[:, 1]]
        if not self._touching and (ra < 0).all() and (rb < 0).all():
            return  # the usual case: wheels and casters on the floor only
        now = set()
        both = (ra >= 0) & (rb >= 0)
        for i, j in zip(ra[both], rb[both], strict=True):
            now.add((int(min(i, j)), int(max(i, j))))
        wall = ((ra >= 0) & self._is_wall[g[:, 1]]) | ((rb >= 0) & self._is_wall[g[:, 0]])
        for i in np.where(ra >= 0, ra, rb)[wall]:
            now.add((int(i), -1))
        for pair in now - self._touching:
            if pair[1] >= 0:
                self.contacts += 1
                self.contact_pairs.append((self.t, *pair))
            else:
                self.wall_contacts += 1
        self._touching = now

    def _detect(self, dt: float, p: np.ndarray | None = None) -> None:
        p = self.poses() if p is None else p
        L = p[self.n]
        r, c = self.frame.cell_of(L[0], L[1])
        rows, cols = self.map.shape
        in_room = not (0 <= r < rows and 0 <= c < cols) or bool(self.map.observer_only[r, c])
        self.observer_out = not in_room
        if in_room:
            return
        P = p[: self.n]
        cand = self._patrol_cone.inside(P[:, 0], P[:, 1], P[:, 2], L[0], L[1])
        for i in np.flatnonzero(cand):
            if line_of_sight(self.model, self.data, P[i, 0], P[i, 1], L[0], L[1]):
                rx, ry, ryaw = map(float, P[i])
                lx, ly, lyaw = map(float, L)
                self.sightings.append(
                    Sighting(float(self.data.time), self.t, int(i), (rx, ry, ryaw), (lx, ly, lyaw))
                )
