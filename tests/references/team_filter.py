"""The first exact N-robot filter (commit 7117727), kept as the reference the faster
:class:`mirl.planning.team_filter.ExactTeam` is checked and timed against: masks of every meeting
assignment over the whole S^N tensor, each pushed through dense mode products."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mirl.planning.team_filter import ExactTeam, TeamParts, meeting_assignments


class ReferenceExactTeam(ExactTeam):  # a subclass only so BeliefFilter accepts it
    """The first version: every meeting assignment pushed through dense mode products."""

    def __init__(self, parts: TeamParts) -> None:
        self.parts = p = parts
        choice, code = meeting_assignments(p)  # the same assignments, shared
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


def _mode_products(x: np.ndarray, mats_T: list[sp.csr_array]) -> np.ndarray:
    """x ×₀ M₀ᵀ ×₁ M₁ᵀ …: apply each (transposed) one-step matrix along its axis."""
    for axis, M in enumerate(mats_T):
        moved = np.moveaxis(x, axis, 0)
        shape = moved.shape
        y = M @ moved.reshape(shape[0], -1)
        x = np.moveaxis(y.reshape(shape), 0, axis)
    return x
