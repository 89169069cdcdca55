"""The paper's procedure for Eq. 4 (Lagrangian, squared partial derivatives, BFGS with a penalty),
kept selectable as method="paper" to compare with the exact solver."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize

from mirl.learning.feature_solver._common import (
    _PAPER_CONSTRAINT_TOL,
    FeatureSolveResult,
    _Pooled,
    _report,
)

# --------------------------------------------------------------------------------------------
# method="paper"

_PAPER_EPS = 1e-6
_PAPER_PENALTY = 1e4


def _solve_paper(pooled: _Pooled) -> FeatureSolveResult:
    """The paper's procedure: BFGS on L' = Σ (∂L/∂·)² with a penalty for leaving (0, 1).

    Variables y = (p, p̄, v, λ); L = Σ H(p, p̄) + Σ_j v_j (Σ_{τ∈ξ_j} log p_τ − log q_j)
    + Σ_τ λ_τ (p_τ + p̄_τ − 1). Start: p = p̄ = 0.5, v = λ = 0 (the paper gives none).
    Logs and 1/p are taken of values clipped to [eps, 1], eps = 1e-6, so that BFGS can step
    outside the box, where the quadratic penalty (weight 1e4) pushes it back; q = 0 is
    clipped to eps the same way. The paper gives none of these constants. (With eps = 1e-12
    the v/p term makes such a cliff at p = 0 that BFGS's first line search already fails,
    e.g. for one subset {a, b} with q = 0.01; eps = 1e-6 lets it proceed.)

    Long because it is the paper's whole procedure (Lagrangian, squared partials, BFGS,
    penalty, success check) kept in one place to compare with the paper.
    """
    A, s, n = pooled.incidence, pooled.successes, pooled.trials
    F, m = A.shape[1], A.shape[0]
    log_q = np.log(np.maximum(s / n, _PAPER_EPS)) if m else np.zeros(0)

    def split(y: np.ndarray) -> tuple[np.ndarray, ...]:
        return y[:F], y[F : 2 * F], y[2 * F : 2 * F + m], y[2 * F + m :]

    def objective(y: np.ndarray) -> tuple[float, np.ndarray]:
        p, pb, v, lam = split(y)
        pc, pbc = np.clip(p, _PAPER_EPS, 1.0), np.clip(pb, _PAPER_EPS, 1.0)
        inp, inpb = (p > _PAPER_EPS) & (p < 1.0), (pb > _PAPER_EPS) & (pb < 1.0)
        av = A.T @ v
        r_p = -(np.log(pc) + 1.0) + av / pc + lam
        r_pb = -(np.log(pbc) + 1.0) + lam
        r_v = A @ np.log(pc) - log_q
        r_l = p + pb - 1.0
        # Jacobian-transpose products for the gradient 2 Jᵀ r (clipped variables: slope 0).
        d_rp_dp = np.where(inp, -1.0 / pc - av / pc**2, 0.0)
        d_rpb_dpb = np.where(inpb, -1.0 / pbc, 0.0)
        dlog_p = np.where(inp, 1.0 / pc, 0.0)
        g_p = 2 * (r_p * d_rp_dp + dlog_p * (A.T @ r_v) + r_l)
        g_pb = 2 * (r_pb * d_rpb_dpb + r_l)
        g_v = 2 * (A @ (r_p / pc))
        g_l = 2 * (r_p + r_pb)
        over = np.concatenate([np.maximum(p - 1.0, 0.0), np.maximum(pb - 1.0, 0.0)])
        under = np.concatenate([np.maximum(-p, 0.0), np.maximum(-pb, 0.0)])
        value = (
            r_p @ r_p
            + r_pb @ r_pb
            + r_v @ r_v
            + r_l @ r_l
            + _PAPER_PENALTY * (over @ over + under @ under)
        )
        pen = 2 * _PAPER_PENALTY * (over - under)
        g_p += pen[:F]
        g_pb += pen[F:]
        return float(value), np.concatenate([g_p, g_pb, g_v, g_l])

    y0 = np.concatenate([np.full(2 * F, 0.5), np.zeros(m + F)])
    with np.errstate(all="ignore"):
        res = minimize(objective, y0, jac=True, method="BFGS", options={"maxiter": 5000})
    y = res.x if np.isfinite(res.x).all() else y0
    p_raw = y[:F]
    p = np.clip(p_raw, 0.0, 1.0)
    in_box = bool(((p_raw >= 0.0) & (p_raw <= 1.0)).all())
    # "Met" means: within 1e-6 in log space where q > 0; model rate <= eps where q = 0 (the
    # closest the clipped problem can come to log 0).
    model = np.prod(np.where(A > 0, p, 1.0), axis=1) if m else np.ones(0)
    with np.errstate(divide="ignore"):
        gap = np.abs(np.log(model) - np.log(np.where(s > 0, s / n, 1.0)))
    clipped_ok = model <= _PAPER_EPS * math.exp(_PAPER_CONSTRAINT_TOL)
    gap = np.where(s > 0, gap, np.where(clipped_ok, 0.0, np.inf))
    worst = float(gap.max()) if m else 0.0
    met = worst <= _PAPER_CONSTRAINT_TOL
    ok = bool(res.success) and met and in_box
    parts = [
        f"BFGS {'converged' if res.success else 'did not converge'} ({res.message})",
        f"L' = {res.fun:.3g}",
        f"max constraint violation {worst:.3g}" + ("" if met else " (constraints not met)"),
    ]
    if not in_box:
        parts.append("p left [0, 1] and was clipped")
    if m and (s == 0).any():
        parts.append(f"q = 0 has no log: replaced by {_PAPER_EPS:g}")
    return _report(
        pooled,
        p,
        success=ok,
        method="paper",
        n_evaluations=int(res.nfev),
        message="; ".join(parts),
    )
