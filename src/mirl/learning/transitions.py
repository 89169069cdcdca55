"""mIRL*/T: counting observed successes per feature subset, labelling observed steps with
actions, and the estimator that learns feature probabilities from occluded trajectories by
maximum entropy (Eq. 4, solved in :mod:`mirl.learning.feature_solver`). The transition function
these probabilities define (Eq. 5) is :mod:`mirl.world.motion`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mirl._estimator import EstimatorParams
from mirl.world.domain import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, PatrolDomain
from mirl.world.game import Equilibrium, game_action_to_action, meeting
from mirl.world.motion import ERROR_MODELS, transition_matrix
from mirl.world.scenario import Scenario

__all__ = [
    "observed_steps",
    "perception_labels",
    "policy_labels",
    "perceived_labels",
    "true_policy_labels",
    "count_subsets",
    "SubsetCounts",
    "TransitionFeatureLearner",
]


# ---- counting and labelling --------------------------------------------------------------------
def observed_steps(series: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every step whose both ends were observed.

    Parameters
    ----------
    series : ndarray of int, shape (horizon,)
        State indices, -1 for occluded time steps.

    Returns
    -------
    t : ndarray of int
        The steps' times.
    s : ndarray of int
        s_t.
    s_next : ndarray of int
        s_{t+1}.
    """
    series = np.asarray(series)
    t = np.flatnonzero((series[:-1] >= 0) & (series[1:] >= 0))
    return t, series[t], series[t + 1]


# Preference among actions with the same intended state: a robot that stayed put is read as
# having stopped, not as having driven into a wall.
_PERCEPTION_ORDER = (STOP, FORWARD, TURN_LEFT, TURN_RIGHT)


def perception_labels(domain: PatrolDomain, s: np.ndarray, s_next: np.ndarray) -> np.ndarray:
    """The action whose intended outcome ψ(s, a) is the observed next state (what L perceives).

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    s : ndarray of int
        States.
    s_next : ndarray of int
        The observed next states.

    Returns
    -------
    ndarray of int
        An action per step; -1 where no action explains the step (possible only with perception
        noise).
    """
    s, s_next = np.asarray(s, dtype=int), np.asarray(s_next, dtype=int)
    labels = np.full(s.shape, -1, dtype=int)
    for a in reversed(_PERCEPTION_ORDER):  # earlier entries of the order overwrite later ones
        labels[domain.intended[s, a] == s_next] = a
    return labels


def policy_labels(
    domain: PatrolDomain,
    series_list: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    equilibrium: Equilibrium,
    pair_equilibria: Mapping[tuple[int, int], Equilibrium] | None = None,
) -> list[np.ndarray]:
    """Label every observed time step of every robot with the action its policy prescribes.

    Where two robots are both observed and their intended moves meet (docs/design.md, "The
    meeting rule"), the label is the action of the equilibrium's most likely game action
    (Sec. 3.6); a robot in several meetings at one step takes its first pair's, in robot order.
    A meeting with a robot L cannot see is invisible to L, so such steps keep the policy's
    action; they may then count as failures, a bias confined to the edge of the visible region.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series_list : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    policies : sequence of ndarray of int, shape (S,)
        Each robot's (learned or true) policy.
    equilibrium : Equilibrium
        The equilibrium the robots play when they meet.
    pair_equilibria : mapping of (int, int) to Equilibrium, optional
        A pair's own equilibrium (robots i < j), where it is not ``equilibrium`` (a scenario's
        ``[[game.pairs]]``).

    Returns
    -------
    list of ndarray of int, shape (horizon,)
        Per robot the labels, -1 at unobserved steps.
    """
    series = [np.asarray(x, dtype=int) for x in series_list]
    labels = []
    for x, pol in zip(series, policies, strict=True):
        lab = np.full(x.shape, -1, dtype=int)
        seen = x >= 0
        lab[seen] = np.asarray(pol)[x[seen]]
        labels.append(lab)
    own = [lab.copy() for lab in labels]
    # a robot in several meetings at one step plays its first pair's game (design: "The meeting
    # rule"), as the simulators and filters do
    engaged = [np.zeros(x.shape, dtype=bool) for x in series]
    for i in range(len(series)):
        for j in range(i + 1, len(series)):
            both = np.flatnonzero((series[i] >= 0) & (series[j] >= 0))
            if both.size == 0:
                continue
            eq = (pair_equilibria or {}).get((i, j), equilibrium)
            game_choice = (int(np.argmax(eq.row)), int(np.argmax(eq.col)))
            met = meeting(domain, series[i][both], series[j][both], own[i][both], own[j][both])
            t = both[met]
            for k, choice in ((i, game_choice[0]), (j, game_choice[1])):
                free = t[~engaged[k][t]]
                labels[k][free] = game_action_to_action(np.full(free.size, choice), own[k][free])
                engaged[k][t] = True
    return labels


@dataclass(frozen=True)
class SubsetCounts:
    """Pooled successes and trials per distinct feature subset of the domain.

    Parameters
    ----------
    subsets : tuple of tuple of str
        The domain's distinct subsets ξ(s, a).
    successes : ndarray of int, shape (n_subsets,)
        Steps that reached their intended state.
    trials : ndarray of int, shape (n_subsets,)
        Labelled steps.
    """

    subsets: tuple[tuple[str, ...], ...]
    successes: np.ndarray
    trials: np.ndarray

    def observations(self) -> list[tuple[tuple[str, ...], int, int]]:
        """The ``(subset, successes, trials)`` triples the solver takes (observed subsets only).

        An action that uses no feature (a scenario's ``stop = []``) is a trial of no part: it
        informs no probability, and a step labelled with it that missed its intended state is
        a label the robot did not follow (L's policy said stop, the robot moved), not a failure
        of any part — so the empty subset is not passed on (the solver would refuse its
        failures as inconsistent). Its counts stay in :attr:`successes` and :attr:`trials`.

        Returns
        -------
        list of (tuple of str, int, int)
            One per non-empty subset with trials.
        """
        return [
            (sub, int(k), int(n))
            for sub, k, n in zip(self.subsets, self.successes, self.trials, strict=True)
            if n > 0 and sub
        ]


def perceived_labels(scenario: Scenario, series_list: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Per robot, every step with both ends observed labelled by perception
    (:func:`perception_labels`); a row of :data:`~mirl.learning.options.LABELLINGS`.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its domain).
    series_list : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.

    Returns
    -------
    list of ndarray of int, shape (horizon,)
        Per robot the labels, -1 where a step's two ends were not both observed.
    """
    out = []
    for x in series_list:
        lab = np.full(len(x), -1, dtype=int)
        t, s, s_next = observed_steps(x)
        lab[t] = perception_labels(scenario.domain, s, s_next)
        out.append(lab)
    return out


def true_policy_labels(scenario: Scenario, series_list: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Per robot, every observed step labelled by the scenario's true policies and played
    equilibria, each pair's own (:func:`policy_labels`; the Known R/T setting); a row of
    :data:`~mirl.learning.options.LABELLINGS`.

    Parameters
    ----------
    scenario : Scenario
        The scenario whose truth labels the steps.
    series_list : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.

    Returns
    -------
    list of ndarray of int, shape (horizon,)
        Per robot the labels, -1 at unobserved steps.
    """
    policies = [scenario.true_policy(i) for i in range(len(scenario.robots))]
    pairs = {p: scenario.pair_equilibrium(*p) for p in scenario.pairs}
    return policy_labels(
        scenario.domain, series_list, policies, scenario.played_equilibrium, pairs
    )


def count_subsets(
    domain: PatrolDomain, s: np.ndarray, a: np.ndarray, s_next: np.ndarray
) -> SubsetCounts:
    """Pool labelled steps by ξ(s, a): success when s_{t+1} = ψ(s_t, a_t).

    Unlabelled steps (a = -1) are left out. Counts are pooled, not probabilities (docs/design.md,
    "Counting").

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    s : ndarray of int
        States.
    a : ndarray of int
        Their labels, -1 for unlabelled.
    s_next : ndarray of int
        The next states.

    Returns
    -------
    SubsetCounts
        Successes and trials per subset.
    """
    s, a, s_next = (np.asarray(v, dtype=int) for v in (s, a, s_next))
    keep = a >= 0
    s, a, s_next = s[keep], a[keep], s_next[keep]
    idx = domain.subset_index[s, a]
    hit = domain.intended[s, a] == s_next
    n = len(domain.subsets)
    return SubsetCounts(
        domain.subsets,
        np.bincount(idx, weights=hit, minlength=n).astype(int),
        np.bincount(idx, minlength=n).astype(int),
    )


class TransitionFeatureLearner(EstimatorParams):
    """mIRL*/T as an estimator: transition-feature probabilities from labelled observed steps.

    By maximum entropy (Eq. 4), then the full transition function (Eq. 5).

    Parameters
    ----------
    domain : PatrolDomain
        The domain: its features ξ and intended outcomes ψ.
    error_model : {"uniform", "stop"}, default "uniform"
        Where a failed step goes in the learned T.
    method : {"maxent", "paper"}, default "maxent"
        The Eq. 4 solver (:func:`~mirl.learning.feature_solver.solve_feature_probabilities`).

    Attributes
    ----------
    counts_ : SubsetCounts
        The pooled counts.
    result_ : FeatureSolveResult
        The solver's result.
    feature_probabilities_ : dict of str to float
        The learned probability of *every* feature.
    transition_model_ : scipy.sparse.csr_array of shape (S*A, S)
        The learned T.

    Raises
    ------
    ValueError
        An unknown error model or method.
    TypeError
        A ``domain`` that is not a :class:`~mirl.world.domain.PatrolDomain`.

    .. versionchanged:: 0.2.0
        An unknown ``method`` is refused here rather than by ``fit``; ``get_params``,
        ``set_params`` and a ``repr`` of the settings (:class:`mirl._estimator.EstimatorParams`).
    """

    def __init__(
        self, domain: PatrolDomain, error_model: str = "uniform", method: str = "maxent"
    ) -> None:
        from mirl.learning.feature_solver import FEATURE_SOLVERS  # scipy.optimize: lazily

        if not isinstance(domain, PatrolDomain):  # found by fit() as an AttributeError
            raise TypeError(f"domain must be a mirl.PatrolDomain, got {type(domain)}")
        if error_model not in ERROR_MODELS:
            raise ValueError(f"unknown error model '{error_model}' (known: {ERROR_MODELS})")
        FEATURE_SOLVERS.lookup(method)  # an unknown method: refused here, not at fit
        self.domain = domain
        self.error_model = error_model
        self.method = method

    def fit(self, s: np.ndarray, a: np.ndarray, s_next: np.ndarray) -> TransitionFeatureLearner:
        """Learn the feature probabilities and T from labelled steps.

        Parameters
        ----------
        s : ndarray of int
            States, indices in [0, S).
        a : ndarray of int
            Their labels, -1 for unlabelled.
        s_next : ndarray of int
            The next states.

        Returns
        -------
        TransitionFeatureLearner
            ``self``, fitted.

        Raises
        ------
        ValueError
            Arrays of different lengths, of other than integers, or indices out of range.
        """
        from mirl.learning.feature_solver import solve_feature_probabilities

        given = [np.asarray(v) for v in (s, a, s_next)]
        for name, v in zip(("s", "a", "s_next"), given, strict=True):
            if v.size and v.dtype.kind not in "iu":  # 3.7 would be truncated to state 3
                raise ValueError(f"{name} must be integer indices, got dtype {v.dtype}")
        s, a, s_next = (v.astype(int) for v in given)
        if not (s.shape == a.shape == s_next.shape):
            raise ValueError("s, a and s_next must have the same length")
        S = self.domain.n_states
        if s.size and (s.min() < 0 or s.max() >= S or s_next.min() < 0 or s_next.max() >= S):
            raise ValueError(f"states must be indices in [0, {S})")
        if a.size and (a.min() < -1 or a.max() >= self.domain.n_actions):
            raise ValueError("actions must be indices of domain.actions (or -1 for unlabelled)")
        self.counts_ = count_subsets(self.domain, s, a, s_next)
        self.result_ = solve_feature_probabilities(
            self.domain.feature_map.features, self.counts_.observations(), method=self.method
        )
        self.feature_probabilities_ = dict(self.result_.probabilities)
        self.transition_model_ = transition_matrix(
            self.domain, self.feature_probabilities_, self.error_model
        )
        return self
