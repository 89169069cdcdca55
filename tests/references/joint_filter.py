"""The exact joint filter of the equilibrium weighing as it was before the per-step rewrite
(commit 9143212), kept as the reference :func:`mirl.learning.equilibria.joint_log_likelihood`
is checked against bit for bit: every step two full S × S sparse products with transposed
copies, the meeting part by scipy's sparse-sparse kernel into a dense array."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import _sparsetools

from mirl.learning.equilibria import _condition, _robot_steps
from mirl.sparse import csr_matmul
from mirl.world.game import meeting


class _MeetingPart:
    def __init__(self, GT_i, GT_j, meet) -> None:
        S = meet.shape[0]
        idx = GT_i.indptr.dtype
        self._S = S
        self._mi, self._mj = (a.astype(np.intp) for a in np.nonzero(meet))
        self._at = (np.searchsorted(self._mi, np.arange(S + 1)).astype(idx), self._mj.astype(idx))
        gj = sp.csr_array(GT_j.T)
        gj.sort_indices()
        self._gi = (GT_i.indptr.astype(idx), GT_i.indices.astype(idx), GT_i.data)
        self._gj = (gj.indptr.astype(idx), gj.indices.astype(idx), gj.data)
        n1 = _sparsetools.csr_matmat_maxnnz(S, S, *self._at, *self._gj[:2])
        self._y = (np.zeros(S + 1, idx), np.zeros(n1, idx), np.zeros(n1))
        self._c = (np.zeros(S + 1, idx), np.zeros(S * S, idx), np.zeros(S * S))

    def add_to(self, out, M) -> None:
        S, kernel = self._S, _sparsetools.csr_matmat
        if len(self._mi) == 0:
            return
        values = M[self._mi, self._mj]
        kernel(S, S, *self._at, values, *self._gj, *self._y)
        kernel(S, S, *self._gi, *self._y, *self._c)
        _sparsetools.csr_todense(S, S, *self._c, out)


def reference_joint_log_likelihood(domain, series, policies, transitions, equilibrium, visible,
                                   epsilon=1e-3) -> float:  # fmt: skip
    x, y = (np.asarray(s, dtype=int) for s in series)
    S = domain.n_states
    vis = np.asarray(visible, dtype=bool).copy()
    vis[x[x >= 0]] = True
    vis[y[y >= 0]] = True
    pol = [np.asarray(p, dtype=int) for p in policies]
    PT, GT = _robot_steps(domain, pol, transitions, equilibrium, epsilon)
    si, sj = np.divmod(np.arange(S * S), S)
    meet = meeting(domain, si, sj, pol[0][si], pol[1][sj]).reshape(S, S)
    off = (~meet).astype(float)
    part = _MeetingPart(GT[0], GT[1], meet)
    M = np.full((S, S), 1.0 / (S * S))
    total = 0.0
    for t in range(len(x)):
        if t > 0:
            out = csr_matmul(PT[0], csr_matmul(PT[1], (M * off).T).T)
            part.add_to(out, M)
            M = out
        _condition(M, x[t], vis, 0)
        _condition(M, y[t], vis, 1)
        c = M.sum()
        if c <= 0.0:
            total += np.log(1e-300)
            M = np.full((S, S), 1.0)
            _condition(M, x[t], vis, 0)
            _condition(M, y[t], vis, 1)
            c = M.sum()
        else:
            total += np.log(c)
        M /= c
    return float(total)
