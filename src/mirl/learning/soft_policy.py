"""Soft (maximum-entropy) values and policies: soft policy iteration (Newton's method on the soft
Bellman equation) over T held as dense (S, A, S) for small models and sparse otherwise."""

from __future__ import annotations

import numpy as np
import scipy.linalg.lapack as lapack
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["soft_policy_iteration"]

_gesv = lapack.get_lapack_funcs("gesv", dtype=np.float64)
_DENSE_LIMIT = 200  # states up to which linear solves are dense (sparse LU: 2.4x faster at 428)


# ---- soft values -------------------------------------------------------------------------------
class _Dynamics:
    """T with the operations the solvers need; dense (S, A, S) for small models, sparse else."""

    def __init__(self, transitions: sp.csr_array, n_actions: int) -> None:
        self.T = sp.csr_array(transitions)
        self.S = self.T.shape[1]
        self.A = n_actions
        self.rows = np.repeat(np.arange(self.S * self.A), np.diff(self.T.indptr))
        self.dense = None
        self._system: _PolicySystem | None = None  # I − γP_π's pattern (sparse models)
        if self.S <= _DENSE_LIMIT:
            self.dense = self.T.toarray().reshape(self.S, self.A, self.S)
        # fixed sparsity pattern of P_πᵀ: entry (s', s) collects T(s, a, s') over actions a
        S = self.S
        key = self.T.indices * S + self.rows // self.A
        uniq, self._pt_pos = np.unique(key, return_inverse=True)
        self._pt_indices = uniq % S
        self._pt_indptr = np.searchsorted(uniq // S, np.arange(S + 1))

    def transposed_policy(self, w: np.ndarray) -> sp.csr_array:
        """P_πᵀ (S, S) as CSR for π = ``w`` (S, A); for ``w`` of shape (S, A, K) the K matrices
        Σ_a w[s, a, k] T(s, a, ·), transposed and stacked into one (K·S, S) CSR."""
        S, nnz = self.S, len(self._pt_indices)
        flat = w.reshape(S * self.A, -1)[self.rows] * self.T.data[:, None]
        data = np.concatenate(
            [
                np.bincount(self._pt_pos, weights=flat[:, k], minlength=nnz)
                for k in range(flat.shape[1])
            ]
        )
        K = flat.shape[1]
        indptr = (self._pt_indptr[None, :-1] + nnz * np.arange(K)[:, None]).ravel()
        indptr = np.append(indptr, K * nnz)
        indices = np.tile(self._pt_indices, K)
        return sp.csr_array((data, indices, indptr), shape=(K * S, S))

    def transition_weights(self, W: np.ndarray) -> np.ndarray:
        """Σ_s' T(s, a, s') W(s', s) as (S, A), for W given on P_πᵀ's pattern (what
        ``transposed_policy`` puts there): the contraction that turns ∂/∂P_πᵀ into ∂/∂π."""
        weights = W[self._pt_pos] * self.T.data
        return np.bincount(self.rows, weights=weights, minlength=self.S * self.A).reshape(
            self.S, self.A
        )

    def transition_values(self, s: np.ndarray, s_next: np.ndarray) -> np.ndarray:
        """T(s_i, a, s_next_i) for every action, (n, A)."""
        if self.dense is not None:
            return self.dense[s, :, s_next]
        if len(s) == 0:  # scipy returns an empty sparse array, not an ndarray, for no index
            return np.zeros((0, self.A))
        rows = (np.asarray(s)[:, None] * self.A + np.arange(self.A)).ravel()
        cols = np.repeat(np.asarray(s_next), self.A)  # entries looked up, not rows densified
        return np.asarray(self.T[rows, cols]).reshape(len(s), self.A)

    def next_values(self, V: np.ndarray) -> np.ndarray:
        """E[V(s') | s, a] as (S, A) (or (S, A, K) for V of shape (S, K))."""
        if self.dense is not None:  # np.tensordot's own product, without its set-up costs
            flat = self.dense.reshape(self.S * self.A, self.S)
            return np.dot(flat, V.reshape(self.S, -1)).reshape(self.S, self.A, *V.shape[1:])
        return (self.T @ V).reshape(self.S, self.A, *V.shape[1:])

    def policy_matrix(self, pi: np.ndarray):
        """P_π (S, S): dense ndarray for small models, CSR otherwise (π may be any weights)."""
        if self.dense is not None:
            return np.einsum("sa,sat->st", pi, self.dense)
        return _policy_matrix(self.T, self.rows, pi, self.S)

    def solve(self, P, discount: float, b: np.ndarray) -> np.ndarray:
        """Solve (I − γ P) x = b for one or several right-hand sides."""
        if self.dense is not None:
            return _dense_solve(np.eye(self.S) - discount * P, np.asarray(b, dtype=float))
        A = sp.csc_array(sp.eye_array(self.S) - discount * P)
        return spla.splu(A).solve(np.asarray(b, dtype=float))

    def solve_policy(self, pi: np.ndarray, discount: float, b: np.ndarray) -> np.ndarray:
        """Solve (I − γ P_π) x = b: :meth:`solve` with P_π, its sparse matrix built from π."""
        if self.dense is None:
            if self._system is None:
                self._system = _PolicySystem(self.T, self.rows, self.A)
            x = self._system.solve(pi, discount, b)
            if x is not None:
                return x
        return self.solve(self.policy_matrix(pi), discount, b)


def _dense_solve(M: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``scipy.linalg.solve(M, b)`` by LAPACK's gesv directly: the same LU and solve (bitwise the
    same result), without solve's condition estimate and checks, which cost as much as the solve
    itself at these sizes (0.21 vs 0.10 ms for 124 states)."""
    x, info = _gesv(M, b)[2:]
    if info != 0:
        raise np.linalg.LinAlgError(f"singular matrix (gesv info {info})")
    return x


def _policy_matrix(T: sp.csr_array, rows: np.ndarray, pi: np.ndarray, n_states: int):
    """P_π (S, S) as CSR from T (S·A, S) and a stochastic policy (S, A)."""
    n_actions = pi.shape[1]
    data = T.data * pi.ravel()[rows]
    return sp.csr_array((data, (rows // n_actions, T.indices)), shape=(n_states, n_states))


class _PolicySystem:
    """I − γ P_π as the CSC array scipy makes of ``eye − γ·P_π`` (P_π from T and π as
    :func:`_policy_matrix` builds it), value for value and in the same order (tested), but
    gathered straight into a pattern fixed by T: the COO sort, the binary operation and the
    format conversion cost more than the LU itself on the office (3 804 states).

    Each entry of P_π sums its actions in T's order, as scipy's duplicate summing does; scipy
    then drops exact zeros (an action of probability 0), and so :meth:`matrix` returns None
    there and the caller takes scipy's way.

    :meth:`solve` factorises it with the column order of its first factorisation: SuperLU's
    COLAMD ordering reads only the pattern, which is fixed, yet scipy recomputes it for every
    matrix (a quarter of each LU on the office: 1.5 against 2.05 ms). The matrix is handed over
    with its columns already in that order and ``permc_spec="NATURAL"``: the same elimination,
    so the same solution bit for bit — except where a column holds tied pivot candidates (seen
    only with near-deterministic policies), which SuperLU's preference for the diagonal breaks
    differently: equal to ~1e-14 there (both tested)."""

    def __init__(self, T: sp.csr_array, rows: np.ndarray, n_actions: int) -> None:
        S = T.shape[1]
        states = rows // n_actions
        # column-major keys: entry (row s, column s') of I − γP_π; P_π's entries and the diagonal
        key_T = T.indices.astype(np.int64) * S + states
        key_diag = np.arange(S, dtype=np.int64) * (S + 1)
        uniq = np.unique(np.concatenate([key_T, key_diag]))
        self._at_T = np.searchsorted(uniq, key_T)
        self._at_diag = np.searchsorted(uniq, key_diag)
        self._off_diag = np.ones(len(uniq), dtype=bool)
        self._off_diag[self._at_diag] = False
        self._indices = (uniq % S).astype(T.indices.dtype)
        self._indptr = np.searchsorted(uniq // S, np.arange(S + 1)).astype(T.indptr.dtype)
        self._weights = T.data
        self._rows = rows
        self._shape = (S, S)
        # after the first factorisation: (order, indptr, indices, take) — column k of the
        # ordered matrix is column order[k], its CSC arrays with data = matrix.data[take]
        self.ordering: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def matrix(self, pi: np.ndarray, discount: float) -> sp.csc_array | None:
        flat = pi.reshape(-1)[self._rows]
        p = np.bincount(self._at_T, weights=self._weights * flat, minlength=len(self._indices))
        if not p[self._off_diag].all():
            return None
        data = -(discount * p)
        data[self._at_diag] = 1.0 - discount * p[self._at_diag]
        return sp.csc_array((data, self._indices, self._indptr), shape=self._shape)

    def solve(self, pi: np.ndarray, discount: float, b: np.ndarray) -> np.ndarray | None:
        """x with (I − γP_π) x = b, as ``splu(matrix).solve(b)`` (see the class docstring);
        None where :meth:`matrix` is None."""
        A = self.matrix(pi, discount)
        if A is None:
            return None
        b = np.asarray(b, dtype=float)
        if self.ordering is None:  # the first factorisation finds the order (COLAMD)
            lu = spla.splu(A)
            order = np.argsort(lu.perm_c)
            self.ordering = (order, *_columns_in(A, order))
            return lu.solve(b)
        order, indptr, indices, take = self.ordering
        ordered = sp.csc_array((A.data[take], indices, indptr), shape=self._shape)
        y = spla.splu(ordered, permc_spec="NATURAL").solve(b)
        x = np.empty_like(y)
        x[order] = y
        return x


def _columns_in(A: sp.csc_array, order: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, take) of A[:, order] in CSC: its data is ``A.data[take]``."""
    lengths = np.diff(A.indptr)[order]
    indptr = np.concatenate(([0], np.cumsum(lengths))).astype(A.indptr.dtype)
    take = np.repeat(A.indptr[order] - indptr[:-1], lengths) + np.arange(indptr[-1])
    return indptr, A.indices[take], take


def _row_sum(X: np.ndarray) -> np.ndarray:
    """``X.sum(axis=1)`` for (S, A) X, a column at a time. numpy sums a row shorter than 8 from
    +0.0, left to right, and so does this: the same result bit for bit (tested, signed zeros
    included; 8 or more are summed pairwise, so they keep numpy's sum). Along the short axis
    numpy pays a loop per row: 81 against 13 µs on the office's (3 804, 4) tables."""
    if not 2 <= X.shape[1] < 8:
        return X.sum(axis=1)
    out = X[:, 0] + 0.0
    for a in range(1, X.shape[1]):
        out += X[:, a]
    return out


def _row_max(X: np.ndarray) -> np.ndarray:
    """``X.max(axis=1)``, a column at a time (158 against 9 µs on the office). The same values;
    where the maximum is a zero its sign may differ from numpy's (whose own code paths differ
    on it with the row length), which no output of :func:`_softmax` can see."""
    out = X[:, 0].copy()
    for a in range(1, X.shape[1]):
        np.maximum(out, X[:, a], out=out)
    return out


def _softmax(Q: np.ndarray, temperature: float) -> tuple[np.ndarray, np.ndarray]:
    # m's zero sign cannot show: Q − (±0) and ±0 + τ·log(tot) round alike (tot ≥ 1)
    m = _row_max(Q)
    z = np.exp((Q - m[:, None]) / temperature)
    tot = _row_sum(z)
    return z / tot[:, None], m + temperature * np.log(tot)


def soft_policy_iteration(
    transitions: sp.csr_array | _Dynamics,
    rewards: np.ndarray,
    discount: float,
    *,
    temperature: float = 1.0,
    initial_values: np.ndarray | None = None,
    tol: float = 1e-8,
    max_iter: int = 100,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Maximum-entropy values by soft policy iteration: evaluate π exactly, then π ∝ exp(Q/τ).

    This is Newton's method on the soft Bellman equation V = τ log Σ_a exp(Q/τ): it converges
    quadratically, typically in 3–6 linear solves from a warm start.

    Parameters
    ----------
    transitions : scipy.sparse.csr_array of shape (S*A, S), or _Dynamics
        T, or the solvers' prepared form of it.
    rewards : ndarray of shape (S, A)
        R(s, a).
    discount : float
        The discount γ, below 1.
    temperature : float, default 1.0
        The temperature τ.
    initial_values : ndarray of shape (S,), optional
        A warm start; zeros by default.
    tol : float, default 1e-8
        Stop when no value changes by this much in one iteration.
    max_iter : int, default 100
        At most this many policy evaluations.

    Returns
    -------
    V : ndarray of shape (S,)
        Soft values.
    Q : ndarray of shape (S, A)
        Soft Q-values.
    pi : ndarray of shape (S, A)
        π(a|s) = exp((Q − V)/τ).
    iterations : int
        The evaluations made.
    """
    S, A = rewards.shape
    dyn = transitions if isinstance(transitions, _Dynamics) else _Dynamics(transitions, A)
    V = np.zeros(S) if initial_values is None else np.asarray(initial_values, dtype=float)
    Q = rewards + discount * dyn.next_values(V)
    pi, V_soft = _softmax(Q, temperature)
    for it in range(1, max_iter + 1):
        # evaluate π: V = Σ_a π (R − τ log π) + γ P_π V
        log_pi = (Q - V_soft[:, None]) / temperature
        b = _row_sum(pi * (rewards - temperature * log_pi))
        V = dyn.solve_policy(pi, discount, b)
        Q = rewards + discount * dyn.next_values(V)
        pi, V_soft = _softmax(Q, temperature)
        if np.abs(V_soft - V).max() < tol:
            return V_soft, Q, pi, it
    return V_soft, Q, pi, max_iter
