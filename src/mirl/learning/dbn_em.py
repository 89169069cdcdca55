"""The DBN-EM baseline (docs/design.md, "DBN-EM"; the random observer is in
:mod:`mirl.experiments.episode`).

**dbn-em** (:func:`em_transition_model`): each patroller is a two-slice state–action–state
dynamic Bayesian network s_t → a_t → s_{t+1} with parameters π(a | s) and a tabular
T(s, a, s'). L observes states only, and only on visible cells, so the actions and the occluded
states are hidden. EM alternates

* an exact E-step — forward–backward over the hidden chain with P(s, s') = Σ_a π(a|s) T(s,a,s')
  (scaled messages; an observed step clamps the state, an occluded step leaves it free), giving
  the expected pair counts Ξ(s, s') = Σ_t P(s_t = s, s_{t+1} = s' | data) and, per pair, the
  posterior of the action π(a|s) T(s,a,s') / P(s,s');
* an M-step with the expected counts: π(a|s) ∝ N(s,a), T(s,a,s') ∝ N(s,a,s'). A (s, a) with no
  expected count keeps its previous (initial) parameters.

The initial T(s, a, ·) is uniform over the intended states of all actions {ψ(s, a')}
(``init="intended"``, default) or over all states (``init="uniform"``). Both are the same for
every action, and since only states are observed nothing in the data can tell the actions
apart: EM keeps T(s, a, ·) = T(s, a', ·) for ever and learns the state chain P only. This is
the weakness the paper reports — no feature is shared between actions or states, so where the
robot was never seen T stays at its uninformative initialisation. ``"intended"`` at least keeps
the robot's physical reach (four successors); ``"uniform"`` lets a robot jump anywhere.

EM never gives mass to a successor the initial T excludes, so with ``"intended"`` T lives on at
most four successors of each state. Where the dense (S, A, S) arrays would not fit
(:data:`MAX_DENSE_ENTRIES`, e.g. the 3 804 states of the generated office), the same EM runs on
that support (:func:`em_fit_on_support`): the same updates, the chain P as a sparse matrix, so
memory grows with S rather than S². Where the dense arrays fit they are used, and the two agree
to rounding (tested).

Under ``"intended"`` an observation that no sequence of the robot's moves reaches from the
previous one in the steps between them (a discretised pose in the physical world can skip a
cell) would make the data impossible for EM. :func:`em_transitions` leaves such observations
out, as unseen, and counts them; the learner's message says how many.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mirl.learning.options import EM_INITS
from mirl.world.domain import PatrolDomain

__all__ = [
    "EM_INITS",
    "em_transitions",
    "unreachable_observations",
    "MAX_DENSE_ENTRIES",
    "EMResult",
    "em_fit",
    "em_fit_on_support",
    "em_transition_model",
    "expected_counts",
]

MAX_DENSE_ENTRIES = 50_000_000  # S·A·S floats of the dense T: 400 MB


@dataclass(frozen=True)
class EMResult:
    """What :func:`em_fit` learned.

    Parameters
    ----------
    policy : ndarray of shape (S, A)
        The policy π(a | s).
    transitions : ndarray of shape (S, A, S)
        T(s, a, s').
    log_likelihood : tuple of float
        After the E-step of each iteration (non-decreasing).
    iterations : int
        The iterations made.
    converged : bool
        Whether the gain fell below ``tol`` before ``n_iter``.
    """

    policy: np.ndarray  # (S, A) π(a | s)
    transitions: np.ndarray  # (S, A, S) T(s, a, s')
    log_likelihood: tuple[float, ...]  # after the E-step of each iteration (non-decreasing)
    iterations: int
    converged: bool

    def transition_matrix(self) -> sp.csr_array:
        """T as the solvers take it.

        Returns
        -------
        scipy.sparse.csr_array of shape (S*A, S)
            T(s, a, s') in row s·A + a.
        """
        S, A, _ = self.transitions.shape
        return sp.csr_array(self.transitions.reshape(S * A, S))


def initial_transitions(domain: PatrolDomain, init: str = "intended") -> np.ndarray:
    """(S, A, S) initial T: uniform over {ψ(s, a')} (``intended``) or over all states."""
    EM_INITS.lookup(init)  # an unknown name: UnknownNameError (a ValueError), one line
    S, A = domain.n_states, domain.n_actions
    if init == "uniform":
        return np.full((S, A, S), 1.0 / S)
    support = np.zeros((S, S))
    support[np.repeat(np.arange(S), A), domain.intended.ravel()] = 1.0  # duplicates count once
    support /= support.sum(axis=1, keepdims=True)
    return np.repeat(support[:, None, :], A, axis=1)


def _check_series(series_list: Sequence[np.ndarray], n_states: int) -> list[np.ndarray]:
    out = []
    for i, x in enumerate(series_list):
        x = np.asarray(x, dtype=int)
        if x.ndim != 1 or len(x) < 2:
            raise ValueError(f"series {i} must be a 1-D array of at least two steps")
        if np.any((x < -1) | (x >= n_states)):
            raise ValueError(f"series {i} has state indices outside -1 … {n_states - 1}")
        out.append(x)
    return out


def expected_counts(
    policy: np.ndarray,
    transitions: np.ndarray,
    series_list: Sequence[np.ndarray],
    *,
    prior: np.ndarray | None = None,
    hidden_states: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """E-step: expected counts N(s, a, s') and the log-likelihood of the data.

    Parameters
    ----------
    policy : ndarray of shape (S, A)
        The policy π(a | s).
    transitions : ndarray of shape (S, A, S)
        T(s, a, s').
    series_list : sequence of ndarray of int, shape (horizon,)
        One or more of the robot's state series, -1 where it was occluded.
    prior : ndarray of shape (S,), optional
        The distribution of s_0; uniform by default.
    hidden_states : ndarray of bool, shape (S,), optional
        Where an unobserved robot can be (negative evidence); by default anywhere, i.e. occluded
        steps are plain missing data.

    Returns
    -------
    counts : ndarray of shape (S, A, S)
        N(s, a, s').
    log_likelihood : float
        Of the data under π and T.

    Raises
    ------
    ValueError
        A series that is not 1-D of at least two steps, or holds indices outside -1 … S − 1.
    """
    S, A, _ = transitions.shape
    P = np.einsum("sa,sat->st", policy, transitions)  # chain P(s, s')
    prior = np.full(S, 1.0 / S) if prior is None else np.asarray(prior, float)
    free = np.ones(S) if hidden_states is None else np.asarray(hidden_states, float)
    pair = np.zeros((S, S))
    loglik = 0.0
    for x in _check_series(series_list, S):
        n = len(x)
        ev = np.tile(free, (n, 1))
        obs = np.flatnonzero(x >= 0)
        ev[obs] = 0.0
        ev[obs, x[obs]] = 1.0
        alpha = np.empty((n, S))
        scale = np.empty(n)
        a = prior * ev[0]
        for t in range(n):
            if t:
                a = (alpha[t - 1] @ P) * ev[t]
            scale[t] = a.sum()
            if scale[t] <= 0:
                raise ValueError(f"observations impossible under the model at t={t}")
            alpha[t] = a / scale[t]
        beta = np.empty((n, S))
        beta[-1] = 1.0
        for t in range(n - 2, -1, -1):
            beta[t] = P @ (ev[t + 1] * beta[t + 1]) / scale[t + 1]
        loglik += float(np.log(scale).sum())
        b = ev[1:] * beta[1:] / scale[1:, None]  # (n-1, S)
        pair += alpha[:-1].T @ b  # Σ_t α_t(s)·e_{t+1}(s')β_{t+1}(s')/c_{t+1}
    pair *= P  # Ξ(s, s')
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(P[:, None, :] > 0, policy[:, :, None] * transitions / P[:, None, :], 0.0)
    return pair[:, None, :] * share, loglik


def _m_step(
    N: np.ndarray, T: np.ndarray, pi: np.ndarray, min_count: float
) -> tuple[np.ndarray, np.ndarray]:
    """M-step from expected counts N (S, A, K): T(s, a, ·) ∝ N(s, a, ·) and π(a | s) ∝ N(s, a);
    an (s, a) or s with no expected count keeps its previous parameters. K is S for the dense
    T, the successor slots on T's support."""
    n_sa = N.sum(axis=2)
    seen_sa = n_sa > min_count
    T = np.where(seen_sa[:, :, None], N / np.where(seen_sa, n_sa, 1.0)[:, :, None], T)
    n_s = n_sa.sum(axis=1)
    seen_s = n_s > min_count
    pi = np.where(seen_s[:, None], n_sa / np.where(seen_s, n_s, 1.0)[:, None], pi)
    return T, pi


def em_fit(
    domain: PatrolDomain,
    series_list: Sequence[np.ndarray],
    *,
    n_iter: int = 20,
    tol: float = 1e-4,
    init: str = "intended",
    hidden_states: np.ndarray | None = None,
    min_count: float = 1e-9,
) -> EMResult:
    """EM for π and T of one robot (module doc).

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series_list : sequence of ndarray of int, shape (horizon,)
        One or more of the robot's state series, -1 where it was occluded.
    n_iter : int, default 20
        At most this many EM iterations.
    tol : float, default 1e-4
        Stop when an iteration gains less log-likelihood than this.
    init : {"intended", "uniform"}, default "intended"
        The initial T (:func:`initial_transitions`).
    hidden_states : ndarray of bool, shape (S,), optional
        Where an unobserved robot can be (:func:`expected_counts`).
    min_count : float, default 1e-9
        An (s, a) or s with no more expected count than this keeps its previous parameters.

    Returns
    -------
    EMResult
        π, T and the log-likelihood's history.

    Raises
    ------
    ValueError
        A dense T too large for the map, or a malformed series.
    """
    S, A = domain.n_states, domain.n_actions
    if S * S * A > MAX_DENSE_ENTRIES:
        raise ValueError(
            f"dbn-em with `init` {init} keeps a dense T of {S}×{A}×{S}; too large for this map"
        )
    T = initial_transitions(domain, init)
    pi = np.full((S, A), 1.0 / A)
    history: list[float] = []
    converged = False
    it = 0
    for it in range(1, n_iter + 1):  # noqa: B007 - reported
        N, ll = expected_counts(pi, T, series_list, hidden_states=hidden_states)
        history.append(ll)
        T, pi = _m_step(N, T, pi, min_count)
        if len(history) > 1 and history[-1] - history[-2] < tol:
            converged = True
            break
    return EMResult(pi, T, tuple(history), it, converged)


def unreachable_observations(domain: PatrolDomain, x: np.ndarray) -> np.ndarray:
    """The observations that no sequence of intended moves reaches from the previous one kept.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    x : ndarray of int, shape (horizon,)
        State indices, -1 unseen.

    Returns
    -------
    ndarray of bool, shape (horizon,)
        True at the observations unreachable in the steps since the previous observation kept.
    """
    x = np.asarray(x, dtype=int)
    S = domain.n_states
    succ = sp.csr_array(
        (np.ones(domain.intended.size), (np.repeat(np.arange(S), domain.n_actions),
                                         domain.intended.ravel())), shape=(S, S)
    ).T.tocsr()  # fmt: skip
    out = np.zeros(len(x), dtype=bool)
    seen = np.flatnonzero(x >= 0)
    if len(seen) == 0:
        return out
    last_t, last_s = int(seen[0]), int(x[seen[0]])
    for t in seen[1:]:
        reach = np.zeros(S, dtype=bool)
        reach[last_s] = True
        for _ in range(int(t) - last_t):  # staying is a move (stop), so reach only grows
            if reach[x[t]]:
                break
            reach = reach | ((succ @ reach.astype(float)) > 0)
        if reach[x[t]]:
            last_t, last_s = int(t), int(x[t])
        else:
            out[t] = True
    return out


def em_transitions(
    domain: PatrolDomain,
    series_list: Sequence[np.ndarray],
    *,
    n_iter: int = 20,
    tol: float = 1e-4,
    init: str = "intended",
) -> tuple[sp.csr_array, int]:
    """DBN-EM's T(s, a, s'), and how many observations were left out as unseen.

    With ``init="intended"``, observations no sequence of moves reaches are left out as unseen
    (:func:`unreachable_observations`; see the module doc), and a large map is fitted on T's
    support (:func:`em_fit_on_support`).

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series_list : sequence of ndarray of int, shape (horizon,)
        One or more of the robot's state series, -1 where it was occluded.
    n_iter : int, default 20
        At most this many EM iterations.
    tol : float, default 1e-4
        Stop when an iteration gains less log-likelihood than this.
    init : {"intended", "uniform"}, default "intended"
        The initial T (:func:`initial_transitions`).

    Returns
    -------
    transitions : scipy.sparse.csr_array of shape (S*A, S)
        T(s, a, s').
    dropped : int
        The observations left out.
    """
    dropped = 0
    if init == "intended":
        cleaned = []
        for x in _check_series(series_list, domain.n_states):
            bad = unreachable_observations(domain, x)
            dropped += int(bad.sum())
            cleaned.append(np.where(bad, -1, x))
        series_list = cleaned
    S, A = domain.n_states, domain.n_actions
    if init == "intended" and S * A * S > MAX_DENSE_ENTRIES:
        return em_fit_on_support(domain, series_list, n_iter=n_iter, tol=tol)[0], dropped
    fit = em_fit(domain, series_list, n_iter=n_iter, tol=tol, init=init)
    return fit.transition_matrix(), dropped


def em_transition_model(
    domain: PatrolDomain,
    series_list: Sequence[np.ndarray],
    *,
    n_iter: int = 20,
    tol: float = 1e-4,
    init: str = "intended",
) -> sp.csr_array:
    """DBN-EM estimate of one robot's T(s, a, s').

    See the module doc for the model and :func:`em_fit` for diagnostics.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series_list : sequence of ndarray of int, shape (horizon,)
        One or more of the robot's state series, -1 where it was occluded.
    n_iter : int, default 20
        At most this many EM iterations.
    tol : float, default 1e-4
        Stop when an iteration gains less log-likelihood than this.
    init : {"intended", "uniform"}, default "intended"
        The initial T (:func:`initial_transitions`).

    Returns
    -------
    scipy.sparse.csr_array of shape (S*A, S)
        T(s, a, s').
    """
    return em_transitions(domain, series_list, n_iter=n_iter, tol=tol, init=init)[0]


def em_fit_on_support(
    domain: PatrolDomain,
    series_list: Sequence[np.ndarray],
    *,
    n_iter: int = 20,
    tol: float = 1e-4,
    min_count: float = 1e-9,
) -> tuple[sp.csr_array, tuple[float, ...]]:
    """:func:`em_fit` with ``init="intended"`` on T's support.

    The support is each state's distinct intended successors {ψ(s, a')}, the only states EM can
    ever give mass to.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    series_list : sequence of ndarray of int, shape (horizon,)
        One or more of the robot's state series, -1 where it was occluded.
    n_iter : int, default 20
        At most this many EM iterations.
    tol : float, default 1e-4
        Stop when an iteration gains less log-likelihood than this.
    min_count : float, default 1e-9
        An (s, a) or s with no more expected count than this keeps its previous parameters.

    Returns
    -------
    transitions : scipy.sparse.csr_array of shape (S·A, S)
        T(s, a, s'), as :meth:`EMResult.transition_matrix` gives it.
    log_likelihood : tuple of float
        After the E-step of each iteration.
    """
    S, A = domain.n_states, domain.n_actions
    succ = np.sort(domain.intended, axis=1)  # (S, A): successors, repeats kept last
    distinct = np.ones_like(succ, dtype=bool)
    distinct[:, 1:] = succ[:, 1:] != succ[:, :-1]
    K = A
    # T[s, a, k] over the k-th successor slot; repeated slots carry no mass
    T = np.repeat((distinct / distinct.sum(axis=1, keepdims=True))[:, None, :], A, axis=1)
    pi = np.full((S, A), 1.0 / A)
    rows = np.repeat(np.arange(S), K)
    series = _check_series(series_list, S)
    history: list[float] = []
    for _ in range(n_iter):
        Pk = np.einsum("sa,sak->sk", pi, T)  # (S, K) chain P(s, succ[s, k])
        chain = sp.csr_array((Pk.ravel(), (rows, succ.ravel())), shape=(S, S))
        pair = np.zeros((S, K))
        loglik = 0.0
        for x in series:
            alpha, scale, b = _forward_backward_sparse(chain, x, S)
            loglik += float(np.log(scale).sum())
            for k in range(K):
                pair[:, k] += np.einsum("ts,ts->s", alpha[:-1], b[:, succ[:, k]])
        # a repeated successor slot shares its state's pair count: keep it once
        pair = np.where(distinct, pair * Pk, 0.0)
        history.append(loglik)
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(Pk[:, None, :] > 0, pi[:, :, None] * T / Pk[:, None, :], 0.0)
        N = pair[:, None, :] * share  # (S, A, K)
        T, pi = _m_step(N, T, pi, min_count)
        if len(history) > 1 and history[-1] - history[-2] < tol:
            break
    data = T.reshape(S * A, K)
    cols = np.repeat(succ, A, axis=0)  # (S·A, K)
    matrix = sp.csr_array(
        (data.ravel(), (np.repeat(np.arange(S * A), K), cols.ravel())), shape=(S * A, S)
    )
    matrix.eliminate_zeros()
    return matrix, tuple(history)


def _forward_backward_sparse(
    chain: sp.csr_array, x: np.ndarray, S: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scaled forward–backward of :func:`expected_counts` with a sparse chain (uniform prior,
    occluded steps free): α (n, S), the scales (n,) and e_{t+1}·β_{t+1}/c_{t+1} (n−1, S). An
    observed step's evidence keeps one state, so it is applied by index, not as an (n, S) mask.
    """
    n = len(x)
    chain_t = chain.T.tocsr()
    alpha, scale = np.empty((n, S)), np.empty(n)
    for t in range(n):
        a = np.full(S, 1.0 / S) if t == 0 else chain_t @ alpha[t - 1]
        if x[t] >= 0:
            a = np.where(np.arange(S) == x[t], a, 0.0)
        scale[t] = a.sum()
        if scale[t] <= 0:
            raise ValueError(f"observations impossible under the model at t={t}")
        alpha[t] = a / scale[t]
    b = np.empty((n - 1, S))  # e_{t+1}·β_{t+1}/c_{t+1}
    beta = np.ones(S)
    for t in range(n - 2, -1, -1):
        if x[t + 1] >= 0:
            beta = np.where(np.arange(S) == x[t + 1], beta, 0.0)
        b[t] = beta / scale[t + 1]
        beta = chain @ b[t]
    return alpha, scale, b
