"""What a :class:`~mirl.physics.patrol.PhysicalWorld` recorded: the patrollers' true, believed
and observed grid states and their actions at every decision step, the true poses at every
control tick, and L's camera measurements as pose tracks."""

from __future__ import annotations

import numpy as np

from mirl.observations.poses import PoseTracks
from mirl.observations.trajectories import Trajectories
from mirl.world.domain import PatrolDomain
from mirl.world.scenario_sections import OBSERVER_NAME

__all__ = ["Records", "OBSERVER"]

OBSERVER = OBSERVER_NAME


class Records:
    """The records of one run, appended to as it goes.

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain (state indices).
    names : tuple of str
        The patrollers, in robot-index order.
    has_observer : bool
        Whether L is in the world (as robot :data:`OBSERVER`, after the patrollers).
    record_ticks : bool
        Whether :meth:`tick` keeps the poses of every control tick.
    """

    def __init__(
        self, domain: PatrolDomain, names: tuple[str, ...], has_observer: bool, record_ticks: bool
    ) -> None:
        self.domain = domain
        self.names = names
        self.has_observer = has_observer
        self.record_ticks = record_ticks
        self.true: list[np.ndarray] = []  # per decision time: (N,) true state indices
        self.believed: list[np.ndarray] = []  # (N,) states the patrollers decided from
        self.actions: list[np.ndarray] = []  # (N,) actions taken at each decision
        self.seen: list[np.ndarray] = []  # (N,) L's discretised observation (-1 unseen)
        self.seen_lateral: list[np.ndarray] = []  # (N,) their lateral offsets (NaN unseen)
        self._tick_t: list[float] = []
        self._tick_pose: list[np.ndarray] = []
        self._obs_rows: list[tuple[float, int, float, float, float]] = []

    @property
    def m(self) -> int:
        """Number of robots in the world (patrollers and L)."""
        return len(self.names) + int(self.has_observer)

    # ---- appending ---------------------------------------------------------------------
    def tick(self, time: float, poses: np.ndarray) -> None:
        """The true poses at a control tick, if ticks are kept.

        Parameters
        ----------
        time : float
            Seconds at the tick's end.
        poses : ndarray of shape (m, 3)
            The x, y, yaw of every robot.
        """
        if self.record_ticks:
            self._tick_t.append(time)
            self._tick_pose.append(poses)

    def measured(self, rows: list[tuple[float, int, float, float, float]]) -> None:
        """L's camera measurements of one decision time.

        Parameters
        ----------
        rows : list of (float, int, float, float, float)
            The t (s), robot, x, y, yaw of each measurement.
        """
        self._obs_rows.extend(rows)

    # ---- reading -----------------------------------------------------------------------
    def true_states(self) -> np.ndarray:
        """The patrollers' true states at every decision time.

        Returns
        -------
        ndarray of int, shape (T, N)
            State indices.
        """
        return np.asarray(self.true)

    def observations(self, until: int | None = None) -> Trajectories:
        """What L saw, discretised, as grid observations.

        Parameters
        ----------
        until : int, optional
            The last decision time included; all by default.

        Returns
        -------
        Trajectories
            The observed states, with their lateral offsets.
        """
        end = len(self.seen) if until is None else until + 1
        seen = np.asarray(self.seen[:end])
        lateral = np.asarray(self.seen_lateral[:end]).reshape(seen.shape)
        return Trajectories.from_states(self.domain, self.names, seen, lateral=lateral)

    def truth(self) -> Trajectories:
        """The patrollers' true states as grid trajectories.

        Returns
        -------
        Trajectories
            Every patroller at every decision time.
        """
        return Trajectories.from_states(self.domain, self.names, self.true_states())

    def tick_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """The true poses at every control tick.

        Returns
        -------
        times : ndarray of shape (k,)
            Seconds.
        poses : ndarray of shape (k, m, 3)
            x, y, yaw of every robot.
        """
        if not self._tick_t:
            return np.zeros(0), np.zeros((0, self.m, 3))
        return np.asarray(self._tick_t), np.asarray(self._tick_pose)

    def observed_rows(self) -> np.ndarray:
        """L's camera measurements.

        Returns
        -------
        ndarray of shape (k, 5)
            Rows t (s), robot, x, y, yaw.
        """
        return np.asarray(self._obs_rows, dtype=float).reshape(-1, 5)

    def observed_tracks(self) -> PoseTracks:
        """What L's camera measured: one noisy pose per seen patroller per decision step.

        Returns
        -------
        PoseTracks
            The measurements.
        """
        r = self.observed_rows()
        return PoseTracks(self.names, r[:, 0], r[:, 1].astype(int), r[:, 2], r[:, 3], r[:, 4],
                          source="L's camera")  # fmt: skip

    def true_tracks(self) -> PoseTracks:
        """Every robot's true pose at every control tick (L, if present, is robot ``L``).

        Returns
        -------
        PoseTracks
            The poses.
        """
        t, p = self.tick_poses()
        k, m = p.shape[:2]
        names = self.names + ((OBSERVER,) if self.has_observer else ())
        return PoseTracks(names, np.repeat(t, m), np.tile(np.arange(m), k),
                          p[:, :, 0].ravel(), p[:, :, 1].ravel(), p[:, :, 2].ravel(),
                          source="physics truth")  # fmt: skip
