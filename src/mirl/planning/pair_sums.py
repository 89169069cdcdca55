"""The pair filter's two sparse sums, computed over their non-zero terms only, bit for bit as
the dense products they stand for (each output adds the same non-zero terms in the same order,
starting from 0; the dense products' other terms are exact zeros): the meeting part of a
propagation step (:class:`MeetingStep`) and P(both robots see L's cell) (:class:`PairSightings`).
The terms are listed in that order (CSR maps for scipy's mat-vec kernel, ``np.bincount``). A
re-plan propagates ~100 steps of the S² joint and sums its sightings at each, and as dense
products these two sums are half of a re-plan's time."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mirl.sparse import csr_block_matvec, linear_map

__all__ = ["MeetingStep", "PairSightings"]


class MeetingStep:
    """M_Iᵀ (B∘m) M_J for the few meeting states of m, bit for bit as the sparse products give it.

    On boyd2 ~400 of 15 376 states meet (as products, 30 % of a propagation step). Each output
    element adds the same non-zero terms in the same order — the CSR order of the row of M_Iᵀ,
    then of M_Jᵀ — starting from 0; the products' other terms are exact zeros. Each stage is a
    fixed CSR map whose rows list their terms in that order, which scipy's mat-vec kernel adds
    left to right from 0 (``np.bincount`` gives the same sums at 1.7× the time).

    Parameters
    ----------
    meet : ndarray of shape (S, S)
        The meeting mask m of the pair's joint states (non-zero where they meet).
    mixed_T : list of scipy.sparse.csr_array of shape (S, S)
        M_Iᵀ and M_Jᵀ, each robot's equilibrium-mixed one-step matrix, transposed.
    """

    def __init__(self, meet: np.ndarray, mixed_T: list[sp.csr_array]) -> None:
        S = meet.shape[0]
        self.at = np.flatnonzero(meet)  # flat (s_I·S + s_J) meeting states
        s_i, s_j = np.divmod(self.at, S)
        # stage 1: X = M_Iᵀ (B∘m), X[a, s_J] = Σ M_Iᵀ[a, s_I]·B[s_I, s_J]
        self._src1, self._coef1, a, sj = self._terms(mixed_T[0], s_i, s_j, S)
        self._x_at, self._dst1 = np.unique(sj * S + a, return_inverse=True)  # X's non-zeros
        # stage 2: Y = M_Jᵀ Xᵀ = (X M_J)ᵀ, Y[b, a] = Σ M_Jᵀ[b, s_J]·X[a, s_J], kept as Y (the
        # caller's transposed output)
        x_sj, x_a = np.divmod(self._x_at, S)
        self._src2, self._coef2, b, a2 = self._terms(mixed_T[1], x_sj, x_a, S)
        self._out_at, self._dst2 = np.unique(b * S + a2, return_inverse=True)
        self._maps = tuple(  # rows: every X (Y) entry; terms in input order
            (len(rows), n_in, *linear_map(dst, np.arange(len(dst)), src, coef, np.int64)[1])
            for rows, n_in, dst, src, coef in (
                (self._x_at, len(self.at), self._dst1, self._src1, self._coef1),
                (self._out_at, len(self._x_at), self._dst2, self._src2, self._coef2),
            )
        )

    @staticmethod
    def _terms(A: sp.csr_array, inner: np.ndarray, outer: np.ndarray, S: int):
        """The terms of A @ V for a sparse V with entries e at (inner[e], outer[e]), in the
        order the CSR kernel adds them: per non-zero A[r, j] (CSR order), one term per entry
        with inner == j. Returns each term's entry, coefficient A[r, j], r and outer."""
        order = np.argsort(inner, kind="stable")
        starts = np.searchsorted(inner[order], np.arange(S + 1))
        r = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
        counts = starts[A.indices + 1] - starts[A.indices]
        nz = np.repeat(np.arange(A.nnz), counts)  # which A non-zero each term comes from
        offset = np.arange(len(nz)) - np.repeat(np.cumsum(counts) - counts, counts)
        src = order[np.repeat(starts[A.indices], counts) + offset]
        return src, A.data[nz], r[nz], outer[src]

    def add_to(self, out_t: np.ndarray, met: np.ndarray) -> None:
        """Add the meeting term into ``out_t``.

        Parameters
        ----------
        out_t : ndarray of shape (S*S,)
            The step's result, flat and transposed ([b·S + a]), added into in place.
        met : ndarray
            The belief B at the meeting states :attr:`at`.
        """
        (n_x, n_met, ptr1, idx1, val1), (n_out, _, ptr2, idx2, val2) = self._maps
        x, y = np.zeros(n_x), np.zeros(n_out)
        csr_block_matvec(n_x, n_met, 1, ptr1, idx1, val1, met, x)
        csr_block_matvec(n_out, n_x, 1, ptr2, idx2, val2, x, y)
        out_t[self._out_at] += y  # unique positions: out + y, element by element


class PairSightings:
    """P(both robots see cell c), summed in the order a dense product summed it.

    P = Σ_{s_I} Σ_{s_J} p[s_I, s_J]·D[s_I, c]·D[s_J, c] for a stack of joint beliefs, summed as
    ``((B @ D) * D).sum(axis=1)`` summed it: over the states that see c in ascending order, s_J
    inside, s_I outside. (OpenBLAS's kernel adds along the inner dimension in order, so that
    product gave these very bits; with D 0/1 and 10 % full on boyd2 the dense product was ~10×
    the work.)

    Parameters
    ----------
    D : ndarray of shape (S, C)
        The 0/1 detection matrix, dense.
    """

    def __init__(self, D: np.ndarray) -> None:
        S, self.n_cells = D.shape
        pos, inner, cell = [], [], []
        n_inner = 0
        for c in range(self.n_cells):
            w = np.flatnonzero(D[:, c])  # ascending
            pos.append((w[:, None] * S + w[None, :]).ravel())  # row s_I, then s_J
            inner.append(np.repeat(n_inner + np.arange(len(w)), len(w)))
            cell.append(np.full(len(w), c))
            n_inner += len(w)
        self._pos = np.concatenate(pos).astype(np.intp)
        self._inner = np.concatenate(inner).astype(np.intp)  # (c, s_I) group of each term
        self._cell = np.concatenate(cell).astype(np.intp)  # cell of each (c, s_I) group
        self._n_inner = n_inner

    def both(self, belief: np.ndarray) -> np.ndarray:
        """P(both robots see cell c) for every cell.

        Parameters
        ----------
        belief : ndarray of shape (S*S,)
            A flat joint belief.

        Returns
        -------
        ndarray of shape (C,)
            The probability per L cell.
        """
        inner = np.bincount(self._inner, belief[self._pos], self._n_inner)  # Σ over s_J
        return np.bincount(self._cell, inner, self.n_cells)  # Σ over s_I
