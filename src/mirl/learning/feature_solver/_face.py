"""A face of the maximum-likelihood polytope in free coordinates, and the maximum-entropy search
over it (grid, then refinement) that :mod:`mirl.learning.feature_solver.maxent` runs."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize

from mirl.learning.feature_solver._common import (
    _GRID_BUDGET,
    _GRID_MAX_PER_AXIS,
    _LOG_P_FLOOR,
    _N_STARTS,
    _binary_entropy,
)


@dataclass(frozen=True)
class _Face:
    """{x <= 0 : C x = d} written as x_B = base − M t, x_F = t (t: free coordinates).

    The split comes from QR with column pivoting, so x_B is well conditioned in t. ``lower``
    bounds each free coordinate: in a row c·x = d_r with c >= 0 and x <= 0, c_τ x_τ >= d_r.
    """

    basis: np.ndarray
    free: np.ndarray
    base: np.ndarray
    M: np.ndarray
    lower: np.ndarray

    @staticmethod
    def of(C: np.ndarray, d: np.ndarray) -> _Face:
        if C.shape[1] == 0:
            empty = np.zeros(0, int)
            return _Face(empty, empty, np.zeros(0), np.zeros((0, 0)), np.zeros(0))
        _, R, piv = sla.qr(C, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        tol = max(C.shape) * np.finfo(float).eps * (diag[0] if diag.size else 0.0)
        rank = int(np.sum(diag > tol))
        basis, free = piv[:rank], np.sort(piv[rank:])
        pinv_b = np.linalg.pinv(C[:, basis])
        with np.errstate(divide="ignore", invalid="ignore"):
            ratios = np.where(C[:, free] > 0, d[:, None] / C[:, free], -np.inf)
        lower = np.maximum(ratios.max(axis=0, initial=-np.inf), _LOG_P_FLOOR)
        return _Face(basis, free, pinv_b @ d, pinv_b @ C[:, free], lower)

    def assemble(self, t: np.ndarray) -> np.ndarray:
        """x for free coordinates t of shape (..., k)."""
        x = np.empty(t.shape[:-1] + (len(self.basis) + len(self.free),))
        x[..., self.basis] = self.base - t @ self.M.T
        x[..., self.free] = t
        return x

    @staticmethod
    def entropy(x: np.ndarray) -> np.ndarray:
        return _binary_entropy(np.exp(np.minimum(x, 0.0))).sum(axis=-1)

    def neg_entropy(self, t: np.ndarray) -> tuple[float, np.ndarray]:
        """−Σ H and its gradient in t."""
        x = self.assemble(t)
        p = np.exp(np.minimum(x, -1e-12))  # dH/dx → −∞ at p = 1; stay finite
        dh = p * (np.log1p(-p) - np.log(p))  # d H(e^x) / dx
        return -float(self.entropy(x)), -(dh[self.free] - self.M.T @ dh[self.basis])

    def grid(self, x_feasible: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Feasible grid points t, their x and their entropy; ``x_feasible`` always included."""
        k = len(self.free)
        if k == 0:
            xs = np.minimum(self.assemble(np.zeros((1, 0))), 0.0)
            return np.zeros((1, 0)), xs, self.entropy(xs)
        per_axis = min(_GRID_MAX_PER_AXIS, max(6, int(_GRID_BUDGET ** (1.0 / k))))
        if per_axis**k <= 2 * _GRID_BUDGET:
            # Half the points uniform in p (where entropy varies), half uniform in log p.
            axes = [
                np.unique(
                    np.concatenate(
                        [
                            np.log(np.linspace(math.exp(lo), 1.0, per_axis // 2 + 1)),
                            np.linspace(lo, 0.0, per_axis - per_axis // 2),
                        ]
                    )
                )
                for lo in self.lower
            ]
            grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, k)
        else:  # many free coordinates: a fixed-seed random sample of the box instead
            grid = self.lower * np.random.default_rng(0).random((_GRID_BUDGET, k))
        grid = np.vstack([grid, x_feasible[self.free]])
        xs = self.assemble(grid)
        feasible = np.asarray((xs[:, self.basis] <= 1e-12).all(axis=1))
        feasible[-1] = True
        xs = np.minimum(xs[feasible], 0.0)
        return grid[feasible], xs, self.entropy(xs)

    def refine(self, grid: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float, int]:
        """SLSQP from the best well-separated grid points; return (x, reduced gradient, nfev)."""
        k = len(self.free)
        if k == 0:
            return np.minimum(self.assemble(np.zeros(0)), 0.0), 0.0, 0
        span = np.maximum(-self.lower, 1e-12)
        starts: list[np.ndarray] = []
        remaining = np.ones(len(grid), bool)
        while remaining.any() and len(starts) < _N_STARTS:
            i = int(np.argmax(np.where(remaining, values, -np.inf)))
            starts.append(grid[i])
            remaining &= (np.abs(grid - grid[i]) / span).max(axis=1) > 0.1

        cons = {"type": "ineq", "fun": lambda t: self.M @ t - self.base, "jac": lambda t: self.M}
        bounds = list(zip(self.lower, np.zeros(k), strict=True))
        best_t, best_v, n_eval = starts[0], float(values.max()), 0
        for t0 in starts:
            res = minimize(
                self.neg_entropy,
                t0,
                jac=True,
                method="SLSQP",
                bounds=bounds,
                constraints=[cons],
                options={"ftol": 1e-15, "maxiter": 300},
            )
            n_eval += int(res.nfev)
            t = np.clip(res.x, self.lower, 0.0)
            if (self.assemble(t)[self.basis] <= 1e-12).all() and -res.fun > best_v + 1e-15:
                best_t, best_v = t, float(-res.fun)
        x = np.minimum(self.assemble(best_t), 0.0)
        return x, float(np.abs(self.neg_entropy(best_t)[1]).max()), n_eval
