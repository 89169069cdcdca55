"""Records and helpers shared by the feature solvers: the result, pooled counts, report."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import entr, gammaln

__all__ = ["FeatureSolveResult"]

# --------------------------------------------------------------------------------------------
# Shared reporting


_METHODS = ("maxent", "paper")
# Projected-Newton limits for the likelihood (normalised by the total count).
_ML_MAX_ITER = 200
_ML_GTOL = 1e-12
# Lower bound for log p inside the likelihood solve (p ≥ 3.7e-44): far below anything finite
# counts can justify, yet keeps exp() and the line search well away from underflow.
_LOG_P_FLOOR = -100.0
# Relative residual under which non-negative least squares counts as "constraints consistent".
_CONSISTENT_TOL = 1e-10
# Roughly how many grid points the global search of step 4 may evaluate.
_GRID_BUDGET = 20_000
# ... but no more than this many per axis (a 1-D search needs far fewer).
_GRID_MAX_PER_AXIS = 1000
# How many well-separated grid points are refined locally.
_N_STARTS = 4
# Reduced-gradient tolerance for accepting the entropy maximiser as stationary.
_KKT_TOL = 1e-6
# Constraint tolerance in log space for the paper method's success flag.
_PAPER_CONSTRAINT_TOL = 1e-6


@dataclass(frozen=True)
class FeatureSolveResult:
    """Outcome of :func:`solve_feature_probabilities`.

    Attributes:
        probabilities: p_τ for every feature, informed or not, each in [0, 1].
        success: ``maxent``: the procedure reached a verified optimum (the constraints may still
            be unmeetable — see ``message``/``residuals``). ``paper``: BFGS converged *and*
            every constraint holds (to 1e-6 in log space; model rate <= 1e-6 where q = 0)
            with all p in [0, 1].
        message: what happened, including whether the data were consistent.
        residuals: per pooled subset with trials > 0, Σ_{τ∈ξ} log p_τ − log q (log space,
            the form of the Eq. 4 constraint). 0 when model and data are both 0; +inf when
            q = 0 but the model rate is positive; −inf when the model rate is 0 but q > 0.
            Keys list the subset's features in the order of ``features``.
        informed: features that appear in some subset with trials > 0, in ``features`` order.
        method: ``"maxent"`` or ``"paper"``.
        log_likelihood: Σ_j log Binomial(s_j; n_j, ∏_{τ∈ξ_j} p_τ), binomial coefficient included.
        n_evaluations: objective evaluations by the iterative solvers (vectorised grid points
            counted individually); 0 when the answer was obtained in closed form.
    """

    probabilities: dict[str, float]
    success: bool
    message: str
    residuals: dict[tuple[str, ...], float]
    informed: tuple[str, ...]
    method: str
    log_likelihood: float
    n_evaluations: int


@dataclass(frozen=True)
class _Pooled:
    """Validated observations pooled by subset (only subsets with trials > 0)."""

    features: tuple[str, ...]
    incidence: np.ndarray  # (m, F) float 0/1: subset j uses feature τ
    successes: np.ndarray  # (m,) float
    trials: np.ndarray  # (m,) float, all > 0
    keys: tuple[tuple[str, ...], ...]  # subset j's features in ``features`` order


def _binary_entropy(p: np.ndarray) -> np.ndarray:
    """H(p) in nats, exact 0 at p ∈ {0, 1}."""
    return entr(p) + entr(1.0 - p)


def _report(
    pooled: _Pooled,
    p: np.ndarray,
    *,
    success: bool,
    message: str,
    method: str,
    n_evaluations: int,
) -> FeatureSolveResult:
    """Assemble the result: residuals and likelihood are computed the same way for both methods."""
    p = np.clip(np.asarray(p, dtype=float), 0.0, 1.0)
    A, s, n = pooled.incidence, pooled.successes, pooled.trials
    model = np.prod(np.where(A > 0, p, 1.0), axis=1) if A.size else np.ones(len(s))
    q = s / n
    with np.errstate(divide="ignore", invalid="ignore"):
        resid = np.log(model) - np.log(q)
    resid = np.where((model == 0) & (q == 0), 0.0, resid)
    loglik = float(
        np.sum(
            gammaln(n + 1)
            - gammaln(s + 1)
            - gammaln(n - s + 1)
            + _xlogy_safe(s, model)
            + _xlogy_safe(n - s, 1.0 - model)
        )
    )
    informed_mask = np.asarray(A.any(axis=0) if A.size else np.zeros(len(pooled.features), bool))
    return FeatureSolveResult(
        probabilities={f: float(v) for f, v in zip(pooled.features, p, strict=True)},
        success=bool(success),
        message=message,
        residuals={k: float(r) for k, r in zip(pooled.keys, resid, strict=True)},
        informed=tuple(f for f, m in zip(pooled.features, informed_mask, strict=True) if m),
        method=method,
        log_likelihood=loglik,
        n_evaluations=int(n_evaluations),
    )


def _xlogy_safe(k: np.ndarray, r: np.ndarray) -> np.ndarray:
    """k·log r with 0·log 0 = 0 and k·log 0 = −inf for k > 0 (no warnings, no NaN)."""
    with np.errstate(divide="ignore"):
        return np.where(k > 0, k * np.log(np.where(k > 0, r, 1.0)), 0.0)
