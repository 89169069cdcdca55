"""Two robots' likelihood on large maps: each robot filtered on its own, coupled where they can
meet (issue 12).

The exact weighing of equilibria (:func:`mirl.learning.equilibria.joint_log_likelihood`) tracks
every pair of states, S² of them (712 k on a 30 × 30 office, 39 M on 80 × 80). Only meetings need
the pair, and a meeting needs the two robots within two cells of each other, so the meeting
states are a sparse set (at most ~50 per state). Here the belief is kept as a product of the two
robots' marginals (the Boyen–Koller projection): a step moves each marginal by its policy, except
for the mass the pair has at meeting states, which moves by the equilibrium's game moves —
exactly the joint step's marginals when the joint is that product — and the evidence (each robot
seen where it is, or not on a visible cell) factorises, so its likelihood is the product of the
two robots'. What is dropped is the correlation a meeting leaves behind (who waited for whom).
Cost per step: two sparse mat-vecs per robot and one product with the sparse meeting matrix,
O(S) instead of O(S²). The approximation against the exact joint is measured in
``benchmarks/bench_speed.py --accuracy`` and docs/design.md ("Equilibrium weighing at scale").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from mirl.sparse import csr_matmul
from mirl.world.domain import PatrolDomain
from mirl.world.game import meeting

__all__ = ["meeting_matrix", "factored_log_likelihood"]


def meeting_matrix(domain: PatrolDomain, policy_i: np.ndarray, policy_j: np.ndarray):
    """(S, S) sparse 0/1 matrix of the pair states where the policies' intended moves meet,
    without enumerating all S² pairs: only states whose cells are within two steps can meet."""
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


def _condition(b: np.ndarray, x: int, visible: np.ndarray) -> float:
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
    """log P(observations of both robots) under the factored filter (module doc), for the
    model of :func:`mirl.learning.equilibria.joint_log_likelihood`: per robot the transposed
    ε-greedy policy step ``PT`` and game-move step ``GT``, the sparse ``meet`` matrix of
    :func:`meeting_matrix` and the (S,) states L can see (a robot seen elsewhere counts)."""
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
            c = _condition(b[k], obs[k], visible)
            if c <= 0.0:  # impossible under the model: restart this robot's marginal
                total += np.log(1e-300)
                b[k] = np.ones(S)
                c = _condition(b[k], obs[k], visible)
            else:
                total += np.log(c)
            b[k] /= c
    return float(total)
