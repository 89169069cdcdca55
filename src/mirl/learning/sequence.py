"""The sequence objective's likelihood of everything L saw of one robot (occlusion included):
steps between two observations, and occluded gaps — each propagated as a column of state
distributions, masked to the occluded states, until it re-enters view at the observed state.

Gaps entered from the same state share one column (they are the same distribution until each
re-enters view), so a record of G gaps from U exit states costs U columns, not G.

The gradient wrt the K reward weights is taken in one of two ways, both exact:

* forward mode (:meth:`ObservedSequence.loglik` with the :class:`BlockOperator`): the K
  derivatives of every distribution are propagated alongside it, (2K + 1) products with P_πᵀ
  per step;
* reverse mode (:meth:`ObservedSequence.loglik_reverse`): the filter keeps its history, one
  adjoint pass runs back, and one contraction with dπ/dθ ends it, about 3 products per step
  whatever K, plus per-step bookkeeping that costs more than it saves on small maps.
  ``OccludedMaxEntIRL(gradient="auto")`` picks by size (see there).

**The adjoint.** With the rescaling held constant (it cancels in every ratio the likelihood
reads), step n maps the kept columns z_{n-1} to z_n = B_n z_{n-1} / c_n, with B_1 = P_πᵀ (from
the observed exit state) and B_n = P_πᵀ·diag(occluded) after. The adjoint
μ_n = ∂ log L / ∂(B_n z_{n-1}) runs back as μ_n = e_read / value_read + B_{n+1}ᵀ μ_{n+1} / c_n,
so that

    ∂ log L / ∂P_πᵀ(s', s) = Σ_n Σ_columns μ_n(s') z_{n-1}(s)   (on P_πᵀ's pattern only),

and ∂P_πᵀ(s', s) / ∂θ = Σ_a T(s, a, s') ∂π(a|s)/∂θ ends it (``_Dynamics.transition_weights``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mirl.learning.soft_policy import _Dynamics
from mirl.sparse import csc_block_matvec, csr_block_matvec, csr_scale_columns

__all__ = ["ObservedSequence", "BlockOperator"]


class ObservedSequence:
    """One robot's state series (-1 = occluded) prepared for :meth:`loglik`.

    Parameters
    ----------
    x : ndarray of int, shape (horizon,)
        The state L saw the robot in at each step, -1 where occluded.
    own : ndarray of bool, shape (horizon,)
        The steps that are the robot's own choice (steps leaving other times are skipped).
    dyn : _Dynamics
        The robot's transition model, as the soft solvers hold it.
    n_states : int
        S.
    """

    def __init__(self, x: np.ndarray, own: np.ndarray, dyn: _Dynamics, n_states: int) -> None:
        S = n_states
        H = len(x)
        self._dyn = dyn
        self._scratch: dict[tuple, tuple[list, list]] = {}
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
        # numpy sums an (S, c) block's columns row after row when c >= 2 but a single column
        # pairwise: with several gaps a block down to one column is summed row after row too,
        # so each mass rounds as it would with a column per gap (sharing changes no bit)
        self._sequential_sums = G >= 2
        # per step n: (gaps re-entering view, their states, gaps still unseen at the end)
        self._gap_events = {}
        for n in np.unique(self._gap_steps):
            g = np.flatnonzero(self._gap_steps == n)
            e = self._gap_ends[g]
            self._gap_events[int(n)] = (g[e >= 0], e[e >= 0], g[e < 0])
        self._gap_max = int(self._gap_steps.max(initial=0))
        # columns still needed at step n (a leading block)
        self._live = [int((need >= n).sum()) for n in range(self._gap_max + 1)]
        # step n multiplies an (S, live[n]) block; the blocks of all steps lie one after another
        # in one buffer (the filter's history, which the reverse pass reads back)
        self._block_start = np.concatenate(([0], np.cumsum(self._live[1:]))).tolist()  # columns
        # quiet steps only multiply (no event, no rescaling, not the first or last, and they
        # keep every column, so they write straight into the next step's input); both passes
        # run each stretch of them in a tight loop: quiet_end[n] is the first step from n on
        # that is not quiet, quiet_start[n] the first of the stretch that ends at n
        top, live = self._gap_max, self._live
        quiet = [
            1 < n < top and n not in self._gap_events and n % 8 > 0 and live[n + 1] == live[n]
            for n in range(top + 2)
        ]  # fmt: skip
        self._quiet_end = list(range(top + 2))
        self._quiet_start = list(range(top + 2))
        for n in range(top - 1, 0, -1):
            if quiet[n]:
                self._quiet_end[n] = self._quiet_end[n + 1]
        for n in range(2, top + 1):
            if quiet[n]:
                self._quiet_start[n] = self._quiet_start[n - 1] if quiet[n - 1] else n

    def loglik(self, pi, B, visible, dpi=None):
        """log P(observed series | first observation, π, T), occlusion included; in forward mode.

        Parameters
        ----------
        pi : ndarray of shape (S, A)
            The policy π.
        B : callable or BlockOperator
            Moves a distribution (and its derivatives) one step on: P_πᵀ, or the
            :class:`BlockOperator` when ``dpi`` is given.
        visible : ndarray of bool, shape (S,)
            The observable states.
        dpi : ndarray of shape (S, A, K), optional
            The derivatives dπ/dθ; with them the gradient is computed too.

        Returns
        -------
        loglik : float
            The log-likelihood.
        grad : ndarray of shape (K,)
            Its gradient in θ (zeros without ``dpi``).
        """
        total, grad = self._pairs_loglik(pi, dpi)
        if self._gap_U0.shape[1]:
            K = len(grad)
            hidden = np.tile(~visible, K + 1).astype(float)
            total = self._filter(B, hidden, total, K, grad).loglik
        return total, grad

    def loglik_reverse(self, pi, PT, visible, dpi):
        """:meth:`loglik` and its gradient in reverse mode (an adjoint pass).

        Parameters
        ----------
        pi : ndarray of shape (S, A)
            The policy π.
        PT : scipy.sparse.csr_array of shape (S, S)
            P_πᵀ alone.
        visible : ndarray of bool, shape (S,)
            The observable states.
        dpi : ndarray of shape (S, A, K)
            The derivatives dπ/dθ.

        Returns
        -------
        loglik : float
            The log-likelihood.
        grad : ndarray of shape (K,)
            Its gradient in θ.
        """
        total, grad = self._pairs_loglik(pi, dpi)
        if self._gap_U0.shape[1]:
            hidden = (~visible).astype(float)
            filtered = self._filter(PT, hidden, total, 0, grad, history=True)
            total = filtered.loglik
            grad += self._gap_gradient(filtered, PT, hidden, dpi)
        return total, grad

    def _pairs_loglik(self, pi, dpi):
        """The steps between two observations: Σ log P(s_{t+1} | s_t) and its gradient."""
        K = 0 if dpi is None else dpi.shape[2]
        a, _ = self._pair
        p_ab = np.maximum((pi[a] * self._Tab).sum(axis=1), 1e-300)
        total = float(np.log(p_ab).sum())
        grad = np.zeros(K)
        if K:
            grad += ((dpi[a] * self._Tab[:, :, None]).sum(axis=1) / p_ab[:, None]).sum(axis=0)
        return total, grad

    def _workspace(self, R: int, history: bool, name: str = "filter") -> tuple[list, list]:
        """(blocks, flats): per step n, the (R, live[n]) block it multiplies and the same
        as a flat view (index 0 unused). With ``history`` the blocks lie one after another in
        one buffer (the reverse pass reads them back); without, two buffers take turns. Either
        way a block is zeroed just before it is written (the kernels add into their output),
        while it is about to be in cache. Kept between calls: allocating them anew costs more
        than the filter itself on boyd2."""
        key = (name, R, history)
        if key not in self._scratch:
            live, start, top = self._live, self._block_start, self._gap_max
            if history:
                buffer = np.zeros(R * start[-1])
                flats = [buffer[R * start[n - 1] : R * start[n]] for n in range(1, top + 1)]
            else:
                buffer = np.zeros((2, R * max(live)))
                flats = [buffer[n % 2, : R * live[n]] for n in range(1, top + 1)]
            flats = [flats[0][:0]] + flats
            blocks = [flats[0]] + [f.reshape(R, -1) for f in flats[1:]]
            self._scratch[key] = (blocks, flats)
        return self._scratch[key]

    @property
    def history_size(self) -> int:
        """Entries of the filter's history in reverse mode (S × the columns of all steps)."""
        return self._gap_U0.shape[0] * self._block_start[-1]

    def free_workspace(self) -> None:
        """Drop the buffers kept between calls (they come back at the next call)."""
        self._scratch.clear()

    def _filter(self, B, hidden, total: float, K: int, grad, history: bool = False) -> Filtered:
        """The gaps' forward filter over (K + 1)·S rows (the distributions, then their K
        derivatives, forward mode; ``hidden`` is the occlusion mask tiled to as many rows). Its
        log-likelihood is added to ``total`` and its gradient to ``grad`` term by term, step by
        step, so that the sums round the same at every call; what each step multiplied is kept
        (``inputs[n]``) for the reverse pass.

        One filter loop with its events inline: each gap is a column of state distributions
        propagated until it re-enters view (or the record ends), rescaled every 8 steps against
        underflow."""
        S = B.shape[0] // (K + 1)
        R = B.shape[0]
        col, need, live, top = self._gap_col, self._col_need, self._live, self._gap_max
        inputs, flats = self._workspace(R, history)
        # columns are rescaled as a whole, so ratios stay exact. After the first step (from the
        # observed exit state) a step multiplies by B·diag(occluded): the mask is folded into
        # the operator's columns, so the distributions are masked only where read.
        Z = inputs[1]
        Z.fill(0.0)
        Z[self._col_start, np.arange(len(need))] = 1.0
        log_scale = np.zeros(len(self._gap_steps))
        alive = np.ones(len(self._gap_steps))
        kept = Filtered(inputs=inputs, reads={}, masses={})
        kernel = csr_block_matvec  # one column: scipy's one-vector kernel (2.3x faster there)
        kept.masked = ip, ix, dt = _without_columns(B, hidden == 0.0)
        n = 1
        while n <= top:
            if self._quiet_end[n] > n:  # a stretch of steps that only multiply
                width = live[n]
                for k in range(n, self._quiet_end[n]):
                    flats[k + 1].fill(0.0)
                    kernel(R, R, width, ip, ix, dt, flats[k], flats[k + 1])
                n = self._quiet_end[n]
                continue
            # the step writes straight into the next step's input when it keeps every column
            same = n < top and live[n + 1] == live[n]
            out = inputs[n + 1] if same else np.zeros((R, live[n]))
            if same:
                out.fill(0.0)
            indptr, indices, data = (ip, ix, dt) if n > 1 else (B.indptr, B.indices, B.data)
            kernel(R, R, live[n], indptr, indices, data, flats[n], out.ravel())
            event = self._gap_events.get(n)
            if event is not None:
                hit, ends, tail = event
                if hit.size:  # re-entry into view at the observed state
                    v = np.maximum(out[ends, col[hit]], 1e-300)
                    total += float((np.log(v) + log_scale[hit]).sum())
                    if K:
                        grad += (out.reshape(K + 1, S, live[n])[1:, ends, col[hit]] / v).sum(1)
                if tail.size:  # still unseen at the end of the record
                    Zt = out[:, col[tail]] * hidden[:, None]
                    m = np.maximum(Zt[:S].sum(axis=0), 1e-300)
                    total += float((np.log(m) + log_scale[tail]).sum())
                    if K:
                        grad += (Zt.reshape(K + 1, S, len(tail))[1:].sum(axis=1) / m).sum(1)
                kept.reads[n] = (v if hit.size else None, m if tail.size else None)
                alive[hit] = 0.0
                alive[tail] = 0.0
            if n % 8 == 0:  # rescale against underflow
                mass = self._column_mass(out[:S] * hidden[:S, None])
                mass = np.where(mass > 0, mass, 1.0)
                out /= mass
                kept.masses[n] = mass
                on = alive > 0
                log_scale[on] += np.log(mass[col[on]])
            if n < top and not same:
                inputs[n + 1][...] = out[:, : live[n + 1]]
            n += 1
        kept.loglik = total
        return kept

    def _column_mass(self, block: np.ndarray) -> np.ndarray:
        """Column sums of an (S, c) block; one column row after row when the record has several
        gaps (``_sequential_sums``)."""
        if block.shape[1] == 1 and self._sequential_sums:
            return np.cumsum(block[:, 0])[-1:]  # row after row, as numpy sums c >= 2 columns
        return block.sum(axis=0)

    # -- reverse mode: the adjoint of the gap filter (module docstring) --
    def _gap_gradient(self, filtered, PT, hidden: np.ndarray, dpi: np.ndarray) -> np.ndarray:
        """∂/∂θ of the gaps' log-likelihood, (K,), from a filter run with its history
        (:meth:`_filter` with K = 0) and dπ/dθ (S, A, K)."""
        W = self._pattern_weights(filtered, PT, hidden)
        K = dpi.shape[2]
        return self._dyn.transition_weights(W).reshape(-1) @ dpi.reshape(-1, K)

    def _pattern_weights(self, fil, PT, hidden: np.ndarray) -> np.ndarray:
        """Σ_n Σ_columns μ_n(s') z_{n-1}(s) at each entry (s', s) of P_πᵀ's pattern.

        The backward loop mirrors the filter's: stretches of quiet steps in a tight loop, the
        others with their reads and rescaling."""
        S, live, top = PT.shape[0], self._live, self._gap_max
        ip, ix, dt = fil.masked
        mu, flats = self._workspace(S, True, "adjoint")  # μ_n, laid out as the inputs
        kernel = csc_block_matvec  # B_{n+1}ᵀ μ: the CSR of B_{n+1} read as a CSC matrix
        n = top
        while n >= 1:
            if self._quiet_end[n] > n:  # n is quiet: back down its stretch, only multiplying
                width = live[n]
                for k in range(n, self._quiet_start[n] - 1, -1):
                    flats[k].fill(0.0)
                    kernel(S, S, width, ip, ix, dt, flats[k + 1], flats[k])
                n = self._quiet_start[n] - 1
                continue
            mu[n].fill(0.0)
            if n < top:
                same = live[n + 1] == live[n]
                back = mu[n] if same else np.zeros((S, live[n + 1]))
                kernel(S, S, live[n + 1], ip, ix, dt, flats[n + 1], back.ravel())
                if n in fil.masses:
                    back /= fil.masses[n][: live[n + 1]]
                if not same:
                    mu[n][:, : live[n + 1]] = back
            self._inject(fil, mu[n], n, hidden)
            n -= 1
        keep_at = np.flatnonzero(hidden[PT.indices] > 0)  # P_πᵀ's entries leaving occluded states
        W = np.zeros(PT.nnz)
        rows_masked = np.repeat(np.arange(S), np.diff(ip))
        W[keep_at] = self._sampled((ip, ix, rows_masked), mu, fil.inputs)
        rows = np.repeat(np.arange(S), np.diff(PT.indptr))
        W += np.einsum("ij,ij->i", mu[1][rows], fil.inputs[1][PT.indices])
        return W

    def _inject(self, fil, mu: np.ndarray, n: int, hidden: np.ndarray) -> None:
        """Add ∂ log L / ∂(values read at step n): 1/v at a re-entry's state, mask/m for tails."""
        event = self._gap_events.get(n)
        if event is None:
            return
        hit, ends, tail = event
        v, m = fil.reads[n]
        col = self._gap_col
        if hit.size:
            np.add.at(mu, (ends, col[hit]), 1.0 / v)
        for c, mass in zip(col[tail], m if tail.size else (), strict=True):
            mu[:, c] += hidden / mass

    def _sampled(self, pattern, mu_blocks, input_blocks) -> np.ndarray:
        """Σ over steps n ≥ 2 and their columns of μ_n[rows] · z_{n-1}[cols] at the entries of a
        CSR ``pattern`` (indptr, cols, rows): M Xᵀ sampled there (a sampled dense product, which
        scipy does not provide). One step and column at a time, on buffers that stay in cache: 2.1x
        faster on the office than gathering all steps at once (memory-bound), the same on
        boydright-3. The second factor is gathered and multiplied in one pass by
        :func:`~mirl.sparse.csr_scale_columns` (the same products: 25 → 22 µs a step on the
        office)."""
        live, top = self._live, self._gap_max
        indptr, cols, rows = pattern
        S = len(indptr) - 1
        out = np.zeros(len(rows))
        a = np.empty(len(rows))
        for n in range(2, top + 1):
            for c in range(live[n]):
                # the indices are P_πᵀ's own, always in range: "clip" only skips the bounds check
                # that "raise" makes on every element (a third of each gather's time)
                mu_blocks[n][:, c].take(rows, out=a, mode="clip")
                z = np.ascontiguousarray(input_blocks[n][:, c])  # a view when one column
                csr_scale_columns(S, S, indptr, cols, a, z)  # a *= z[cols]
                out += a
        return out


@dataclass
class Filtered:
    """What the reverse pass needs of a forward filter: ``inputs[n]`` the (S, live) columns step
    n multiplied (views of one buffer), ``reads[n]`` the values read at step n's events
    (re-entries, tails; None where there were none), ``masses[n]`` the rescaling of step n's
    columns, and ``masked`` the CSR arrays of the operator the steps after the first used."""

    inputs: list
    reads: dict
    masses: dict
    masked: tuple = ()
    loglik: float = 0.0


def _without_columns(B, drop: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR arrays of B with the columns ``drop`` removed: B·diag(1 − drop) without its zeros.
    A product with it adds the same terms in the same order as B times the masked vector, less
    exact zeros, so the sums are bitwise those of masking first."""
    keep = ~drop[B.indices]
    indptr = np.concatenate(([0], np.cumsum(keep)))[B.indptr]
    return indptr.astype(B.indptr.dtype), B.indices[keep], B.data[keep]


class BlockOperator:
    """Forward mode's one-step operator for a distribution and its K derivatives, with the
    block pattern kept between calls (``OccludedMaxEntIRL`` holds one per fit)."""

    def __init__(self) -> None:
        self._blocks: tuple | None = None

    def __call__(self, PT: sp.csr_array, dPT: sp.csr_array | None) -> sp.csr_array:
        """P_πᵀ, or with derivatives the block matrix [[Pᵀ, 0, …], [dPᵀ_1, Pᵀ, 0, …], …] that
        moves a distribution and its K derivatives one step on together (forward mode).

        The block pattern is the same at every evaluation (P_πᵀ has a fixed pattern), so it is
        built once and later calls only gather the values into it."""
        if dPT is None:
            return PT
        key = (PT.shape, PT.nnz, dPT.shape, dPT.nnz)
        if self._blocks is None or self._blocks[0] != key:
            # the pattern, with each entry's position in [tile(PT.data), dPT.data] as its value
            n_pt = PT.nnz * (dPT.shape[0] // PT.shape[0] + 1)
            pt = sp.csr_array((np.arange(1.0, PT.nnz + 1), PT.indices, PT.indptr), PT.shape)
            dpt = np.arange(1.0, dPT.nnz + 1) + n_pt
            order = _block_operator(
                pt, sp.csr_array((dpt, dPT.indices, dPT.indptr), dPT.shape), tiled_offsets=PT.nnz
            )
            self._blocks = (key, order.data.astype(np.int64) - 1, order.indices, order.indptr)
        _, position, indices, indptr = self._blocks
        K = dPT.shape[0] // PT.shape[0]
        data = np.concatenate([np.tile(PT.data, K + 1), dPT.data])[position]
        n = (K + 1) * PT.shape[0]
        return sp.csr_array((data, indices, indptr), shape=(n, n))


def _block_operator(PT: sp.csr_array, dPT: sp.csr_array, tiled_offsets: int = 0) -> sp.csr_array:
    """[[Pᵀ, 0, …], [dPᵀ_1, Pᵀ, 0, …], …] as CSR. With ``tiled_offsets`` = PT.nnz, the k-th
    copy of Pᵀ has its values raised by k·PT.nnz (used to number the entries' positions)."""
    S = PT.shape[0]
    K = dPT.shape[0] // S
    pt, d = PT.tocoo(), dPT.tocoo()
    off = np.repeat(np.arange(K + 1) * S, pt.nnz)
    rows = np.concatenate([np.tile(pt.row, K + 1) + off, d.row + S])
    cols = np.concatenate([np.tile(pt.col, K + 1) + off, d.col])
    shift = np.repeat(np.arange(K + 1) * float(tiled_offsets), pt.nnz)
    data = np.concatenate([np.tile(pt.data, K + 1) + shift, d.data])
    n = (K + 1) * S
    return sp.csr_array(sp.coo_array((data, (rows, cols)), shape=(n, n)).tocsr())
