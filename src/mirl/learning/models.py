"""What L knows about the patrollers after learning: per-robot models and the learning result.

These records are the interface between learning (``mirl.learning``), prediction and planning
(``mirl.planning``) and the experiments. ``oracle_models`` builds them from a scenario's truth.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from mirl.mdp import optimal_action_mask
from mirl.world.game import Equilibrium
from mirl.world.scenario import Scenario

__all__ = ["RobotModel", "LearnResult", "behavior_accuracy", "oracle_models"]


@dataclass(frozen=True, eq=False)
class RobotModel:
    """One patroller as L models it."""

    name: str
    weights: np.ndarray  # (K,) reward weights over domain.reward_feature_names
    feature_probabilities: Mapping[str, float]
    transitions: sp.csr_array  # (S·A, S)
    policy: np.ndarray  # (S,) greedy action per state
    behavior_accuracy: float | None = None  # filled in when the truth is known


@dataclass(frozen=True, eq=False)
class LearnResult:
    """Outcome of ``mirl.learning.learn``: models, chosen equilibrium, diagnostics."""

    method: str
    robots: tuple[RobotModel, ...]
    equilibrium: Equilibrium
    equilibrium_weights: tuple[float, ...] = ()  # one per candidate equilibrium
    iterations: int = 1
    label_changes: tuple[int, ...] = ()  # labels changed at each relabelling iteration
    timings: dict[str, float] = field(default_factory=dict)
    success: bool = True
    message: str = ""

    def robot(self, name: str) -> RobotModel:
        for r in self.robots:
            if r.name == name:
                return r
        raise KeyError(name)


def behavior_accuracy(scenario: Scenario, robot: int, policy: np.ndarray) -> float:
    """Share of the robot's states where ``policy`` takes an action optimal under the truth
    (SPEC §6); where the true policy has tied optimal actions, any of them counts."""
    optimal = optimal_action_mask(scenario.true_q(robot), rtol=1e-9, atol=1e-9)
    policy = np.asarray(policy, dtype=int)
    return float(optimal[np.arange(len(policy)), policy].mean())


def oracle_models(scenario: Scenario, method: str = "oracle") -> LearnResult:
    """The truth as a LearnResult: true T, true reward, true policy and played equilibrium."""
    robots = tuple(
        RobotModel(
            name=r.name,
            weights=np.asarray(r.weights, dtype=float),
            feature_probabilities=dict(r.feature_probabilities),
            transitions=scenario.true_transitions(i),
            policy=scenario.true_policy(i),
            behavior_accuracy=1.0,
        )
        for i, r in enumerate(scenario.robots)
    )
    return LearnResult(method=method, robots=robots, equilibrium=scenario.played_equilibrium)
