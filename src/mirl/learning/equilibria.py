"""Interactions: which observed steps could be meetings, and the weighing of the interaction
game's candidate equilibria by the likelihood of both robots' observations under the joint
dynamics, in which the equilibrium's moves replace the policies' at meeting states.

**Interactions.** Observed steps at which both robots are in view and *could* meet are left out of
the per-robot fit (their actions may be the game's). The candidate equilibria (all Nash equilibria
of the bimatrix) are weighed by the likelihood of both robots' observations
(:func:`joint_log_likelihood`), which contains the likelihood of the evident meetings
(:func:`meeting_log_likelihood`). The exact joint filter costs ~0.1 s per equilibrium on boyd2
(450 steps), 10–25 times a marginal objective evaluation, so equilibria are weighed once per
learned model rather than inside the optimiser.

**The exact joint filter** (:class:`JointFilter`). The joint belief is an S × S matrix M; a step
is M ← Pᵢᵀ (M off meetings) Pⱼ + Gᵢᵀ (M at meetings) Gⱼ, where P are the robots' ε-greedy policy
steps and G the equilibrium's game moves. Each step adds the same products in the same order as
the plain form (two dense-by-sparse products of the whole S × S matrix, and scipy's
sparse-sparse kernel for the meeting part), so the likelihood is bit for bit the plain one
(``tests/references/joint_filter.py``), but it skips what is known to be zero:

* after a step at which L saw robot I, M is zero off that robot's row, so the next step is an
  outer product of two vectors (and after one at which it saw J, the product of Pᵢᵀ with the few
  columns J can reach) instead of two S × S × nnz products — exactly, since a sum of exact zeros
  and one product is that product;
* the meeting part is two fixed linear maps from the few hundred meeting values to the entries
  they reach (their order of summation that of scipy's kernel), instead of a sparse-sparse
  product whose structure is rebuilt at every step.

**The factored filter on large maps** (:func:`factored_log_likelihood`). The exact filter tracks
every pair of states, S² of them (712 k on a 30 × 30 office, 39 M on 80 × 80). Only meetings
need the pair, and a meeting needs the two robots within two cells of each other, so the meeting
states are a sparse set (at most ~50 per state, :func:`meeting_matrix`). Above
``MAX_JOINT_STATES`` pair states the belief is kept as a product of the two robots' marginals
(the Boyen–Koller projection): a step moves each marginal by its policy, except for the mass the
pair has at meeting states, which moves by the equilibrium's game moves — exactly the joint
step's marginals when the joint is that product — and the evidence (each robot seen where it is,
or not on a visible cell) factorises, so its likelihood is the product of the two robots'. What
is dropped is the correlation a meeting leaves behind (who waited for whom). Cost per step: two
sparse mat-vecs per robot and one product with the sparse meeting matrix, O(S) instead of O(S²).
The approximation against the exact joint is measured in ``benchmarks/bench_speed.py
--accuracy`` and docs/design.md ("Equilibrium weighing at scale").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mirl.learning.soft_policy import _Dynamics
from mirl.sparse import csr_block_matvec, csr_matmul, linear_map
from mirl.world.domain import STOP, TURN_LEFT, PatrolDomain
from mirl.world.game import Equilibrium, meeting

# pair states up to which the weighing filters the exact joint (as the planner's BeliefFilter);
# above, the factored filter coupled at meetings (error measured in docs/design.md)
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
    "JointFilter",
    "MeetingMaps",
    "meeting_matrix",
    "factored_log_likelihood",
]


# ---- interactions ------------------------------------------------------------------------------
def potential_meetings(domain: PatrolDomain, series_i: np.ndarray, series_j: np.ndarray):
    """The steps at which both robots are observed and *some* pair of actions would make them meet.

    Used to leave game-driven steps out of the per-robot IRL without knowing the policies yet.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series_i : ndarray of int, shape (horizon,)
        One robot's observed states, -1 where occluded.
    series_j : ndarray of int, shape (horizon,)
        The other's.

    Returns
    -------
    ndarray of bool, shape (horizon,)
        True at those steps.
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


# ---- weighing equilibria -------------------------------------------------------------------------
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
    conditioned on what L saw (the observed state, or "somewhere not visible").

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    policies : sequence of ndarray of int, shape (S,)
        Each robot's (learned) policy.
    transitions : sequence of scipy.sparse.csr_array of shape (S*A, S)
        Each robot's (learned) T.
    equilibrium : Equilibrium
        The equilibrium the robots play when they meet.
    visible : ndarray of bool, shape (S,)
        The states L sees (a robot seen elsewhere counts too).
    epsilon : float, default 1e-3
        The uniform action mixed into the greedy policies, so that no observation has
        probability 0.
    max_joint_states : int or None, default MAX_JOINT_STATES
        Above this many pair states the robots are filtered on their own and coupled at meetings
        (:func:`factored_log_likelihood`), an approximation; None: never.

    Returns
    -------
    float
        The log-likelihood.
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
            if c <= 0.0:  # impossible from anywhere (unseen where every state is visible)
                M, c = np.full((S, S), 1.0), float(S * S)
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
    """The log-likelihood of the *evident* meetings under the equilibrium, and how many there were.

    A meeting is evident when both robots are observed at t and t+1 and meet under the policies.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    policies : sequence of ndarray of int, shape (S,)
        Each robot's (learned) policy.
    transitions : sequence of scipy.sparse.csr_array of shape (S*A, S)
        Each robot's (learned) T.
    equilibrium : Equilibrium
        The equilibrium the robots play when they meet.
    epsilon : float, default 1e-3
        The uniform action mixed into the greedy policies, so that no observation has
        probability 0.

    Returns
    -------
    log_likelihood : float
        Of the evident meetings' moves.
    n_meetings : int
        The evident meetings.
    """
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
    """Candidate equilibria scored against the observations.

    Parameters
    ----------
    candidates : tuple of Equilibrium
        The candidates, in order.
    log_likelihoods : ndarray of shape (n,)
        The joint-filter log-likelihood of each.
    weights : ndarray of shape (n,)
        The posterior under a uniform prior.
    meeting_log_likelihoods : ndarray of shape (n,)
        Of the evident meetings only, per candidate.
    n_meetings : int
        The evident meetings seen.
    best : int
        The index of the most likely candidate (ties: the earlier).
    """

    candidates: tuple[Equilibrium, ...]
    log_likelihoods: np.ndarray  # joint-filter log-likelihood per candidate
    weights: np.ndarray  # posterior under a uniform prior
    meeting_log_likelihoods: np.ndarray  # evident meetings only, per candidate
    n_meetings: int  # evident meetings seen
    best: int

    @property
    def equilibrium(self) -> Equilibrium:
        """The most likely candidate."""
        return self.candidates[self.best]

    @classmethod
    def from_log_likelihoods(
        cls, candidates, ll: np.ndarray, meeting_ll: np.ndarray, n_meetings: int
    ) -> EquilibriumWeights:
        """Posterior weights (uniform prior) and the best candidate (ties: the earlier).

        Parameters
        ----------
        candidates : sequence of Equilibrium
            The candidates.
        ll : ndarray of shape (n,)
            Their joint-filter log-likelihoods.
        meeting_ll : ndarray of shape (n,)
            Their evident meetings' log-likelihoods.
        n_meetings : int
            The evident meetings seen.

        Returns
        -------
        EquilibriumWeights
            The weighing.
        """
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
    """Weight each candidate equilibrium by the likelihood of everything L saw of both robots.

    The likelihood is :func:`joint_log_likelihood`'s, exact up to ``max_joint_states`` pair
    states; ties go to the earlier candidate.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    policies : sequence of ndarray of int, shape (S,)
        Each robot's (learned) policy.
    transitions : sequence of scipy.sparse.csr_array of shape (S*A, S)
        Each robot's (learned) T.
    candidates : sequence of Equilibrium
        The equilibria to weigh.
    visible : ndarray of bool, shape (S,)
        The states L sees.
    epsilon : float, default 1e-3
        The uniform action mixed into the greedy policies, so that no observation has
        probability 0.
    max_joint_states : int or None, default MAX_JOINT_STATES
        Above this many pair states the robots are filtered on their own and coupled at meetings
        (:func:`factored_log_likelihood`), an approximation; None: never.

    Returns
    -------
    EquilibriumWeights
        The candidates' log-likelihoods, weights and the best.

    Raises
    ------
    ValueError
        Other than two robots.
    """
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
    return EquilibriumWeights.from_log_likelihoods(
        candidates, ll, np.array([m[0] for m in meet]), meet[0][1] if meet else 0
    )


# ---- the exact joint filter ----------------------------------------------------------------------
def _expand(indptr: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (i, k) with k an entry position of row ``rows[i]`` of a compressed array."""
    starts = indptr[rows]
    counts = indptr[rows + 1] - starts
    i = np.repeat(np.arange(len(rows)), counts)
    k = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts - starts, counts)
    return i, k


class MeetingMaps:
    """Gᵢᵀ (M at meetings) Gⱼ added into a dense (S, S) array, by two fixed linear maps.

    scipy's sparse-sparse kernel (Gustavson's) forms Y = (M at meetings) Gⱼ summing each entry
    over the meeting states of its row in order, then Gᵢᵀ Y summing each entry over Gᵢᵀ's row in
    its stored order. The two maps sum the same terms in the same orders (an entry that is zero
    adds an exact zero, as the kernel's dropped entries do not), so the result is bitwise the
    kernel's; their structure is built once rather than at every step.

    Parameters
    ----------
    GT_i : scipy.sparse.csr_array of shape (S, S)
        Robot I's game-move step, transposed.
    GT_j : scipy.sparse.csr_array of shape (S, S)
        Robot J's.
    meet : ndarray of bool, shape (S, S)
        The joint states where the robots' intended moves meet.
    """

    def __init__(self, GT_i: sp.csr_array, GT_j: sp.csr_array, meet: np.ndarray) -> None:
        S = meet.shape[0]
        dtype = GT_i.indptr.dtype
        mi, mj = (a.astype(np.intp) for a in np.nonzero(meet))  # row-major: the kernel's order
        self.at = mi * S + mj  # flat positions of the meeting states
        gj = sp.csr_array(GT_j.T)  # Gⱼ as CSR, in the kernel's order
        gj.sort_indices()
        # first map: meeting value e times Gⱼ entry k lands on Y[mi[e], column of k]
        e, k = _expand(gj.indptr.astype(np.intp), mj)
        y_keys, self._first = linear_map(mi[e] * S + gj.indices[k], e, e, gj.data[k], dtype)
        # second map: Y entry y = (a, c) times Gᵢᵀ entry kk = (r, a) lands on C[r, c]
        by_column = np.argsort(GT_i.indices, kind="stable")
        column_ptr = np.searchsorted(GT_i.indices[by_column], np.arange(S + 1))
        y_index, p = _expand(column_ptr, y_keys // S)
        kk = by_column[p]
        gi_rows = np.repeat(np.arange(S), np.diff(GT_i.indptr))
        c_key = gi_rows[kk] * S + y_keys[y_index] % S
        self._c_keys, self._second = linear_map(c_key, kk, y_index, GT_i.data[kk], dtype)
        self._n = (len(mi), len(y_keys), len(self._c_keys))

    def add_to(self, out: np.ndarray, M: np.ndarray) -> None:
        """Add Gᵢᵀ (M at meetings) Gⱼ into ``out``.

        Parameters
        ----------
        out : ndarray of shape (S, S)
            C-contiguous; added into in place.
        M : ndarray of shape (S, S)
            The joint belief.
        """
        m, n_y, n_c = self._n
        if m == 0:
            return
        values = M.reshape(-1)[self.at]
        y, c = np.zeros(n_y), np.zeros(n_c)
        csr_block_matvec(n_y, m, 1, *self._first, values, y)
        csr_block_matvec(n_c, n_y, 1, *self._second, y, c)
        flat = out.reshape(-1)
        flat[self._c_keys] += c


class JointFilter:
    """One step of the joint belief of two robots (module docstring).

    Parameters
    ----------
    PT : sequence of scipy.sparse.csr_array of shape (S, S)
        Per robot the transposed ε-greedy policy step.
    GT : sequence of scipy.sparse.csr_array of shape (S, S)
        Per robot the transposed game-move step.
    meet : ndarray of bool, shape (S, S)
        The joint states where the robots' intended moves meet.
    """

    def __init__(self, PT, GT, meet: np.ndarray) -> None:
        S = meet.shape[0]
        self.S = S
        self._P = [(P.indptr, P.indices, P.data) for P in PT]
        self._P_i_dense = PT[0].toarray()  # column x: where robot I goes from x
        self._P_j_dense = PT[1].toarray()
        self._off = (~meet).astype(float)  # masks as factors: M·1 = M, M·0 = +0
        self._off_T = np.ascontiguousarray(self._off.T)
        self._meeting = MeetingMaps(GT[0], GT[1], meet)
        self._xt, self._y, self._yt = np.empty((S, S)), np.empty((S, S)), np.empty((S, S))

    def step(self, M: np.ndarray, seen_i: int, seen_j: int) -> np.ndarray:
        """M one step on.

        Parameters
        ----------
        M : ndarray of shape (S, S)
            The joint belief, conditioned on the last step's observations.
        seen_i : int
            The state L saw robot I in at that step (-1: not seen), where M is zero off that row.
        seen_j : int
            The state L saw robot J in (-1: not seen), where M is zero off that column.

        Returns
        -------
        ndarray of shape (S, S)
            The propagated joint.
        """
        S = self.S
        out = np.zeros((S, S))
        if seen_i >= 0:  # (M off meetings) is row x: Pᵢᵀ e_x (Pⱼᵀ row)ᵀ, an outer product
            w = np.zeros(S)
            csr_block_matvec(S, S, 1, *self._P[1], M[seen_i] * self._off[seen_i], w)
            np.multiply(self._P_i_dense[:, seen_i, None], w, out=out)
        elif seen_j >= 0:  # column y: only the columns robot J reaches from y are not zero
            b = self._P_j_dense[:, seen_j]
            reach = np.flatnonzero(b)
            yt = np.multiply.outer(M[:, seen_j] * self._off_T[seen_j], b[reach])
            part = np.zeros((S, len(reach)))
            csr_block_matvec(S, S, len(reach), *self._P[0], yt.ravel(), part.ravel())
            out[:, reach] = part
        else:  # Pᵢᵀ ((M off meetings) Pⱼ), the latter as (Pⱼᵀ (M off meetings)ᵀ)ᵀ
            np.multiply(M.T, self._off_T, out=self._xt)
            self._y.fill(0.0)
            csr_block_matvec(S, S, S, *self._P[1], self._xt.ravel(), self._y.ravel())
            np.copyto(self._yt, self._y.T)
            csr_block_matvec(S, S, S, *self._P[0], self._yt.ravel(), out.ravel())
        self._meeting.add_to(out, M)
        return out


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


# ---- the factored filter, coupled at meetings ----------------------------------------------------
def meeting_matrix(domain: PatrolDomain, policy_i: np.ndarray, policy_j: np.ndarray):
    """The pair states where the policies' intended moves meet.

    Without enumerating all S² pairs: only states whose cells are within two steps can meet.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    policy_i : ndarray of int, shape (S,)
        Robot I's policy.
    policy_j : ndarray of int, shape (S,)
        Robot J's.

    Returns
    -------
    scipy.sparse.csr_array of shape (S, S)
        1 where they meet.
    """
    S = domain.n_states
    cells = domain.cells
    rows, cols = domain.cell_lut.shape
    offsets = [(dr, dc) for dr in range(-2, 3) for dc in range(-2, 3) if abs(dr) + abs(dc) <= 2]
    si_all, sj_all = [], []
    heads = np.arange(4)
    for dr, dc in offsets:
        r, c = cells[:, 0] + dr, cells[:, 1] + dc
        ok = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        other = np.full(len(cells), -1)
        other[ok] = domain.cell_lut[r[ok], c[ok]]
        ci = np.flatnonzero(other >= 0)
        # every heading of the cell against every heading of the other cell
        si = (ci[:, None, None] * 4 + heads[:, None]).repeat(4, axis=2).ravel()
        sj = (other[ci][:, None, None] * 4 + heads[None, None, :]).repeat(4, axis=1).ravel()
        si_all.append(si)
        sj_all.append(sj)
    si, sj = np.concatenate(si_all), np.concatenate(sj_all)
    pi, pj = np.asarray(policy_i, dtype=int), np.asarray(policy_j, dtype=int)
    hit = meeting(domain, si, sj, pi[si], pj[sj])
    data = np.ones(int(hit.sum()))
    return sp.csr_array((data, (si[hit], sj[hit])), shape=(S, S))


def _condition_marginal(b: np.ndarray, x: int, visible: np.ndarray) -> float:
    """In place: one robot's marginal given its observation; returns the evidence's probability."""
    if x >= 0:
        keep = b[x]
        b[:] = 0.0
        b[x] = keep
    else:
        b[visible] = 0.0
    return float(b.sum())


def factored_log_likelihood(
    series: Sequence[np.ndarray],
    PT: Sequence[sp.csr_array],
    GT: Sequence[sp.csr_array],
    meet: sp.csr_array,
    visible: np.ndarray,
) -> float:
    """log P(observations of both robots) under the factored filter (module docstring).

    For the model of :func:`joint_log_likelihood`.

    Parameters
    ----------
    series : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    PT : sequence of scipy.sparse.csr_array of shape (S, S)
        Per robot the transposed ε-greedy policy step.
    GT : sequence of scipy.sparse.csr_array of shape (S, S)
        Per robot the transposed game-move step.
    meet : scipy.sparse.csr_array of shape (S, S)
        :func:`meeting_matrix`.
    visible : ndarray of bool, shape (S,)
        The states L can see (a robot seen elsewhere counts).

    Returns
    -------
    float
        The log-likelihood.
    """
    x, y = (np.asarray(s, dtype=int) for s in series)
    S = meet.shape[0]
    meet_T = sp.csr_array(meet.T)
    b = [np.full(S, 1.0 / S), np.full(S, 1.0 / S)]
    total = 0.0
    for t in range(len(x)):
        if t > 0:
            # mass each robot has at meeting states: r_I(s) = b_I(s) Σ_s' m(s, s') b_J(s')
            r = [b[0] * csr_matmul(meet, b[1]), b[1] * csr_matmul(meet_T, b[0])]
            b = [csr_matmul(PT[k], b[k] - r[k]) + csr_matmul(GT[k], r[k]) for k in (0, 1)]
        obs = (int(x[t]), int(y[t]))
        for k in (0, 1):
            c = _condition_marginal(b[k], obs[k], visible)
            if c <= 0.0:  # impossible under the model: restart this robot's marginal
                total += np.log(1e-300)
                b[k] = np.ones(S)
                c = _condition_marginal(b[k], obs[k], visible)
                if c <= 0.0:  # impossible from anywhere (unseen where every state is visible)
                    b[k], c = np.ones(S), float(S)
            else:
                total += np.log(c)
            b[k] /= c
    return float(total)


# ---- teams of N ≥ 2 ----------------------------------------------------------------------------
def meeting_pairs(
    domain: PatrolDomain, series: Sequence[np.ndarray], *, fallback: bool = True
) -> list[tuple[int, int]]:
    """The pairs (i < j) L has seen meet.

    Both in view at a step where some pair of actions would make them meet.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    fallback : bool, default True
        Whether to return the first pair when none was seen meeting (its joint filter still
        weighs what L did *not* see).

    Returns
    -------
    list of (int, int)
        The pairs; the first pair if none was seen meeting and ``fallback``.
    """
    n = len(series)
    pairs = [
        (i, j)
        for i in range(n)
        for j in range(i + 1, n)
        if potential_meetings(domain, series[i], series[j]).any()
    ]
    return pairs or ([(0, 1)] if fallback else [])


@dataclass(frozen=True)
class TeamEquilibria:
    """Equilibria weighed on every pair L has seen meet.

    Parameters
    ----------
    shared : EquilibriumWeights
        The pairs' log-likelihoods summed: one game for the whole team, the scenario format's
        default.
    pairs : dict of (int, int) to EquilibriumWeights
        Each pair's own weighing (a team whose pairs play different equilibria).
    seen_meeting : bool, default True
        Whether L saw any pair meet; when it saw none, ``pairs`` holds :func:`meeting_pairs`'s
        fallback, the first pair, weighed on what L did not see of it.
    """

    shared: EquilibriumWeights
    pairs: dict[tuple[int, int], EquilibriumWeights]
    seen_meeting: bool = True

    def best_per_pair(self) -> dict[tuple[int, int], Equilibrium]:
        """Each pair's most likely equilibrium, for the pairs L saw meet.

        Returns
        -------
        dict of (int, int) to Equilibrium
            Per pair; empty when L saw no pair meet (the fallback pair's equilibrium is then
            the team's, ``shared``'s, so every pair plays it).
        """
        if not self.seen_meeting:
            return {}
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
    """:func:`weigh_equilibria` on every pair of :func:`meeting_pairs`, combined.

    Each pair's joint filter ignores the other robots; the pairs are combined by summing
    log-likelihoods. With two robots this is exactly :func:`weigh_equilibria`.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series : sequence of ndarray of int, shape (horizon,)
        Each robot's observed states, -1 where occluded.
    policies : sequence of ndarray of int, shape (S,)
        Each robot's (learned) policy.
    transitions : sequence of scipy.sparse.csr_array of shape (S*A, S)
        Each robot's (learned) T.
    candidates : sequence of Equilibrium
        The equilibria to weigh.
    visible : ndarray of bool, shape (S,)
        The states L sees.
    epsilon : float, default 1e-3
        The uniform action mixed into the greedy policies, so that no observation has
        probability 0.
    max_joint_states : int or None, default MAX_JOINT_STATES
        Above this many pair states the robots are filtered on their own and coupled at meetings
        (:func:`factored_log_likelihood`), an approximation; None: never.

    Returns
    -------
    TeamEquilibria
        The shared weighing and each pair's.
    """
    met = meeting_pairs(domain, series, fallback=False)
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
        for i, j in met or [(0, 1)]  # meeting_pairs' fallback
    }
    seen = len(series) < 3 or bool(met)
    if len(per_pair) == 1:
        return TeamEquilibria(next(iter(per_pair.values())), per_pair, seen)
    shared = EquilibriumWeights.from_log_likelihoods(
        candidates,
        np.sum([w.log_likelihoods for w in per_pair.values()], axis=0),
        np.sum([p.meeting_log_likelihoods for p in per_pair.values()], axis=0),
        sum(p.n_meetings for p in per_pair.values()),
    )
    return TeamEquilibria(shared, per_pair, seen)
