"""The exact forward filter over two robots' joint state behind the weighing of equilibria
(:func:`mirl.learning.equilibria.joint_log_likelihood`).

The joint belief is an S × S matrix M; a step is M ← Pᵢᵀ (M off meetings) Pⱼ + Gᵢᵀ (M at meetings)
Gⱼ, where P are the robots' ε-greedy policy steps and G the equilibrium's game moves. Each step
here adds the same products in the same order as the plain form (two dense-by-sparse products
of the whole S × S matrix, and scipy's sparse-sparse kernel for the meeting part), so the
likelihood is bit for bit the plain one (``tests/joint_filter_reference.py``), but it skips
what is known to be zero:

* after a step at which L saw robot I, M is zero off that robot's row, so the next step is an
  outer product of two vectors (and after one at which it saw J, the product of Pᵢᵀ with the few
  columns J can reach) instead of two S × S × nnz products — exactly, since a sum of exact zeros
  and one product is that product;
* the meeting part is two fixed linear maps from the few hundred meeting values to the entries
  they reach (their order of summation that of scipy's kernel), instead of a sparse-sparse
  product whose structure is rebuilt at every step.

Written by hand because it is a filter loop: numpy and scipy supply every product in it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mirl.sparse import csr_block_matvec, linear_map

__all__ = ["JointFilter", "MeetingMaps"]


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
    its stored order. The two maps below sum the same terms in the same orders (an entry that is
    zero adds an exact zero, as the kernel's dropped entries do not), so the result is bitwise
    the kernel's; their structure is built once rather than at every step."""

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
        """``out`` (C-contiguous) += Gᵢᵀ (M at meetings) Gⱼ."""
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
    """One step of the joint belief of two robots (module docstring). ``PT``, ``GT``: per robot
    the transposed ε-greedy policy step and game-move step, (S, S) CSR; ``meet``: (S, S) bool,
    the joint states where the robots' intended moves meet."""

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
        """M one step on. ``seen_i``, ``seen_j``: the states L saw the robots in at the step M
        was conditioned on (-1: not seen), where M is zero off that row (column)."""
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
