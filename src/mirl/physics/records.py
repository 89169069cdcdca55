"""What a :class:`~mirl.physics.patrol.PhysicalWorld` recorded: the patrollers' true and observed
grid states, the true poses at every control tick, and L's camera measurements as pose tracks."""

from __future__ import annotations

import numpy as np

from mirl.observations.poses import PoseTracks
from mirl.observations.trajectories import Trajectories
from mirl.physics.config import PhysicsConfig
from mirl.physics.world import Frame
from mirl.world.domain import PatrolDomain

__all__ = ["Records", "OBSERVER"]

OBSERVER = "L"


class Records:
    """Mixin of :class:`~mirl.physics.patrol.PhysicalWorld` (its attributes are set there)."""

    n: int
    m: int
    names: tuple[str, ...]
    has_observer: bool
    domain: PatrolDomain
    frame: Frame
    cfg: PhysicsConfig
    true: list[np.ndarray]
    seen: list[np.ndarray]
    _tick_t: list[float]
    _tick_pose: list[np.ndarray]
    _obs_rows: list[tuple[float, int, float, float, float]]

    def poses(self) -> np.ndarray:  # pragma: no cover - provided by PhysicalWorld
        raise NotImplementedError

    # ---- records -----------------------------------------------------------------------
    def true_states(self) -> np.ndarray:
        return np.asarray(self.true)

    def observations(self, until: int | None = None) -> Trajectories:
        seen = np.asarray(self.seen if until is None else self.seen[: until + 1])
        return Trajectories.from_states(self.domain, self.names, seen)

    def truth(self) -> Trajectories:
        return Trajectories.from_states(self.domain, self.names, self.true_states())

    def tick_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(k,) times and (k, m, 3) true poses at every control tick."""
        if not self._tick_t:
            return np.zeros(0), np.zeros((0, self.m, 3))
        return np.asarray(self._tick_t), np.asarray(self._tick_pose)

    def observed_rows(self) -> np.ndarray:
        """(k, 5) rows t (s), robot, x, y, yaw of L's camera measurements."""
        return np.asarray(self._obs_rows, dtype=float).reshape(-1, 5)

    def observed_tracks(self) -> PoseTracks:
        """What L's camera measured: one noisy pose per seen patroller per decision step."""
        r = self.observed_rows()
        return PoseTracks(self.names, r[:, 0], r[:, 1].astype(int), r[:, 2], r[:, 3], r[:, 4],
                          source="L's camera")  # fmt: skip

    def true_tracks(self) -> PoseTracks:
        """Every robot's true pose at every control tick (L, if present, is robot ``L``)."""
        t, p = self.tick_poses()
        k, m = p.shape[:2]
        names = self.names + ((OBSERVER,) if self.has_observer else ())
        return PoseTracks(names, np.repeat(t, m), np.tile(np.arange(m), k),
                          p[:, :, 0].ravel(), p[:, :, 1].ravel(), p[:, :, 2].ravel(),
                          source="physics truth")  # fmt: skip
