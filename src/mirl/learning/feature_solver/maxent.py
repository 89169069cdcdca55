"""The exact Eq. 4 solver: maximum likelihood of the pooled binomial counts, then maximum entropy
over the polytope of maximum-likelihood points."""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.optimize import linprog, nnls

from mirl.learning.feature_solver._common import (
    _CONSISTENT_TOL,
    _KKT_TOL,
    _LOG_P_FLOOR,
    _ML_GTOL,
    _ML_MAX_ITER,
    FeatureSolveResult,
    _Pooled,
    _report,
)
from mirl.learning.feature_solver._face import _Face

# --------------------------------------------------------------------------------------------
# method="maxent"


def _solve_maxent(pooled: _Pooled) -> FeatureSolveResult:
    """ML for the counts, then maximum entropy among the ML solutions (module docstring)."""
    A, s, n = pooled.incidence, pooled.successes, pooled.trials
    n_feat = len(pooled.features)
    p = np.full(n_feat, 0.5)  # maximum entropy for anything the data do not pin down
    if not len(s):
        return _report(
            pooled,
            p,
            success=True,
            method="maxent",
            n_evaluations=0,
            message="no observation with trials > 0: every feature at 0.5 (maximum entropy)",
        )
    notes: list[str] = []

    # Step 2: zero-success subsets that a feature unused by any successful subset can explain.
    used_by_success = A[s > 0].any(axis=0)
    zero_rows = s == 0
    killable = zero_rows & (A[:, ~used_by_success].sum(axis=1) > 0)
    if killable.any():
        zeroed = _min_hitting_set(A[killable] * ~used_by_success)
        p[zeroed] = 0.0
        notes.append(
            f"{int(killable.sum())} zero-success subset(s) explained by p=0 for "
            + ", ".join(pooled.features[i] for i in zeroed)
        )

    rows = ~killable
    # every feature of the remaining rows is used by a successful row
    cols = np.asarray(used_by_success)
    if not rows.any():
        return _report(
            pooled,
            p,
            success=True,
            method="maxent",
            n_evaluations=0,
            message="; ".join(notes + ["other features at 0.5 (maximum entropy)"]),
        )
    Ar, sr, nr = A[rows][:, cols], s[rows], n[rows]

    # Step 3: the ML polytope {x <= 0 : C x = d}.
    C, d, x_feas, consistent, ml_ok, n_ml = _ml_polytope(Ar, sr, nr)
    notes.append(
        "constraints consistent: exact Eq. 4 maximiser"
        if consistent
        else "constraints inconsistent: maximum-likelihood rates, then maximum entropy"
    )

    # Step 4: maximum entropy over the polytope.
    x, n_ent, kkt, tie_classes = _max_entropy_on_polytope(C, d, x_feas)
    p[cols] = np.exp(np.minimum(x, 0.0))
    names_f1 = [f for f, c in zip(pooled.features, cols, strict=True) if c]
    for cls in tie_classes:
        notes.append(
            "maximiser not unique: interchangeable features "
            + ", ".join(names_f1[i] for i in cls)
            + " split asymmetrically (earlier-listed feature given the larger probability)"
        )
    if not ml_ok:
        notes.append("likelihood maximisation did not converge")
    ok = bool(ml_ok and np.isfinite(x).all() and kkt <= _KKT_TOL)
    notes.append(f"reduced gradient {kkt:.1e}" + ("" if ok else " (not stationary)"))
    return _report(
        pooled,
        p,
        success=ok,
        method="maxent",
        n_evaluations=n_ml + n_ent,
        message="; ".join(notes),
    )


def _min_hitting_set(rows: np.ndarray) -> list[int]:
    """Fewest columns such that every row of the 0/1 matrix ``rows`` has a chosen column.

    Exhaustive for up to 16 candidate columns (robots have a handful of features), greedy
    beyond. Ties prefer later columns, so earlier-listed features keep the larger probability.
    """
    candidates = np.flatnonzero(rows.any(axis=0))[::-1]
    hit = rows > 0
    if len(candidates) <= 16:
        for size in range(1, len(candidates) + 1):
            for combo in itertools.combinations(candidates, size):
                if hit[:, list(combo)].any(axis=1).all():
                    return sorted(int(c) for c in combo)
    chosen: list[int] = []
    uncovered = np.ones(len(hit), bool)
    while uncovered.any():
        gains = hit[uncovered].sum(axis=0)
        best = int(len(gains) - 1 - np.argmax(gains[::-1]))  # ties: latest column
        chosen.append(best)
        uncovered &= ~hit[:, best]
    return sorted(chosen)


def _ml_polytope(
    A: np.ndarray, s: np.ndarray, n: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool, bool, int]:
    """(C, d, x, consistent, converged, evaluations): the ML set is {x <= 0 : C x = d}, x in it.

    Every row of C has non-negative coefficients and d <= 0, which the caller uses for bounds.
    """
    if (s > 0).all():
        # Consistent iff A x = log q has a solution with x <= 0: NNLS on y = -x >= 0.
        target = -np.log(s / n)
        y, rnorm = nnls(A, target)
        if rnorm <= _CONSISTENT_TOL * (1.0 + np.linalg.norm(target)):
            return A, -target, -y, True, True, 0

    x, nfev, converged = _ml_point(A, s, n)
    z = A @ x
    certain = s == n  # q = 1: linear likelihood term, only the weighted sum is identified
    C, d = A[~certain], z[~certain]
    if certain.any():
        w = n[certain] @ A[certain]
        zc = float(n[certain] @ np.minimum(z[certain], 0.0))
        C, d = np.vstack([C, w]), np.append(d, zc)
    return C, np.minimum(d, 0.0), x, False, converged, nfev


def _ml_point(A: np.ndarray, s: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, int, bool]:
    """(x, evaluations, converged): a maximiser of the binomial log-likelihood, x ∈ [floor, 0]^F.

    log(1 − e^z) is replaced beyond z_c by its second-order Taylor expansion: the surrogate is
    still concave, finite everywhere, and agrees with the likelihood wherever a maximiser can
    be — at any ML point each subset with failures has 1 − e^z ≥ 1/(N+1) (stationarity bounds
    its failure term by the total count N), so z ≤ log(N/(N+1)) < z_c.

    Long because it is one projected-Newton method with its line search and active set,
    which is easier to check read whole than split.
    """
    total = float(n.sum())
    fail = n - s
    z_c = 0.5 * math.log(total / (total + 1.0))
    e_c = math.exp(z_c)
    l_c, d1_c, d2_c = math.log1p(-e_c), -e_c / (1.0 - e_c), -e_c / (1.0 - e_c) ** 2

    def pieces(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z = A @ x
        inside = z <= z_c
        zi = np.minimum(z, z_c)
        ez = np.exp(zi)
        dz = z - z_c
        ell = np.where(inside, np.log1p(-ez), l_c + d1_c * dz + 0.5 * d2_c * dz**2)
        d1 = np.where(inside, -ez / (1.0 - ez), d1_c + d2_c * dz)
        d2 = np.where(inside, -ez / (1.0 - ez) ** 2, d2_c)
        value = (s @ z + fail @ ell) / total
        grad = A.T @ (s + fail * d1) / total
        curv = fail * d2 / total
        return value, grad, curv

    # Start from log-space least squares on continuity-corrected rates.
    q0 = (s + 0.5) / (n + 1.0)
    y0, _ = nnls(A, -np.log(q0))
    x = np.clip(-y0, _LOG_P_FLOOR, -1e-3)

    # Projected Newton ascent on the box [floor, 0]. Hand-written rather than L-BFGS-B: the
    # problem has a handful of variables and Newton reaches machine precision in a few steps,
    # while scipy's L-BFGS-B stopped near 1e-8 and, with multi-threaded OpenBLAS on a busy
    # machine, took 10–180 ms per call (about 1 ms single-threaded).
    def project(v: np.ndarray) -> np.ndarray:
        return np.clip(v, _LOG_P_FLOOR, 0.0)

    value, grad, curv = pieces(x)
    nfev, converged = 1, False
    for _ in range(_ML_MAX_ITER):
        gap = project(x + grad) - x  # projected gradient: zero exactly at a KKT point
        width = float(np.abs(gap).max())
        if width <= _ML_GTOL:
            converged = True
            break
        # Bertsekas' projected Newton: variables within eps of a bound they are pushed
        # against move by the gradient (and are stopped by the projection); the others take a
        # Newton step. Damping keeps the step an ascent direction along flat directions
        # (q = 1 terms are linear in z).
        eps = min(1e-6, width)
        blocked = ((x >= -eps) & (grad > 0.0)) | ((x <= _LOG_P_FLOOR + eps) & (grad < 0.0))
        free = ~blocked
        direction = grad.copy()
        if free.any():
            Af = A[:, free]
            neg_hess = -(Af.T @ (curv[:, None] * Af))  # positive semi-definite
            damping = 1e-9 * (1.0 + np.trace(neg_hess))
            eye = np.eye(Af.shape[1])
            direction[free] = np.linalg.solve(neg_hess + damping * eye, grad[free])
        improved = False
        for d in (direction, grad):  # Newton first, projected gradient as the fallback
            alpha = 1.0
            for _ in range(60):
                trial = project(x + alpha * d)
                t_value, t_grad, t_curv = pieces(trial)
                nfev += 1
                gain = float(grad @ (trial - x))
                # Armijo; once the predicted gain is below rounding of the value, accept any
                # step that does not lose (Newton is then polishing the last digits of x).
                noise = 4 * np.finfo(float).eps * abs(value)
                if t_value > value + 1e-4 * gain or (gain <= noise and t_value >= value - noise):
                    improved = True
                    break
                alpha *= 0.5
            if improved:
                break
        if not improved or np.array_equal(trial, x):
            break
        x, value, grad, curv = trial, t_value, t_grad, t_curv
    return x, nfev, converged


def _max_entropy_on_polytope(
    C: np.ndarray, d: np.ndarray, x_feasible: np.ndarray
) -> tuple[np.ndarray, int, float, list[list[int]]]:
    """Maximise Σ H(e^{x_τ}) over {x <= 0 : C x = d}; return (x, evaluations, KKT, ties).

    ``x_feasible`` is a known point of the polytope (from NNLS or the ML solve). Features the
    polytope pins at x = 0 (p = 1) are fixed first: the rest then have a relative-interior
    point with every x < 0, which is where the maximiser lies (dH/dx → −∞ as p → 1), so the
    reduced gradient of the entropy must vanish there. The objective is not concave, hence a
    grid search over the free coordinates followed by local SLSQP refinements.
    """
    n1 = C.shape[1]
    # a row ∑ c x = 0 with c > 0, x <= 0 pins all its x
    fixed = np.asarray(C[d >= -1e-14].any(axis=0))
    n_eval = 0
    for _ in range(n1 + 1):  # each pass fixes at least one more feature, or stops
        face = _Face.of(C[:, ~fixed], d)
        grid, xs, values = face.grid(x_feasible[~fixed])
        n_eval += len(xs) if len(face.free) else 0  # a single point is no search
        # A feature seen strictly negative at some feasible point is not pinned; the others
        # are checked by linear programming (minimum of x_τ over the polytope).
        suspects = np.flatnonzero(~fixed)[(xs > -1e-9).all(axis=0)]
        pinned = [tau for tau in suspects if _min_over_polytope(C, d, tau) > -1e-9]
        if not pinned:
            break
        fixed[pinned] = True
    x, kkt, n_local = face.refine(grid, values)
    full = np.zeros(n1)
    full[~fixed] = x

    # Interchangeable features (identical columns): order values so earlier gets larger.
    ties: list[list[int]] = []
    _, cls = np.unique(C.T.round(12), axis=0, return_inverse=True)
    for c in np.unique(cls):
        members = np.flatnonzero(cls == c)
        if len(members) > 1:
            vals = np.sort(full[members])[::-1]
            full[members] = vals
            if vals[0] - vals[-1] > 1e-7:
                ties.append(members.tolist())
    return full, n_eval + n_local, kkt, ties


def _min_over_polytope(C: np.ndarray, d: np.ndarray, tau: int) -> float:
    """min x_τ over {x <= 0 : C x = d} (0 when the LP fails, i.e. treat τ as pinned)."""
    cost = np.zeros(C.shape[1])
    cost[tau] = 1.0
    res = linprog(cost, A_eq=C, b_eq=d, bounds=[(_LOG_P_FLOOR, 0.0)] * C.shape[1], method="highs")
    return float(res.fun) if res.status == 0 else 0.0
