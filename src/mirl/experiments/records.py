"""What one penetration run produces: its outcome, L's path, detections and planning rounds,
as records with a JSON form (:meth:`RunResult.to_dict`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from mirl.experiments.options import RunProtocol
from mirl.learning.results import LearnResult
from mirl.observations.trajectories import Trajectories
from mirl.planning.go import ObserverPlan
from mirl.worlds import DEFAULT_WORLD, Detection

if TYPE_CHECKING:
    from mirl.worlds import WorldExtras

__all__ = [
    "Detection",
    "PlanAttempt",
    "Relearn",
    "RunResult",
]


@dataclass(frozen=True)
class PlanAttempt:
    """One planning round: when, the best go value in the window and the chosen go time.

    .. versionchanged:: 0.2.0
       ``predicted_success`` is the posterior-averaged chance; the point models' is
       ``predicted_success_point``.

    Parameters
    ----------
    t : int
        The step the round planned at.
    best_value : float
        The best go value in the planning window.
    go_time : int or None
        The chosen go time (an absolute step; None when no go value was positive).
    predicted_success : float, optional
        The adaptive rule's P(success) of going now, averaged over model sets drawn from the
        posterior of L's models (None under the value rule and when L waits).
    predicted_success_interval : tuple of (float, float), optional
        The 5 % and 95 % quantiles of the per-draw chances.
    predicted_success_point : float, optional
        The point models' exact P(success) along the same plan.
    predicted_success_averaged : float, optional
        The posterior-averaged chance before the method's held-out calibration (None when the
        method has none: ``predicted_success`` is then that average).
    predicted_success_interval_averaged : tuple of (float, float), optional
        The per-draw quantiles before the calibration (None when the method has none).
    """

    t: int
    best_value: float
    go_time: int | None
    predicted_success: float | None = None  # the adaptive rule: P(success) of going now
    predicted_success_interval: tuple[float, float] | None = None
    predicted_success_point: float | None = None
    predicted_success_averaged: float | None = None  # before calibration (None: uncalibrated)
    predicted_success_interval_averaged: tuple[float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The round's JSON form (the ``predicted_success`` keys only when set).

        Returns
        -------
        dict
            ``t``, ``best_value``, ``go_time``, ``predicted_success``,
            ``predicted_success_interval``, ``predicted_success_point``,
            ``predicted_success_averaged`` and ``predicted_success_interval_averaged``.
        """
        return {
            "t": self.t,
            "best_value": self.best_value,
            "go_time": self.go_time,
            **_if_set(
                predicted_success=self.predicted_success,
                predicted_success_interval=_listed(self.predicted_success_interval),
                predicted_success_point=self.predicted_success_point,
                predicted_success_averaged=self.predicted_success_averaged,
                predicted_success_interval_averaged=_listed(
                    self.predicted_success_interval_averaged
                ),
            ),
        }


@dataclass(frozen=True)
class Relearn:
    """One re-learn while L waited: when, on how many observed steps (both ends seen, summed
    over the patrollers), and what it changed to — the feature probabilities, each robot's fault
    verdict in words (for methods that give one), the behaviour accuracy (mean over the
    patrollers) — and its wall time.

    Parameters
    ----------
    t : int
        The step it re-learned at.
    observed_steps : int
        Observed steps with both ends seen, summed over the patrollers.
    feature_probabilities : dict of str to dict of str to float
        Per robot, per feature, the learned success probability.
    verdicts : dict of str to str
        Per robot, its fault verdict's sentence (empty for methods that give none).
    behavior_accuracy : float or None
        The learned policies' behaviour accuracy, the mean over the patrollers (None without a
        truth to score against).
    seconds : float
        Its wall time (not in the JSON form, which is the same for the same seed).
    """

    t: int
    observed_steps: int
    feature_probabilities: dict[str, dict[str, float]]
    verdicts: dict[str, str]
    behavior_accuracy: float | None
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """The re-learn's JSON form (its wall time left out).

        Returns
        -------
        dict
            ``t``, ``observed_steps``, ``feature_probabilities``, ``verdicts`` and
            ``behavior_accuracy``.
        """
        return {
            "t": self.t,
            "observed_steps": self.observed_steps,
            "feature_probabilities": self.feature_probabilities,
            "verdicts": self.verdicts,
            "behavior_accuracy": self.behavior_accuracy,
        }


@dataclass(frozen=True, eq=False)
class RunResult:
    """Everything about one run; :meth:`to_dict` is its JSON form (``mirl run --json``).

    Parameters
    ----------
    scenario : str
        The scenario's name.
    method : str
        The method's name (a row of :data:`~mirl.learning.methods.METHODS`).
    seed : int
        The run's seed.
    observability : float
        The share of the hallway L saw from its room.
    obs_steps : int
        Steps L observed before it could go.
    outcome : {"success", "detected", "timeout"}
        How the run ended.
    go_time : int or None
        The absolute step at which L left its start cell (None: it never went).
    plan_value : float or None
        The go value of the executed plan.
    behavior_accuracy : float or None
        The learned policies' behaviour accuracy, the mean over the patrollers.
    behavior_accuracy_per_robot : dict of str to float
        The same per robot.
    feature_probabilities : dict of str to dict of str to float
        Per robot, per feature, the learned success probability (empty for methods that learn
        none).
    timings : dict of str to float
        Wall seconds per phase (observe, learn, plan, execute), their total and the CPU time.
    observer_path : ndarray of shape (n, 4)
        L's (t, row, col, heading) from its go time on.
    detections : tuple of Detection
        The patrollers that saw L, and where.
    true_states : ndarray of shape (end_time + 1, N)
        The patrollers' true state indices at every step.
    observations : Trajectories
        Everything L saw from its room.
    attempts : tuple of PlanAttempt
        The planning rounds, in order.
    robot_names : tuple of str
        The patrollers' names.
    end_time : int
        The run's last step.
    learned : LearnResult, optional
        The models L planned with (None for a method that learns nothing to report).
    plan : ObserverPlan, optional
        The executed (or last) plan.
    seen_steps : dict of str to int, default {}
        Per patroller, the steps L saw it on while observing.
    extras : WorldExtras, optional
        What the run's world records beyond the contract (the physical world's contacts).
    predicted_success : float, optional
        The adaptive rule's P(success) at the go time, averaged over model sets drawn from the
        posterior of L's models (docs/design.md, "The stated chance").
    relearns : tuple of Relearn, optional
        The re-learns while L waited (None: L learned once).
    protocol : RunProtocol, optional
        How the run went (None: a record made by hand).
    world : str, default "grid"
        The run's world, a name in :data:`~mirl.worlds.WORLDS`.
    predicted_success_interval : tuple of (float, float), optional
        The 5 % and 95 % quantiles of the per-draw chances at the go time.
    predicted_success_point : float, optional
        The point models' exact P(success) at the go time.
    predicted_success_averaged : float, optional
        The posterior-averaged chance at the go time before the method's held-out calibration
        (None when the method has none).
    predicted_success_interval_averaged : tuple of (float, float), optional
        The per-draw quantiles at the go time before the calibration (None when the method
        has none).
    filter_fallbacks : int, optional
        The steps, up to the go time (or the deadline), on which what L saw had probability
        ~0 under the models it planned with, so that its belief took each robot's sighting
        alone (:attr:`~mirl.planning.belief.BeliefFilter.fallbacks`; per robot in a factored
        belief). None for a run that kept no belief (the random baseline).
    """

    scenario: str
    method: str
    seed: int
    observability: float
    obs_steps: int
    outcome: str
    go_time: int | None  # absolute step at which L left its start cell
    plan_value: float | None  # go value of the executed plan
    behavior_accuracy: float | None  # mean over robots
    behavior_accuracy_per_robot: dict[str, float]
    feature_probabilities: dict[str, dict[str, float]]
    timings: dict[str, float]  # wall s per phase (observe, learn, plan, execute), total, cpu
    observer_path: np.ndarray  # (n, 4): t, row, col, heading of L from its go time
    detections: tuple[Detection, ...]
    true_states: np.ndarray  # (end_time + 1, N) patroller state indices
    observations: Trajectories  # everything L saw from its room
    attempts: tuple[PlanAttempt, ...]
    robot_names: tuple[str, ...]
    end_time: int
    learned: LearnResult | None = None
    plan: ObserverPlan | None = None  # the executed (or last) plan
    seen_steps: dict[str, int] = field(default_factory=dict)  # observation-phase sightings
    extras: WorldExtras | None = None  # what the run's world records beyond the interface
    predicted_success: float | None = None  # the adaptive rule's P(success) at the go time
    relearns: tuple[Relearn, ...] | None = None  # None: L learned once
    protocol: RunProtocol | None = None  # how the run went (None: a record made by hand)
    world: str = DEFAULT_WORLD  # the run's world, a name in mirl.worlds.WORLDS
    predicted_success_interval: tuple[float, float] | None = None  # per-draw 5–95 % quantiles
    predicted_success_point: float | None = None  # the point models' chance at the go time
    predicted_success_averaged: float | None = None  # before calibration (None: uncalibrated)
    predicted_success_interval_averaged: tuple[float, float] | None = None  # ditto
    filter_fallbacks: int | None = None  # sightings L's models gave probability ~0

    @property
    def never_seen(self) -> tuple[str, ...]:
        """The patrollers L had not seen once when it went (when it never went, by the end of
        the run): its models of them are borrowed, not learned, and the chance it states takes
        each to be somewhere out of its view, which nothing it saw can check (docs/design.md,
        "A robot L never saw")."""
        obs = self.observations
        until = self.go_time if self.go_time is not None else self.end_time
        seen = set(obs.robot[obs.t <= until].tolist())
        return tuple(n for i, n in enumerate(self.robot_names) if i not in seen)

    @property
    def watch_until_seen(self) -> int | None:
        """The protocol's watching rule (None: a fixed observation time)."""
        return None if self.protocol is None else self.protocol.watch_until_seen

    def to_dict(self) -> dict[str, Any]:
        """The run's JSON form, ``mirl run --json``'s (optional keys absent when unset).

        Returns
        -------
        dict
            The fields above (the learned models as their ``feature_intervals``,
            ``verdicts`` and ``lateral_drifts`` where a method gives them; the plan and the
            observations left out), the detections and plan rounds as lists, the world's
            extras, ``never_seen`` (:attr:`never_seen`) where L stated a chance and it is
            not empty, and ``filter_fallbacks`` where L kept a belief.
        """
        return {
            "scenario": self.scenario,
            "method": self.method,
            "seed": self.seed,
            "observability": self.observability,
            "obs_steps": self.obs_steps,
            **_if_set(watch_until_seen=self.watch_until_seen),
            "outcome": self.outcome,
            "go_time": self.go_time,
            "plan_value": self.plan_value,
            **_if_set(
                predicted_success=self.predicted_success,
                predicted_success_interval=_listed(self.predicted_success_interval),
                predicted_success_point=self.predicted_success_point,
                predicted_success_averaged=self.predicted_success_averaged,
                predicted_success_interval_averaged=_listed(
                    self.predicted_success_interval_averaged
                ),
                never_seen=(list(self.never_seen) or None)
                if self.predicted_success is not None
                else None,
                filter_fallbacks=self.filter_fallbacks,
            ),
            "behavior_accuracy": self.behavior_accuracy,
            "behavior_accuracy_per_robot": self.behavior_accuracy_per_robot,
            "feature_probabilities": self.feature_probabilities,
            **_uncertainty(self.learned),
            "timings": self.timings,
            "seen_steps": self.seen_steps,
            "plan_attempts": [a.to_dict() for a in self.attempts],
            **_if_set(
                relearns=None if self.relearns is None else [r.to_dict() for r in self.relearns]
            ),
            "detections": [
                {
                    "t": d.t,
                    "robot": d.robot,
                    "robot_state": list(d.robot_state),
                    "observer_cell": list(d.observer_cell),
                }
                for d in self.detections
            ],
            "observer_path": self.observer_path.tolist(),
            "end_time": self.end_time,
            **(self.extras.to_dict() if self.extras is not None else {}),
        }


def _uncertainty(learned: LearnResult | None) -> dict[str, Any]:
    """``feature_intervals`` and ``verdicts`` per robot, for models that have them, and
    ``lateral_drifts`` for the robots whose poses gave one."""
    robots = [r for r in learned.robots if r.verdict is not None] if learned is not None else []
    if not robots:
        return {}
    return {
        "feature_intervals": {
            r.name: {
                f: [round(float(lo), 4), round(float(hi), 4)]
                for f, (lo, hi) in r.feature_intervals.items()
            }
            for r in robots
        },
        "verdicts": {r.name: r.verdict.to_dict() for r in robots if r.verdict is not None},
        **_if_set(
            lateral_drifts={
                r.name: r.lateral_drift.to_dict() for r in robots if r.lateral_drift is not None
            }
            or None
        ),
    }


def _listed(pair: tuple[float, float] | None) -> list[float] | None:
    """A pair as a JSON list (None stays None)."""
    return None if pair is None else [float(v) for v in pair]


def _if_set(**values: Any) -> dict[str, Any]:
    """The entries whose value is not None (optional JSON keys stay absent by default)."""
    return {k: v for k, v in values.items() if v is not None}
