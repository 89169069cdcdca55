"""What L knows about the patrollers after learning: per-robot models and the learning result.

These records are the interface between learning (``mirl.learning``), prediction and planning
(``mirl.planning``) and the experiments. ``oracle_models`` builds them from a scenario's truth.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from mirl.learning.verdicts import FeatureUncertainty, LateralDrift, Verdict, point_verdict
from mirl.mdp import optimal_action_mask
from mirl.world.game import Equilibrium
from mirl.world.scenario import Scenario

__all__ = [
    "RobotModel",
    "LearnResult",
    "behavior_accuracy",
    "ObservedAgreement",
    "observed_agreement",
    "oracle_models",
]


@dataclass(frozen=True, eq=False)
class RobotModel:
    """One patroller as L models it.

    Parameters
    ----------
    name : str
        The robot's name in the scenario.
    weights : ndarray of shape (K,)
        Reward weights over ``domain.reward_feature_names``.
    feature_probabilities : mapping of str to float
        Success probability of each transition feature; empty for methods whose T has none
        (one success probability ``p``, DBN-EM).
    transitions : sparse array of shape (S·A, S)
        The transition model, CSR, row ``s·A + a`` being T(s, a, ·).
    policy : ndarray of shape (S,)
        The greedy action in each state.
    behavior_accuracy : float or None
        Share of states where ``policy`` is optimal under the truth (docs/design.md, "Behaviour
        accuracy"); None when the truth was not used to score it.
    feature_intervals : mapping of str to (float, float)
        The 95 % interval of each feature probability (docs/design.md, "Fault verdicts");
        empty where ``feature_probabilities`` is.
    verdict : Verdict or None
        Which part is damaged and how sure L is; None for methods without feature
        probabilities.
    lateral_drift : LateralDrift or None
        The robot's mean lateral offset on its forward steps, from poses (None: grid states,
        or too few steps), which the verdict weighs.
    uncertainty : FeatureUncertainty or None
        Everything the verdict was drawn from: the posterior medians, the motion models'
        weights, the parts the steps cannot tell apart (None where ``verdict`` is).
    motion_model : str
        The motion model ``transitions`` were learned under
        (:class:`~mirl.learning.motion_models.MotionModel` names; ``""`` for a T not made of
        features): the one L plans with.

        .. versionchanged:: 0.2.0
           ``uncertainty`` and ``motion_model`` are new.
    """

    name: str
    weights: np.ndarray
    feature_probabilities: Mapping[str, float]
    transitions: sp.csr_array
    policy: np.ndarray
    behavior_accuracy: float | None = None
    feature_intervals: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    verdict: Verdict | None = None
    lateral_drift: LateralDrift | None = None
    uncertainty: FeatureUncertainty | None = None
    motion_model: str = ""


@dataclass(frozen=True, eq=False)
class LearnResult:
    """Outcome of :func:`mirl.learning.learn.learn`: the models, the equilibrium the robots
    were learned to play, and diagnostics.

    Parameters
    ----------
    method : str
        The method that built the models (a name of :data:`mirl.learning.methods.METHODS`).
    robots : tuple of RobotModel
        One model per patroller, in the scenario's order.
    equilibrium : Equilibrium
        The interaction equilibrium the team plays (the best weighed one, or the truth).
    equilibrium_weights : tuple of float
        Posterior weight of each candidate equilibrium of the game; empty when not weighed.
    iterations : int
        Rounds of labelling run (one for the methods that do not relabel).
    label_changes : tuple of int
        Labels changed by each relabelling.
    timings : dict of str to float
        Wall time per phase, in seconds, and ``"total"``.
    success : bool
        Whether learning converged (the labels settled, for ``mirl-t``).
    message : str
        How it ended, and notes (e.g. the fixed success probability, robots never observed).
    pair_equilibria : mapping of (int, int) to Equilibrium
        Per pair (i < j, i the row player), the equilibrium it was learned to play; pairs not
        listed play ``equilibrium``.
    horizon : int or None
        The time steps of the record the models were learned from (t < horizon); None for
        models not learned from a record (the truth, hand-made models).
    """

    method: str
    robots: tuple[RobotModel, ...]
    equilibrium: Equilibrium
    equilibrium_weights: tuple[float, ...] = ()
    iterations: int = 1
    label_changes: tuple[int, ...] = ()
    timings: dict[str, float] = field(default_factory=dict)
    success: bool = True
    message: str = ""
    pair_equilibria: Mapping[tuple[int, int], Equilibrium] = field(default_factory=dict)
    horizon: int | None = None

    def pair_equilibrium(self, i: int, j: int) -> Equilibrium:
        """The equilibrium robots ``i`` < ``j`` play.

        Parameters
        ----------
        i, j : int
            The robots' indices, ``i`` < ``j`` (``i`` the row player).

        Returns
        -------
        Equilibrium
            The pair's own, or the team's ``equilibrium``.
        """
        return self.pair_equilibria.get((i, j), self.equilibrium)

    def robot(self, name: str) -> RobotModel:
        """The model of the robot called ``name``.

        Parameters
        ----------
        name : str
            The robot's name in the scenario.

        Returns
        -------
        RobotModel
            Its model.

        Raises
        ------
        KeyError
            If no robot has that name.
        """
        for r in self.robots:
            if r.name == name:
                return r
        names = ", ".join(r.name for r in self.robots)
        raise KeyError(f"no robot {name!r}: the robots are {names}")


def behavior_accuracy(scenario: Scenario, robot: int, policy: np.ndarray) -> float:
    """Share of the robot's states where ``policy`` takes an action optimal under the truth
    (docs/design.md, "Behaviour accuracy"); where the true policy has tied optimal actions, any of
    them counts.

    Parameters
    ----------
    scenario : Scenario
        The scenario whose truth scores the policy.
    robot : int
        The robot's index.
    policy : ndarray of shape (S,) of int
        The policy to score.

    Returns
    -------
    float
        The share, in [0, 1].
    """
    optimal = optimal_action_mask(scenario.true_q(robot), rtol=1e-9, atol=1e-9)
    policy = np.asarray(policy, dtype=int)
    return float(optimal[np.arange(len(policy)), policy].mean())


@dataclass(frozen=True)
class ObservedAgreement:
    """How a learned policy agrees with the moves L saw — the only score data without a truth
    supports (docs/design.md, "Reports on data without a truth"). A *move* is a pair of
    consecutive steps at which the robot was seen at both.

    Parameters
    ----------
    moves : int
        Observed moves.
    followed : int
        Moves to where the learned policy's action was meant to go.
    unexplained : int
        Moves to a state no action was meant to reach (explained by nothing).
    """

    moves: int  # observed moves
    followed: int  # moves to where the learned policy's action was meant to go
    unexplained: int  # moves to a state no action was meant to reach (explained by nothing)

    @property
    def share(self) -> float | None:
        """The share of the moves the policy followed (None: no move observed)."""
        return self.followed / self.moves if self.moves else None


def observed_agreement(domain, series: np.ndarray, policy: np.ndarray) -> ObservedAgreement:
    """Score ``policy`` against one robot's observed moves (``series``: (T,) states, -1 where
    unseen): how many went where its action was meant to go, and how many went where no
    action was meant to go.

    Parameters
    ----------
    domain : PatrolDomain
        The domain (its intended next states).
    series : ndarray of shape (horizon,) of int
        The robot's observed states, -1 where unseen.
    policy : ndarray of shape (S,) of int
        The learned policy.

    Returns
    -------
    ObservedAgreement
        The counts.
    """
    x = np.asarray(series, dtype=int)
    t = np.flatnonzero((x[:-1] >= 0) & (x[1:] >= 0))
    s, nxt = x[t], x[t + 1]
    intended = domain.intended[s]  # (moves, A)
    followed = intended[np.arange(len(s)), np.asarray(policy, dtype=int)[s]] == nxt
    explained = (intended == nxt[:, None]).any(axis=1)
    return ObservedAgreement(len(t), int(followed.sum()), int((~explained).sum()))


def oracle_models(scenario: Scenario, method: str = "oracle") -> LearnResult:
    """The truth as a LearnResult: true T, true reward, true policy and played equilibrium.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    method : str, default "oracle"
        The method the result is recorded under (a method that learns nothing).

    Returns
    -------
    LearnResult
        Every robot's true model (behaviour accuracy 1, intervals of zero width, the verdict
        of the true probabilities).
    """
    robots = tuple(
        RobotModel(
            name=r.name,
            weights=np.asarray(r.weights, dtype=float),
            feature_probabilities=dict(r.feature_probabilities),
            transitions=scenario.true_transitions(i),
            policy=scenario.true_policy(i),
            behavior_accuracy=1.0,
            feature_intervals={f: (float(p), float(p)) for f, p in r.feature_probabilities.items()},
            verdict=point_verdict(r.feature_probabilities, scenario.faults),
        )
        for i, r in enumerate(scenario.robots)
    )
    return LearnResult(
        method=method,
        robots=robots,
        equilibrium=scenario.played_equilibrium,
        pair_equilibria={p: scenario.pair_equilibrium(*p) for p in scenario.pairs},
    )
