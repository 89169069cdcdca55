"""Tabular MDP core: sparse transitions, value iteration (hard and soft), backward induction,
policies and state-visitation by forward propagation of distributions.

Transitions are a CSR matrix of shape (S*A, S) whose row ``s*A + a`` is T(s, a, ·). Every
solver is vectorised over states: one sparse mat-vec per sweep, no Python loop over states.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from mirl._validation import Interval, OptionError, check_argument
from mirl.sparse import csr_block_matvec

__all__ = [
    "TabularMDP",
    "SolveResult",
    "FiniteHorizonResult",
    "value_iteration",
    "soft_value_iteration",
    "backward_induction",
    "greedy_policy",
    "optimal_action_mask",
    "policy_matrix",
    "state_visitation",
    "validate_transitions",
    "actions_first",
]


def validate_transitions(transitions: sp.spmatrix | sp.sparray, n_actions: int) -> sp.csr_array:
    """Return ``transitions`` as CSR after checking shape, non-negativity and row sums.

    Parameters
    ----------
    transitions : sparse matrix or array of shape (S*A, S)
        T(s, a, s') in row ``s*A + a``.
    n_actions : int
        A, the number of actions.

    Returns
    -------
    scipy.sparse.csr_array of shape (S*A, S)
        The same probabilities as floats in CSR.

    Raises
    ------
    ValueError
        The shape is not (S*A, S), an entry is negative or not finite, or a row does not sum
        to 1 (the message names the first such (s, a)).
    """
    P = sp.csr_array(transitions, dtype=float)
    if P.ndim != 2:
        raise ValueError(f"transitions must be a 2-D (S*A, S) matrix, got shape {P.shape}")
    rows, n_states = P.shape
    if rows != n_states * n_actions:
        raise ValueError(
            f"transitions must have shape (S*A, S) = ({n_states * n_actions}, {n_states}), "
            f"got {P.shape}"
        )
    if not np.isfinite(P.data).all():
        raise ValueError("transitions contain non-finite values (NaN or inf)")
    if P.nnz and P.data.min() < -1e-12:
        raise ValueError("transitions contain negative probabilities")
    sums = np.asarray(P.sum(axis=1)).ravel()
    bad = np.flatnonzero(np.abs(sums - 1.0) > 1e-8)
    if bad.size:
        s, a = divmod(int(bad[0]), n_actions)
        raise ValueError(f"T(s={s}, a={a}, ·) sums to {sums[bad[0]]:.6g}, not 1")
    return P


@dataclass(frozen=True)
class TabularMDP:
    """A discounted tabular MDP with sparse transitions of shape (S*A, S) and rewards R(s, a).

    Parameters
    ----------
    transitions : sparse matrix or array of shape (S*A, S)
        T(s, a, s') in row ``s*A + a``; checked by :func:`validate_transitions` and kept as CSR.
    rewards : ndarray of shape (S, A)
        R(s, a).
    discount : float, default 0.95
        The discount γ, in [0, 1).

    Raises
    ------
    ValueError
        Rewards that are not 2-D, transitions that disagree with them or are not stochastic, or a
        discount outside [0, 1).
    """

    transitions: sp.csr_array
    rewards: np.ndarray
    discount: float = 0.95

    def __post_init__(self) -> None:
        rewards = np.asarray(self.rewards, dtype=float)
        if rewards.ndim != 2:
            raise ValueError(f"rewards must be (S, A), got shape {rewards.shape}")
        if not np.isfinite(rewards).all():  # value iteration would run every sweep to NaNs
            s, a = np.argwhere(~np.isfinite(rewards))[0]
            bad = rewards[s, a]
            raise ValueError(f"rewards contain non-finite values: R(s={s}, a={a}) = {bad}")
        object.__setattr__(self, "rewards", rewards)
        object.__setattr__(
            self, "transitions", validate_transitions(self.transitions, rewards.shape[1])
        )
        if self.transitions.shape[1] != rewards.shape[0]:
            raise ValueError(
                f"transitions have {self.transitions.shape[1]} states, rewards {rewards.shape[0]}"
            )
        real = isinstance(self.discount, numbers.Real) and not isinstance(self.discount, bool)
        if not (real and 0.0 <= self.discount < 1.0):
            raise ValueError(f"discount must be in [0, 1), got {self.discount!r}")

    @property
    def n_states(self) -> int:
        """S, the number of states."""
        return self.rewards.shape[0]

    @property
    def n_actions(self) -> int:
        """A, the number of actions."""
        return self.rewards.shape[1]

    def expected_next(self, values: np.ndarray) -> np.ndarray:
        """E[V(s') | s, a] as an (S, A) array.

        Parameters
        ----------
        values : ndarray of shape (S,)
            V(s').

        Returns
        -------
        ndarray of shape (S, A)
            The expected value of the next state for every state and action.
        """
        return (self.transitions @ values).reshape(self.n_states, self.n_actions)


@dataclass(frozen=True)
class SolveResult:
    """Outcome of an infinite-horizon solve (mirrors ``scipy.optimize.OptimizeResult`` fields).

    Parameters
    ----------
    values : ndarray of shape (S,)
        V(s).
    q_values : ndarray of shape (S, A)
        Q(s, a).
    policy : ndarray of shape (S,) or (S, A)
        The greedy actions, or for a soft solve the action probabilities π(a|s).
    iterations : int
        Sweeps made.
    success : bool
        Whether the sweeps converged within the tolerance.
    message : str
        How the solve ended ("converged, delta=…" or "max_iter reached").
    """

    values: np.ndarray
    q_values: np.ndarray
    policy: np.ndarray  # (S,) greedy actions, or (S, A) action probabilities for soft solves
    iterations: int
    success: bool
    message: str


def value_iteration(
    mdp: TabularMDP,
    *,
    tol: float = 1e-8,
    max_iter: int = 10_000,
    initial_values: np.ndarray | None = None,
) -> SolveResult:
    """Discounted value iteration until the sup-norm change is below ``tol``.

    The sweeps run on an actions-first copy of T (row a·S + s) so that Q is (A, S) and the max
    over actions runs along the long axis (3× faster than over the short axis of (S, A), same
    values bit for bit), in preallocated buffers; ``q_values`` is handed back as (S, A).

    Parameters
    ----------
    mdp : TabularMDP
        The MDP to solve.
    tol : float, default 1e-8
        Stop when no value changes by this much in one sweep.
    max_iter : int, default 10000
        At most this many sweeps.
    initial_values : ndarray of shape (S,), optional
        Values to start from (a warm start); zeros by default.

    Returns
    -------
    SolveResult
        V, Q, the greedy policy (the lowest-index optimal action) and whether it converged.

    Raises
    ------
    OptionError
        A ``tol`` that is not a positive number (no sweep could meet it), a ``max_iter`` that
        is not an integer >= 0, or ``initial_values`` not S finite numbers (a ValueError).
    """
    check_argument("tol", tol, Interval(float, 0.0, None, open_low=True))
    check_argument("max_iter", max_iter, Interval(int, 0, None))
    S, A = mdp.n_states, mdp.n_actions
    if initial_values is not None:
        start = np.asarray(initial_values)
        if start.shape != (S,) or start.dtype.kind not in "iuf" or not np.isfinite(start).all():
            raise OptionError(
                "initial_values", f"must be {S} finite numbers, one per state, got shape "
                f"{start.shape} and dtype {start.dtype}"
            )  # fmt: skip
    T_as = actions_first(mdp.transitions, A)
    R_as = np.ascontiguousarray(mdp.rewards.T)
    # a copy: the sweeps below write into V's buffer
    V = np.zeros(S) if initial_values is None else np.array(initial_values, dtype=float)
    Q, V_new, diff = np.empty((A, S)), np.empty(S), np.empty(S)
    for it in range(1, max_iter + 1):
        _bellman(T_as, R_as, mdp.discount, V, Q)
        _column_max(Q, V_new)
        delta = np.abs(np.subtract(V_new, V, out=diff), out=diff).max(initial=0.0)
        V, V_new = V_new, V
        if delta < tol:
            Q_sa = Q.T
            return SolveResult(
                V, Q_sa, greedy_policy(Q_sa), it, True, f"converged, delta={delta:.2e}"
            )
    Q_sa = _bellman(T_as, R_as, mdp.discount, V, Q).T
    return SolveResult(V, Q_sa, greedy_policy(Q_sa), max_iter, False, "max_iter reached")


def _bellman(
    T_as: sp.csr_array, R_as: np.ndarray, discount: float, V: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """``out[:] = R_as + discount * (T_as @ V).reshape(A, S)`` in place, bit for bit the same
    (the same kernel as ``@``; x·1.0 = x, and + and · commute exactly); returns ``out``."""
    out.fill(0.0)  # the kernel adds into its output, as scipy's ``@`` does into fresh zeros
    M, N = T_as.shape
    csr_block_matvec(M, N, 1, T_as.indptr, T_as.indices, T_as.data, V, out.reshape(-1))
    if discount != 1.0:
        out *= discount
    out += R_as
    return out


def actions_first(transitions: sp.csr_array, n_actions: int) -> sp.csr_array:
    """T (S·A, S) with rows s·A + a reordered to a·S + s (so E[V] reshapes to (A, S)).

    Parameters
    ----------
    transitions : scipy.sparse.csr_array of shape (S*A, S)
        T, states first.
    n_actions : int
        A.

    Returns
    -------
    scipy.sparse.csr_array of shape (A*S, S)
        The same rows, actions first.
    """
    S = transitions.shape[1]
    order = np.arange(S * n_actions).reshape(S, n_actions).T.ravel()
    return sp.csr_array(transitions[order])


def soft_value_iteration(
    mdp: TabularMDP,
    *,
    temperature: float = 1.0,
    tol: float = 1e-8,
    max_iter: int = 10_000,
    initial_values: np.ndarray | None = None,
) -> SolveResult:
    """Maximum-entropy (soft) value iteration: V(s) = τ log Σ_a exp(Q(s,a)/τ).

    Parameters
    ----------
    mdp : TabularMDP
        The MDP to solve.
    temperature : float, default 1.0
        The temperature τ, positive; the policy approaches the greedy one as τ → 0.
    tol : float, default 1e-8
        Stop when no value changes by this much in one sweep.
    max_iter : int, default 10000
        At most this many sweeps.
    initial_values : ndarray of shape (S,), optional
        Values to start from; zeros by default.

    Returns
    -------
    SolveResult
        Soft V and Q, and as ``policy`` the stochastic policy
        π(a|s) = exp((Q(s,a) - V(s))/τ) of shape (S, A).

    Raises
    ------
    ValueError
        A temperature that is not positive.
    """
    if temperature <= 0:
        raise ValueError("temperature must be positive")
    V = np.zeros(mdp.n_states) if initial_values is None else np.asarray(initial_values, float)
    converged = False
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - reported below
        Q = mdp.rewards + mdp.discount * mdp.expected_next(V)
        V_new = temperature * _logsumexp(Q / temperature)
        delta = np.abs(V_new - V).max(initial=0.0)
        V = V_new
        if delta < tol:
            converged = True
            break
    Q = mdp.rewards + mdp.discount * mdp.expected_next(V)
    V = temperature * _logsumexp(Q / temperature)
    pi = np.exp((Q - V[:, None]) / temperature)
    pi /= pi.sum(axis=1, keepdims=True)
    msg = "converged" if converged else "max_iter reached"
    return SolveResult(V, Q, pi, it, converged, msg)


@dataclass(frozen=True)
class FiniteHorizonResult:
    """The outcome of :func:`backward_induction`.

    ``values`` (H+1, S), values[H] the terminal ones, read-only; ``policy`` (H, S) greedy
    actions, the lowest-index maximiser, as the smallest unsigned integer type that holds A.
    The (H, S, A) ``q_values`` are recomputed from ``values`` on first access (bit for bit those
    of the sweeps), so that the sweeps need not write H·S·A floats most callers never read.

    Parameters
    ----------
    values : ndarray of shape (H+1, S)
        V_t(s) for t = 0..H.
    policy : ndarray of shape (H, S)
        The greedy action at every time and state.
    _q_all : callable
        Recomputes the (H, A, S) Q-values; :func:`backward_induction` passes it.
    """

    values: np.ndarray
    policy: np.ndarray
    _q_all: Callable[[], np.ndarray] = field(repr=False, compare=False)  # (H, A, S)

    @cached_property
    def q_values(self) -> np.ndarray:  # (H, S, A)
        """Q_t(s, a), shape (H, S, A), computed on first access."""
        return self._q_all().transpose(0, 2, 1)


def backward_induction(
    transitions: sp.csr_array,
    rewards: np.ndarray,
    horizon: int,
    *,
    terminal_values: np.ndarray | None = None,
    discount: float = 1.0,
) -> FiniteHorizonResult:
    """Finite-horizon dynamic programming.

    One sparse mat-vec per time step, into one (A, S) buffer (actions first, as in
    :func:`value_iteration`, so the max and argmax run along the long axis).

    Parameters
    ----------
    transitions : scipy.sparse.csr_array of shape (S*A, S)
        Stationary dynamics T(s, a, s').
    rewards : ndarray of shape (S, A) or (H, S, A)
        Stationary rewards, or one (S, A) slice per time step.
    horizon : int
        H, the number of decisions (at least 0).
    terminal_values : ndarray of shape (S,), optional
        V_H; zeros by default.
    discount : float, default 1.0
        The discount γ applied to the next step's values.

    Returns
    -------
    FiniteHorizonResult
        V_t for t = 0..H and the greedy policy for t = 0..H-1.

    Raises
    ------
    ValueError
        A negative horizon, or time-indexed rewards with other than ``horizon`` slices.
    """
    rewards = np.asarray(rewards, dtype=float)
    S, A = rewards.shape[-2:]
    if horizon < 0:
        raise ValueError(f"horizon must be at least 0, got {horizon}")
    if rewards.ndim == 3 and rewards.shape[0] != horizon:
        raise ValueError(f"time-indexed rewards must have {horizon} slices, got {rewards.shape[0]}")
    T_as = actions_first(sp.csr_array(transitions), A)
    R_as = np.swapaxes(rewards, -1, -2) if rewards.ndim == 3 else np.ascontiguousarray(rewards.T)
    V = np.zeros((horizon + 1, S))
    if terminal_values is not None:
        V[horizon] = terminal_values

    def q_step(t: int, out: np.ndarray) -> np.ndarray:
        return _bellman(T_as, R_as[t] if rewards.ndim == 3 else R_as, discount, V[t + 1], out)

    policy = np.empty((horizon, S), dtype=np.min_scalar_type(A))
    Q, neq, acc = np.empty((A, S)), np.empty((A, S), dtype=bool), np.empty(S, dtype=bool)
    for t in range(horizon - 1, -1, -1):
        _column_max(q_step(t, Q), V[t])
        _first_max(Q, V[t], policy[t], neq, acc)
    for t_nan in np.flatnonzero(np.isnan(V[:horizon]).any(axis=1)):  # argmax: the first NaN
        policy[t_nan] = q_step(int(t_nan), Q).argmax(axis=0)
    V.flags.writeable = False  # q_values are recomputed from V

    def q_all() -> np.ndarray:
        Q_all = np.empty((horizon, A, S))
        for t in range(horizon):
            q_step(t, Q_all[t])
        return Q_all

    return FiniteHorizonResult(V, policy, q_all)


def _column_max(Q: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``np.max(Q, axis=0, out=out)`` — the same ufunc reduction, without ``np.max``'s wrapper,
    which costs a third of the reduction itself on (4, 3 788) (6.5 against 4.8 µs a sweep)."""
    return np.maximum.reduce(Q, axis=0, out=out)


def _first_max(
    Q: np.ndarray, best: np.ndarray, out: np.ndarray, neq: np.ndarray, acc: np.ndarray
) -> np.ndarray:
    """``out[s]`` = the first a with Q[a, s] == best[s], i.e. ``Q.argmax(axis=0)`` when ``best``
    is Q's column max (A where it is NaN): counts the leading actions below the max in 2A passes
    along the long axis, 10× faster than argmax over axis 0, which copies Q to (S, A) first."""
    np.not_equal(Q, best, out=neq)
    np.copyto(acc, neq[0])
    np.copyto(out, acc)
    for a in range(1, len(Q)):
        np.logical_and(acc, neq[a], out=acc)  # below the max in every action up to a
        np.add(out, acc, out=out)
    return out


def optimal_action_mask(q_values: np.ndarray, *, rtol: float = 1e-9, atol: float = 1e-9):
    """Boolean (..., A) mask of actions whose Q is within tolerance of the best (ties kept).

    Parameters
    ----------
    q_values : ndarray of shape (..., A)
        Q-values, actions last.
    rtol : float, default 1e-9
        Relative tolerance, of the best value's magnitude.
    atol : float, default 1e-9
        Absolute tolerance.

    Returns
    -------
    ndarray of bool, shape (..., A)
        True for every action within ``atol + rtol·|best|`` of the best.
    """
    best = q_values.max(axis=-1, keepdims=True)
    return q_values >= best - (atol + rtol * np.abs(best))


def greedy_policy(q_values: np.ndarray) -> np.ndarray:
    """Deterministic policy: the first action (lowest index) among the optimal ones.

    Parameters
    ----------
    q_values : ndarray of shape (..., A)
        Q-values, actions last.

    Returns
    -------
    ndarray of int, shape (...)
        The chosen action; ties (within :func:`optimal_action_mask`'s tolerance) go to the lowest
        index.
    """
    return optimal_action_mask(q_values).argmax(axis=-1)


def policy_matrix(transitions: sp.csr_array, policy: np.ndarray) -> sp.csr_array:
    """State-to-state matrix P_π (S, S) for a deterministic (S,) or stochastic (S, A) policy.

    Parameters
    ----------
    transitions : scipy.sparse.csr_array of shape (S*A, S)
        T(s, a, s').
    policy : ndarray of shape (S,) or (S, A)
        An action per state, or action probabilities per state.

    Returns
    -------
    scipy.sparse.csr_array of shape (S, S)
        P_π(s, s') = Σ_a π(a|s) T(s, a, s').
    """
    n_states = transitions.shape[1]
    n_actions = transitions.shape[0] // n_states
    policy = np.asarray(policy)
    if policy.ndim == 1:
        rows = np.arange(n_states) * n_actions + policy.astype(int)
        return sp.csr_array(transitions[rows])
    weights = sp.csr_array(
        (policy.ravel(), (np.repeat(np.arange(n_states), n_actions), np.arange(policy.size))),
        shape=(n_states, n_states * n_actions),
    )
    return sp.csr_array(weights @ transitions)


def state_visitation(
    transitions: sp.csr_array,
    policy: np.ndarray,
    initial: np.ndarray,
    steps: int,
) -> np.ndarray:
    """Distributions over states at t = 0..steps, shape (steps+1, S), by forward propagation.

    Parameters
    ----------
    transitions : scipy.sparse.csr_array of shape (S*A, S)
        T(s, a, s').
    policy : ndarray of shape (S,) or (S, A)
        A deterministic or stochastic policy (see :func:`policy_matrix`).
    initial : ndarray of shape (S,)
        The distribution at t = 0.
    steps : int
        How many steps to propagate.

    Returns
    -------
    ndarray of shape (steps+1, S)
        Row t is the distribution over states at time t.
    """
    P_pi = policy_matrix(transitions, policy)
    P_T = sp.csr_array(P_pi.T)
    out = np.empty((steps + 1, P_pi.shape[0]))
    out[0] = initial
    for t in range(steps):
        out[t + 1] = P_T @ out[t]
    return out


def _logsumexp(Q: np.ndarray) -> np.ndarray:
    from scipy.special import logsumexp  # scipy.special costs ~0.1 s to import: only if used

    return logsumexp(Q, axis=1)
