"""The sequence likelihood's first implementation, kept as a reference for the tests: its
gradient in forward mode (the K derivatives propagated alongside the distributions by the block
operator of ``mirl.learning.sequence.BlockOperator``). The library now takes the gradient in
reverse mode (:mod:`mirl.learning.sequence`); both must agree."""

from __future__ import annotations

import numpy as np
from scipy.sparse import _sparsetools

from mirl.learning.sequence import _without_columns


def forward_mode_loglik(self, pi, B, visible, dpi=None):
    """log P(observed series | first observation, π, T), occlusion included; with ``dpi``
    (S, A, K) = dπ/dθ also its gradient. ``B`` moves a distribution and its derivatives one
    step on (``mirl.learning.sequence.BlockOperator``); ``visible``: the observable states.

    Long because the occluded gaps are one filter loop with its events inline: each gap is a
    column of state distributions (and their K derivatives) propagated until it re-enters
    view (or the record ends), rescaled every 8 steps against underflow."""
    K = 0 if dpi is None else dpi.shape[2]
    a, b = self._pair
    p_ab = np.maximum((pi[a] * self._Tab).sum(axis=1), 1e-300)
    total = float(np.log(p_ab).sum())
    grad = np.zeros(K)
    if K:
        grad += ((dpi[a] * self._Tab[:, :, None]).sum(axis=1) / p_ab[:, None]).sum(axis=0)
    G = self._gap_U0.shape[1]
    if G == 0:
        return total, grad
    S = self._gap_U0.shape[0]
    hidden = np.tile(~visible, K + 1).astype(float)[:, None]
    hidden_s = hidden[:S]
    masked = _without_columns(B, hidden[:, 0] == 0.0)
    col, need = self._gap_col, self._col_need
    # at least two columns when there are several gaps (a copy of column 0 if needed), so
    # that column sums reduce as with one column per gap (numpy sums one column pairwise)
    min_cols = min(2, G)
    n_cols = max(len(need), min_cols)
    # rows [k·S, (k+1)·S) of Z: the columns' state distributions (k = 0) and their
    # derivatives wrt θ_k; columns are rescaled as a whole, so ratios stay exact. After the
    # first step (from the observed exit state) Z holds B · (masked Z of the step before):
    # the mask to the occluded states is folded into B's columns, so Z is masked only where
    # it is read (tails, rescaling).
    Z = np.zeros(((K + 1) * S, n_cols))
    Z[self._col_start, np.arange(len(need))] = 1.0
    if n_cols > len(need):  # a copy of column 0, only so that sums reduce as before
        Z[:, len(need)] = Z[:, 0]
    log_scale = np.zeros(G)
    alive = np.ones(G)
    R, kernel = Z.shape[0], _sparsetools.csr_matvecs
    out = np.empty_like(Z)  # two buffers in turn: the step writes one from the other
    z_flat, out_flat = Z.ravel(), out.ravel()
    ip, ix, dt = masked
    n = 1
    while n <= self._gap_max:
        live = max(int((need >= n).sum()), min_cols)
        if live < Z.shape[1]:
            Z = np.ascontiguousarray(Z[:, :live])
            out = np.empty_like(Z)
            z_flat, out_flat = Z.ravel(), out.ravel()
        out.fill(0.0)  # Z ← B Z by the kernel behind `B @ Z` (mirl.sparse.csr_matmul)
        indptr, indices, data = masked if n > 1 else (B.indptr, B.indices, B.data)
        kernel(R, R, live, indptr, indices, data, z_flat, out_flat)
        Z, out, z_flat, out_flat = out, Z, out_flat, z_flat
        event = self._gap_events.get(n)
        if event is not None:
            hit, ends, tail = event
            if hit.size:  # re-entry into view at the observed state
                v = np.maximum(Z[ends, col[hit]], 1e-300)
                total += float((np.log(v) + log_scale[hit]).sum())
                if K:
                    Zk = Z.reshape(K + 1, S, Z.shape[1])
                    grad += (Zk[1:, ends, col[hit]] / v).sum(axis=1)
            if tail.size:  # still unseen at the end of the record
                Zt = Z[:, col[tail]] * hidden
                m = np.maximum(Zt[:S].sum(axis=0), 1e-300)
                total += float((np.log(m) + log_scale[tail]).sum())
                if K:
                    grad += (Zt.reshape(K + 1, S, len(tail))[1:].sum(axis=1) / m).sum(axis=1)
            alive[hit] = 0.0
            alive[tail] = 0.0
        if n % 8 == 0:  # rescale against underflow
            mass = (Z[:S] * hidden_s).sum(axis=0)
            mass = np.where(mass > 0, mass, 1.0)
            Z /= mass
            on = alive > 0
            log_scale[on] += np.log(mass[col[on]])
        n += 1
    return total, grad
