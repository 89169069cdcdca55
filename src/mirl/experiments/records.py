"""What one penetration run produces: its outcome, L's path, detections and planning rounds,
as records with a JSON form (:meth:`RunResult.to_dict`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mirl.learning.models import LearnResult
from mirl.observations.trajectories import Trajectories
from mirl.planning.go import ObserverPlan

__all__ = [
    "METHODS",
    "LEARNED_METHODS",
    "OUTCOMES",
    "MAX_WAIT",
    "Detection",
    "PlanAttempt",
    "RunResult",
]

METHODS = ("mirl-t", "mirl", "known-r-t", "known-r", "dbn-em", "random", "oracle")
LEARNED_METHODS = ("mirl-t", "mirl", "known-r-t", "known-r", "dbn-em")
OUTCOMES = ("success", "detected", "timeout")
# L may wait 450 steps (15 min) after observing: with the default 300 observation steps a run
# lasts at most 25 min of robot time, the paper's limit for its physical runs
MAX_WAIT = 450


@dataclass(frozen=True)
class Detection:
    """A patroller seeing L: time, robot, the robot's (row, col, heading) and L's cell."""

    t: int
    robot: str
    robot_state: tuple[int, int, int]
    observer_cell: tuple[int, int]


@dataclass(frozen=True)
class PlanAttempt:
    """One planning round: when, the best go value in the window and the chosen go time
    (absolute; None when no go value was positive)."""

    t: int
    best_value: float
    go_time: int | None


@dataclass(frozen=True, eq=False)
class RunResult:
    """Everything about one run; :meth:`to_dict` is its JSON form."""

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
    physical: Any = None  # the mirl.physics PhysicalWorld of a --world physics run (poses, cones)

    def to_dict(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "method": self.method,
            "seed": self.seed,
            "observability": self.observability,
            "obs_steps": self.obs_steps,
            "outcome": self.outcome,
            "go_time": self.go_time,
            "plan_value": self.plan_value,
            "behavior_accuracy": self.behavior_accuracy,
            "behavior_accuracy_per_robot": self.behavior_accuracy_per_robot,
            "feature_probabilities": self.feature_probabilities,
            "timings": self.timings,
            "seen_steps": self.seen_steps,
            "plan_attempts": [
                {"t": a.t, "best_value": a.best_value, "go_time": a.go_time} for a in self.attempts
            ],
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
            **({"world": "physics", "contacts": self.physical.contacts,
                "wall_contacts": self.physical.wall_contacts}
               if self.physical is not None else {}),
        }  # fmt: skip
