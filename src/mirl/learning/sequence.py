"""The sequence objective's likelihood of everything L saw of one robot (occlusion included):
steps between two observations, and occluded gaps — each propagated as a column of state
distributions, masked to the occluded states, until it re-enters view at the observed state.

Gaps entered from the same state share one column (they are the same distribution until each
re-enters view), so a record of G gaps from U exit states costs U columns, not G (issue 12).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import _sparsetools

from mirl.learning.soft_policy import _Dynamics

__all__ = ["ObservedSequence"]


class ObservedSequence:
    """One robot's (horizon,) state series (-1 = occluded) prepared for :meth:`loglik`; ``own``
    marks the steps that are the robot's own choice (steps leaving other times are skipped)."""

    def __init__(self, x: np.ndarray, own: np.ndarray, dyn: _Dynamics, n_states: int) -> None:
        S = n_states
        H = len(x)
        seen = x >= 0
        pairs = np.flatnonzero(seen[:-1] & seen[1:] & own[:-1])
        self._pair = (x[pairs], x[pairs + 1])
        self._Tab = dyn.transition_values(x[pairs], x[pairs + 1])
        starts, steps, ends = [], [], []
        t = int(np.flatnonzero(seen)[0])  # condition on the first observation
        while t < H:
            if seen[t]:
                t += 1
                continue
            u = t
            while t < H and not seen[t]:
                t += 1
            # occluded run u .. t-1, entered from the observed x[u-1]
            e = np.zeros(S)
            e[x[u - 1]] = 1.0
            starts.append(e)
            steps.append(t - u + 1)
            ends.append(x[t] if t < H else -1)
            if t >= H:  # trailing gap: the last prediction is still occluded, no end state
                steps[-1] -= 1
        self._gap_U0 = np.array(starts).T if starts else np.zeros((S, 0))
        self._gap_steps = np.array(steps, dtype=int)
        self._gap_ends = np.array(ends, dtype=int)
        self._prepare_gap_columns()

    def _prepare_gap_columns(self) -> None:
        """Gaps entered from the same state share one propagated column (they are the same
        distribution until each re-enters view); columns are ordered by how long they are
        needed, so the ones still needed are always a leading block."""
        G = self._gap_U0.shape[1]
        start = self._gap_U0.argmax(axis=0) if G else np.zeros(0, dtype=int)
        uniq, col = np.unique(start, return_inverse=True)
        need = np.zeros(len(uniq), dtype=int)
        np.maximum.at(need, col, self._gap_steps)
        order = np.argsort(-need, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        self._gap_col = rank[col]  # gap -> its column
        self._col_start = uniq[order]
        self._col_need = need[order]
        # columns kept: at least two when there are several gaps, so that column sums reduce
        # exactly as they did with one column per gap (numpy sums one column pairwise)
        self._min_cols = min(2, G)
        # per step n: (gaps re-entering view, their states, gaps still unseen at the end)
        self._gap_events = {}
        for n in np.unique(self._gap_steps):
            g = np.flatnonzero(self._gap_steps == n)
            e = self._gap_ends[g]
            self._gap_events[int(n)] = (g[e >= 0], e[e >= 0], g[e < 0])
        self._gap_max = int(self._gap_steps.max(initial=0))
        # columns still needed at step n (a leading block), never fewer than _min_cols
        self._live = [max(int((need >= n).sum()), self._min_cols) for n in range(self._gap_max + 1)]
        # quiet steps only multiply (no event, no fewer columns, no rescaling, not the first):
        # _quiet_end[n] is the first step from n on that is not quiet
        self._quiet_end = list(range(self._gap_max + 2))
        for n in range(self._gap_max - 1, 1, -1):
            if n not in self._gap_events and self._live[n] == self._live[n - 1] and n % 8:
                self._quiet_end[n] = self._quiet_end[n + 1]

    def loglik(self, pi, B, visible, dpi=None):
        """log P(observed series | first observation, π, T), occlusion included; with ``dpi``
        (S, A, K) = dπ/dθ also its gradient. ``B`` moves a distribution and its derivatives one
        step on (``OccludedMaxEntIRL._forward_operator``); ``visible``: the observable states.

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
        n_cols = max(len(need), self._min_cols)
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
            quiet_end = self._quiet_end[n]
            if quiet_end > n:  # a run of steps that only multiply, in a tight loop
                live = Z.shape[1]
                for _ in range(quiet_end - n):
                    out_flat.fill(0.0)
                    kernel(R, R, live, ip, ix, dt, z_flat, out_flat)
                    z_flat, out_flat = out_flat, z_flat
                if (quiet_end - n) % 2:
                    Z, out = out, Z
                n = quiet_end
                continue
            live = self._live[n]
            if live < Z.shape[1]:
                Z = np.ascontiguousarray(Z[:, :live])
                out = np.empty_like(Z)
                z_flat, out_flat = Z.ravel(), out.ravel()
            out.fill(0.0)  # Z ← B Z by the kernel behind `B @ Z` (mirl.mdp.csr_matmul)
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


def _without_columns(B, drop: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR arrays of B with the columns ``drop`` removed: B·diag(1 − drop) without its zeros.
    A product with it adds the same terms in the same order as B times the masked vector, less
    exact zeros, so the sums are bitwise those of masking first."""
    keep = ~drop[B.indices]
    indptr = np.concatenate(([0], np.cumsum(keep)))[B.indptr]
    return indptr.astype(B.indptr.dtype), B.indices[keep], B.data[keep]
