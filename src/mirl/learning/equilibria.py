"""Interactions: which observed steps could be meetings, and the weighing of the interaction game's
candidate equilibria by the exact likelihood of both robots' observations under the joint
dynamics (a forward filter over joint states where the equilibrium replaces the policies at
meeting states).

**Interactions.** Observed steps at which both robots are in view and *could* meet are left out of
the per-robot fit (their actions may be the game's). The candidate equilibria (all Nash equilibria
of the bimatrix) are weighed by the exact likelihood of both robots' observations under the joint
dynamics — a forward filter over the S² joint states where the equilibrium's moves replace the
policies' at meeting states (:func:`joint_log_likelihood`) — which contains the likelihood of the
evident meetings (:func:`meeting_log_likelihood`). The joint filter costs ~0.1 s per equilibrium
on boyd2 (450 steps), 10–25 times a marginal objective evaluation, so it weighs equilibria once
per learned model rather than inside the optimiser.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mirl.learning.factored_pair import factored_log_likelihood, meeting_matrix
from mirl.learning.joint_filter import JointFilter
from mirl.learning.soft_policy import _Dynamics
from mirl.world.domain import STOP, TURN_LEFT, PatrolDomain
from mirl.world.game import Equilibrium, meeting

# pair states up to which the weighing filters the exact joint (as the planner's BeliefFilter);
# above, the factored filter coupled at meetings (issue 12; error measured in docs/design.md)
MAX_JOINT_STATES = 60_000

__all__ = [
    "potential_meetings",
    "EquilibriumWeights",
    "joint_log_likelihood",
    "meeting_log_likelihood",
    "weigh_equilibria",
    "meeting_pairs",
    "TeamEquilibria",
    "weigh_team_equilibria",
]


# ---- interactions ------------------------------------------------------------------------------
def potential_meetings(domain: PatrolDomain, series_i: np.ndarray, series_j: np.ndarray):
    """(horizon,) bool: both robots observed and *some* pair of actions would make them meet.

    Used to leave game-driven steps out of the per-robot IRL without knowing the policies yet.
    """
    x, y = np.asarray(series_i), np.asarray(series_j)
    both = np.flatnonzero((x >= 0) & (y >= 0))
    out = np.zeros(len(x), dtype=bool)
    if both.size == 0:
        return out
    A = domain.n_actions
    ai, aj = np.meshgrid(np.arange(A), np.arange(A), indexing="ij")
    hit = meeting(
        domain,
        x[both][:, None],
        y[both][:, None],
        ai.ravel()[None, :],
        aj.ravel()[None, :],
    )
    out[both] = hit.any(axis=1)
    return out


def _game_actions(equilibrium_side: Sequence[float], own: np.ndarray, n_actions: int):
    """(n, A) action distribution of a robot playing ``equilibrium_side`` (go/stop/turn)."""
    p = np.asarray(equilibrium_side, dtype=float)
    out = np.zeros((len(own), n_actions))
    out[np.arange(len(own)), own] += p[0]
    out[:, STOP] += p[1]
    out[:, TURN_LEFT] += p[2]
    return out


def _robot_steps(domain, pol, transitions, equilibrium, epsilon):
    """Per robot the transposed ε-greedy policy step Pᵀ and game-move step Gᵀ, (S, S) CSR."""
    S, A = domain.n_states, domain.n_actions
    PT, GT = [], []
    for p, t, side in zip(pol, transitions, (equilibrium.row, equilibrium.col), strict=True):
        dyn = _Dynamics(sp.csr_array(t), A)
        own = np.zeros((S, A))
        own[np.arange(S), p] = 1.0
        PT.append(dyn.transposed_policy((1 - epsilon) * own + epsilon / A))
        game = _game_actions(side, p, A)
        GT.append(dyn.transposed_policy((1 - epsilon) * game + epsilon / A))
    return PT, GT


def _joint_filter(domain, policies, transitions, equilibrium, epsilon) -> JointFilter:
    S = domain.n_states
    pol = [np.asarray(p, dtype=int) for p in policies]
    PT, GT = _robot_steps(domain, pol, transitions, equilibrium, epsilon)
    si, sj = np.divmod(np.arange(S * S), S)
    meet = meeting(domain, si, sj, pol[0][si], pol[1][sj]).reshape(S, S)
    return JointFilter(PT, GT, meet)


def _condition(M: np.ndarray, x: int, visible: np.ndarray, axis: int) -> None:
    """In-place: keep only what is consistent with one robot's observation at this step."""
    view = M if axis == 0 else M.T
    if x >= 0:
        keep = view[x].copy()
        view[:] = 0.0
        view[x] = keep
    else:
        view[visible] = 0.0


def joint_log_likelihood(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    equilibrium: Equilibrium,
    visible: np.ndarray,
    *,
    epsilon: float = 1e-3,
    max_joint_states: int | None = MAX_JOINT_STATES,
) -> float:
    """log P(observations of both robots | policies, T, equilibrium), exactly.

    A forward (HMM) filter over the joint state (s_I, s_J): S² states, propagated as an S × S
    matrix M ← P_Iᵀ (M off meetings) P_J + the equilibrium's joint moves at meeting states, then
    conditioned on what L saw (the observed state, or "somewhere not visible"). Policies are the
    greedy ones mixed with ε of uniform actions so that no observation has probability 0.
    Above ``max_joint_states`` pair states (None: never) the robots are filtered on their own
    and coupled at meetings (:mod:`mirl.learning.factored_pair`), an approximation.
    """
    x, y = (np.asarray(s, dtype=int) for s in series)
    S = domain.n_states
    vis = np.asarray(visible, dtype=bool).copy()
    vis[x[x >= 0]] = True
    vis[y[y >= 0]] = True
    if max_joint_states is not None and S * S > max_joint_states:
        pol = [np.asarray(p, dtype=int) for p in policies]
        PT, GT = _robot_steps(domain, pol, transitions, equilibrium, epsilon)
        meet = meeting_matrix(domain, pol[0], pol[1])
        return factored_log_likelihood((x, y), PT, GT, meet, vis)
    jf = _joint_filter(domain, policies, transitions, equilibrium, epsilon)
    M = np.full((S, S), 1.0 / (S * S))
    total = 0.0
    for t in range(len(x)):
        if t > 0:
            M = jf.step(M, x[t - 1], y[t - 1])
        _condition(M, x[t], vis, 0)
        _condition(M, y[t], vis, 1)
        c = M.sum()
        if c <= 0.0:  # impossible under the model (e.g. noisy data): restart the filter
            total += np.log(1e-300)
            M = np.full((S, S), 1.0)
            _condition(M, x[t], vis, 0)
            _condition(M, y[t], vis, 1)
            c = M.sum()
        else:
            total += np.log(c)
        M /= c
    return float(total)


def meeting_log_likelihood(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    equilibrium: Equilibrium,
    *,
    epsilon: float = 1e-3,
) -> tuple[float, int]:
    """log-likelihood of the *evident* meetings — both robots observed at t and t+1 and meeting
    under the policies — under the equilibrium, and how many there were."""
    x, y = (np.asarray(s, dtype=int) for s in series)
    t = np.flatnonzero((x[:-1] >= 0) & (y[:-1] >= 0) & (x[1:] >= 0) & (y[1:] >= 0))
    pol = [np.asarray(p, dtype=int) for p in policies]
    t = t[meeting(domain, x[t], y[t], pol[0][x[t]], pol[1][y[t]])]
    if t.size == 0:
        return 0.0, 0
    A = domain.n_actions
    total = 0.0
    for s, s2, p, T, side in (
        (x[t], x[t + 1], pol[0], transitions[0], equilibrium.row),
        (y[t], y[t + 1], pol[1], transitions[1], equilibrium.col),
    ):
        act = (1 - epsilon) * _game_actions(side, p[s], A) + epsilon / A
        Td = sp.csr_array(T)[(s[:, None] * A + np.arange(A)).ravel()][:, s2]
        prob_next = Td.toarray().reshape(len(s), A, len(s))[np.arange(len(s)), :, np.arange(len(s))]
        total += float(np.log(np.maximum((act * prob_next).sum(axis=1), 1e-300)).sum())
    return total, int(t.size)


@dataclass(frozen=True)
class EquilibriumWeights:
    """Candidate equilibria scored against the observations."""

    candidates: tuple[Equilibrium, ...]
    log_likelihoods: np.ndarray  # joint-filter log-likelihood per candidate
    weights: np.ndarray  # posterior under a uniform prior
    meeting_log_likelihoods: np.ndarray  # evident meetings only, per candidate
    n_meetings: int  # evident meetings seen
    best: int

    @property
    def equilibrium(self) -> Equilibrium:
        return self.candidates[self.best]

    @classmethod
    def from_log_likelihoods(
        cls, candidates, ll: np.ndarray, meeting_ll: np.ndarray, n_meetings: int
    ) -> EquilibriumWeights:
        """Posterior weights (uniform prior) and the best candidate (ties: the earlier)."""
        w = np.exp(ll - ll.max())
        best = int(np.flatnonzero(ll >= ll.max() - 1e-9)[0])
        return cls(tuple(candidates), ll, w / w.sum(), meeting_ll, n_meetings, best)


def weigh_equilibria(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    candidates: Sequence[Equilibrium],
    visible: np.ndarray,
    *,
    epsilon: float = 1e-3,
    max_joint_states: int | None = MAX_JOINT_STATES,
) -> EquilibriumWeights:
    """Weight each candidate equilibrium by the likelihood of everything L saw of both robots
    (:func:`joint_log_likelihood`, exact up to ``max_joint_states`` pair states); ties go to
    the earlier candidate."""
    if len(series) != 2:
        raise ValueError("equilibrium weighting is defined for two robots")
    ll = np.array(
        [
            joint_log_likelihood(
                *(domain, series, policies, transitions, e, visible),
                epsilon=epsilon,
                max_joint_states=max_joint_states,
            )
            for e in candidates
        ]
    )
    meet = [
        meeting_log_likelihood(domain, series, policies, transitions, e, epsilon=epsilon)
        for e in candidates
    ]
    w = np.exp(ll - ll.max())
    w /= w.sum()
    best = int(np.flatnonzero(ll >= ll.max() - 1e-9)[0])
    return EquilibriumWeights(
        tuple(candidates),
        ll,
        w,
        np.array([m[0] for m in meet]),
        meet[0][1] if meet else 0,
        best,
    )


# ---- teams of N ≥ 2 ----------------------------------------------------------------------------
def meeting_pairs(domain: PatrolDomain, series: Sequence[np.ndarray]) -> list[tuple[int, int]]:
    """The pairs (i < j) L has seen meet — both in view at a step where some pair of actions
    would make them meet; the first pair if none was (its joint filter still weighs what L did
    *not* see)."""
    n = len(series)
    pairs = [
        (i, j)
        for i in range(n)
        for j in range(i + 1, n)
        if potential_meetings(domain, series[i], series[j]).any()
    ]
    return pairs or [(0, 1)]


@dataclass(frozen=True)
class TeamEquilibria:
    """Equilibria weighed on every pair L has seen meet. ``shared`` sums the pairs'
    log-likelihoods (one game for the whole team, the scenario format's default); ``pairs`` keeps
    each pair's own weighing (a team whose pairs play different equilibria)."""

    shared: EquilibriumWeights
    pairs: dict[tuple[int, int], EquilibriumWeights]

    def best_per_pair(self) -> dict[tuple[int, int], Equilibrium]:
        return {p: w.equilibrium for p, w in self.pairs.items()}


def weigh_team_equilibria(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    candidates: Sequence[Equilibrium],
    visible: np.ndarray,
    *,
    epsilon: float = 1e-3,
    max_joint_states: int | None = MAX_JOINT_STATES,
) -> TeamEquilibria:
    """:func:`weigh_equilibria` on every pair of :func:`meeting_pairs` (each pair's joint
    filter ignores the other robots), combined by summing log-likelihoods. With two robots this
    is exactly :func:`weigh_equilibria`. A pair whose joint has more than ``max_joint_states``
    states is filtered factored, coupled at meetings (:mod:`mirl.learning.factored_pair`).
    """
    per_pair = {
        (i, j): weigh_equilibria(
            domain,
            [series[i], series[j]],
            [policies[i], policies[j]],
            [transitions[i], transitions[j]],
            candidates,
            visible,
            epsilon=epsilon,
            max_joint_states=max_joint_states,
        )
        for i, j in meeting_pairs(domain, series)
    }
    if len(per_pair) == 1:
        return TeamEquilibria(next(iter(per_pair.values())), per_pair)
    shared = EquilibriumWeights.from_log_likelihoods(
        candidates,
        np.sum([w.log_likelihoods for w in per_pair.values()], axis=0),
        np.sum([p.meeting_log_likelihoods for p in per_pair.values()], axis=0),
        sum(p.n_meetings for p in per_pair.values()),
    )
    return TeamEquilibria(shared, per_pair)
