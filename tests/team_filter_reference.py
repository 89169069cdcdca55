"""The first exact N-robot filter (commit 7117727), kept as the reference the faster
:class:`mirl.planning.team_filter.ExactTeam` is checked and timed against: masks of every meeting
assignment over the whole S^N tensor, each pushed through dense mode products."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mirl.planning.team_filter import ExactTeam, TeamParts


class ReferenceExactTeam(ExactTeam):  # a subclass only so BeliefFilter accepts it
    """The first version: every meeting assignment pushed through dense mode products."""

    def __init__(self, parts: TeamParts) -> None:
        self.parts = p = parts
        shape = (p.S,) * p.n
        # per robot, which of its options it takes in each joint state: 0 = policy, 1 + k =
        # the game of its k-th pair (first meeting in robot order)
        choice = np.zeros((p.n, *shape), dtype=np.int8)
        for k, (i, j) in enumerate(p.pairs):
            met = _broadcast(p.meet[k].toarray() > 0, i, j, p.n)
            for r in (i, j):
                choice[r] = np.where((choice[r] == 0) & met, 1 + k, choice[r])
        code = np.zeros(shape, dtype=np.int64)
        for r in range(p.n):
            code = code * (len(p.pairs) + 1) + choice[r]
        self.free = code == 0
        self.groups = []  # (mask, per robot transposed matrix) for each meeting assignment
        for value in np.unique(code[~self.free]):
            mask = code == value
            mats = []
            for r in range(p.n):
                k = int(choice[r][mask].flat[0]) - 1
                if k < 0:
                    mats.append(p.step_T[r])
                else:
                    mats.append(p.game_T[k][0 if p.pairs[k][0] == r else 1])
            self.groups.append((mask, mats))

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        p = self.parts
        out = _mode_products(np.where(self.free, belief, 0.0), p.step_T)
        for mask, mats in self.groups:
            part = np.where(mask, belief, 0.0)
            if part.any():
                out += _mode_products(part, mats)
        return out

    def marginals(self, belief: np.ndarray) -> np.ndarray:
        n = self.parts.n
        return np.stack([belief.sum(axis=tuple(a for a in range(n) if a != i)) for i in range(n)])

    def none_sees(self, belief: np.ndarray, G: np.ndarray) -> np.ndarray:
        """(C,) P(no patroller sees cell c) = Σ_s B[s] ∏ᵢ G[sᵢ, c]."""
        x = np.tensordot(belief, G, axes=([belief.ndim - 1], [0]))  # (S, …, S, C)
        while x.ndim > 2:
            x = np.einsum("...sc,sc->...c", x, G)
        return np.einsum("sc,sc->c", x, G)


def _broadcast(mask2: np.ndarray, i: int, j: int, n: int) -> np.ndarray:
    shape = [1] * n
    shape[i] = shape[j] = mask2.shape[0]
    return mask2.reshape(shape)


def _mode_products(x: np.ndarray, mats_T: list[sp.csr_array]) -> np.ndarray:
    """x ×₀ M₀ᵀ ×₁ M₁ᵀ …: apply each (transposed) one-step matrix along its axis."""
    for axis, M in enumerate(mats_T):
        moved = np.moveaxis(x, axis, 0)
        shape = moved.shape
        y = M @ moved.reshape(shape[0], -1)
        x = np.moveaxis(y.reshape(shape), 0, axis)
    return x
