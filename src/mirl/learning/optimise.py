"""The optimiser calls of :class:`~mirl.learning.irl.OccludedMaxEntIRL`: one start of
Nelder–Mead (derivative-free, the paper's) or L-BFGS-B with the exact gradient, with the
options the estimator's defaults were measured with (:mod:`mirl.learning.irl`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import OptimizeResult, minimize

__all__ = ["minimise_from"]


def minimise_from(
    loss: Callable,
    x_start: np.ndarray,
    *,
    optimizer: str,
    max_evaluations: int,
    tol: float | None,
) -> OptimizeResult:
    """Minimise ``loss`` from ``x_start``. ``loss(x)`` returns the value, ``loss(x, True)``
    (value, gradient). Nelder–Mead starts from a simplex of half the start's scale (at least
    0.5); L-BFGS-B stops at ``tol`` relative gain (None: scipy's default ftol)."""
    if optimizer == "nelder-mead":
        K = len(x_start)
        step = 0.5 * max(1.0, float(np.abs(x_start).max()))
        simplex = np.vstack([x_start, x_start + step * np.eye(K)])
        options = {"initial_simplex": simplex, "maxfev": max_evaluations}
        return minimize(
            loss, x_start, method="Nelder-Mead", options=options | {"xatol": 1e-3, "fatol": 1e-7}
        )
    options = {"maxfun": max_evaluations, "gtol": 1e-7, **({} if tol is None else {"ftol": tol})}
    return minimize(loss, x_start, args=(True,), jac=True, method="L-BFGS-B", options=options)
