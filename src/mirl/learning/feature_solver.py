"""Transition-feature success probabilities from pooled success counts (mIRL*/T, Eq. 3–4).

A robot's transitions are explained by independent binary *transition features* τ (wheels,
navigation, floor, ...) with unknown success probabilities p_τ. An action that uses the feature
subset ξ reaches its intended state with probability ∏_{τ∈ξ} p_τ (paper Eq. 2). Observation
gives, per subset, a number of trials and of successes, i.e. an empirical rate q (Eq. 3). Eq. 4
then asks for the p of *every* feature that maximises the total binary entropy Σ_τ H(p_τ)
subject to Σ_{τ∈ξ} log p_τ = log q for every observed subset.

Two procedures are offered.

``method="maxent"`` (default) — maximum likelihood, then maximum entropy:

1. Counts of identical subsets are pooled (counts, not rates, so that 1/2 + 50/100 is 51/102).
2. Zero-success subsets that can be explained by zeroing a feature used by no subset with any
   success get such a feature set to exactly 0 — this attains the likelihood supremum (the
   subset's term becomes log 1 = 0 without touching any other subset). Which features: the
   fewest possible (each zeroed feature costs log 2 nats of entropy against 0.5); ties go to
   the *later* feature in ``features``. Other features of such subsets are then constrained
   by nothing and get 0.5.
3. In x = log p ≤ 0 the binomial log-likelihood Σ_j s_j z_j + (n_j − s_j) log(1 − e^{z_j}),
   z = A x, is concave, so the maximum-likelihood (ML) set is convex. Each term with failures
   is strictly concave in its z_j, so every such z_j is the same at all ML points; terms with
   q = 1 are linear, so only their count-weighted sum Σ n_j z_j is pinned down. The ML set is
   therefore the polytope {x ≤ 0 : z_j = z_j* for subsets with failures, Σ_{q=1} n_j z_j = c*}.
   When the Eq. 4 constraints are consistent (some p in [0, 1] meets all of them exactly — checked
   by non-negative least squares) every constraint is met at its own optimum, so the ML set *is*
   the Eq. 4 feasible set and z* = log q exactly; no numerical likelihood maximisation is done.
   Otherwise an ML point is found by projected Newton ascent (to machine precision).
4. Total entropy is maximised over that polytope. This is *not* a concave problem: in x the
   entropy h(x) = H(e^x) is convex for p below ≈ 0.2178, and in p the constraint surface
   ∏ p = q is not convex. For example one subset {a, b} with q < 0.047 has two mirror-image
   asymmetric maximisers (q = 0.01: 0.454 and 0.022) while the symmetric point √q is a
   saddle. The polytope is parametrised by its free coordinates (QR with column pivoting),
   searched on a grid of ~20 000 points (a full grid up to 5 free coordinates, a fixed-seed
   random sample beyond), and the best distinct grid points are refined by SLSQP; the result
   is checked for a vanishing reduced gradient (the maximiser is interior once features pinned
   at p = 1 are fixed, because dH/dx → −∞ as p → 1). Features that share the same subsets
   are interchangeable; when the maximiser splits them asymmetrically the earlier-listed
   feature gets the larger probability (and the message says so).

``method="paper"`` — the paper's own procedure, reproduced for comparison: the Lagrangian of
Eq. 4 over (p, p̄, v, λ), the objective L' = Σ (∂L/∂·)², minimised by BFGS with a quadratic
penalty keeping p and p̄ in (0, 1). It converges to *any* stationary point of the Lagrangian
(minima and saddles of the entropy included), has no answer for q = 0 (log 0; q is clipped to
1e-6 here) and cannot satisfy inconsistent constraints; ``success`` is True only when the
constraints are actually met. Observed behaviour (pinned by the tests): it agrees with
``maxent`` on identified and on symmetric underdetermined data; for {a, b} with q = 0.01 it
stops at the symmetric saddle a = b = 0.1 (constraints met, entropy 0.14 nats short); with
q = 0 alone it drives the feature to ~1e-6, with q = 0 beside successes it fails; with
q = 1 BFGS runs out of iterations near p = 1 (stationarity needs λ → ∞); with inconsistent
data it returns a least-squares compromise of lower likelihood and reports failure.
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import linprog, minimize, nnls
from scipy.special import entr, gammaln

from mirl._registry import Registry

__all__ = ["solve_feature_probabilities", "FeatureSolveResult", "FeatureSolver", "FEATURE_SOLVERS"]


def solve_feature_probabilities(
    features: Sequence[str],
    observations: Iterable[tuple[Iterable[str], int, int]],
    method: str = "maxent",
) -> FeatureSolveResult:
    """Estimate p_τ for every feature from ``(subset, successes, trials)`` observations.

    Parameters
    ----------
    features : sequence of str
        All transition features of the robot (distinct names).
    observations : iterable of (iterable of str, int, int)
        ``(subset, successes, trials)``: ``subset`` names the features an action uses,
        ``successes`` counts arrivals in the intended state out of ``trials``. Identical subsets
        (in any order) are pooled by adding their counts.
    method : {"maxent", "paper"}, default "maxent"
        ML, then maximum entropy (the exact Eq. 4 maximiser when the constraints are
        consistent), or the paper's BFGS on the squared Lagrangian gradient. See the module
        docstring.

    Returns
    -------
    FeatureSolveResult
        The probabilities, with how they were found.

    Raises
    ------
    ValueError
        Duplicate or non-string feature names; an observation that is not a triple, names an
        unknown or repeated feature, has negative, non-integer or inconsistent counts
        (successes > trials, or failures of an empty subset); an unknown method (a row of
        :data:`FEATURE_SOLVERS`, the nearest suggested). The message names the offending
        observation by index.
    """
    solver = FEATURE_SOLVERS.lookup(method)
    return solver.solve(_pool(features, observations))


@dataclass(frozen=True)
class FeatureSolveResult:
    """Outcome of :func:`solve_feature_probabilities`.

    Parameters
    ----------
    probabilities : dict of str to float
        The probability p_τ of every feature, informed or not, each in [0, 1].
    success : bool
        ``maxent``: the procedure reached a verified optimum (the constraints may still be
        unmeetable — see ``message``/``residuals``). ``paper``: BFGS converged *and* every
        constraint holds (to 1e-6 in log space; model rate <= 1e-6 where q = 0) with all p in
        [0, 1].
    message : str
        What happened, including whether the data were consistent.
    residuals : dict of tuple of str to float
        Per pooled subset with trials > 0, Σ_{τ∈ξ} log p_τ − log q (log space, the form of the
        Eq. 4 constraint). 0 when model and data are both 0; +inf when q = 0 but the model rate
        is positive; −inf when the model rate is 0 but q > 0. Keys list the subset's features in
        the order of ``features``.
    informed : tuple of str
        Features that appear in some subset with trials > 0, in ``features`` order.
    method : str
        ``"maxent"`` or ``"paper"``.
    log_likelihood : float
        Σ_j log Binomial(s_j; n_j, ∏_{τ∈ξ_j} p_τ), binomial coefficient included.
    n_evaluations : int
        Objective evaluations by the iterative solvers (vectorised grid points counted
        individually); 0 when the answer was obtained in closed form.
    """

    probabilities: dict[str, float]
    success: bool
    message: str
    residuals: dict[tuple[str, ...], float]
    informed: tuple[str, ...]
    method: str
    log_likelihood: float
    n_evaluations: int


# --------------------------------------------------------------------------------------------
# Validation and pooling


@dataclass(frozen=True)
class _Pooled:
    """Validated observations pooled by subset (only subsets with trials > 0)."""

    features: tuple[str, ...]
    incidence: np.ndarray  # (m, F) float 0/1: subset j uses feature τ
    successes: np.ndarray  # (m,) float
    trials: np.ndarray  # (m,) float, all > 0
    keys: tuple[tuple[str, ...], ...]  # subset j's features in ``features`` order


def _as_count(value: object, what: str, index: int) -> int:
    """Return ``value`` as a non-negative int, rejecting bools, fractions and NaN."""
    if isinstance(value, bool | np.bool_):
        raise ValueError(f"observation {index}: {what} must be an integer count, got {value!r}")
    if isinstance(value, numbers.Integral):
        count = int(value)
    elif (
        isinstance(value, numbers.Real)
        and math.isfinite(float(value))
        and float(value).is_integer()
    ):
        # 3.0 from a float array is a count; 2.5 is not.
        count = int(float(value))
    else:
        raise ValueError(f"observation {index}: {what} must be an integer count, got {value!r}")
    if count < 0:
        raise ValueError(f"observation {index}: {what} must be non-negative, got {count}")
    return count


def _pool(
    features: Sequence[str], observations: Iterable[tuple[Iterable[str], int, int]]
) -> _Pooled:
    """Validate the inputs and add up the counts of identical feature subsets."""
    if isinstance(features, str):
        raise ValueError("features must be a sequence of feature names, not a single string")
    names = tuple(features)
    for name in names:
        if not isinstance(name, str):
            raise ValueError(f"feature names must be strings, got {name!r}")
    position = {name: i for i, name in enumerate(names)}
    if len(position) != len(names):
        dupes = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"duplicate feature names: {', '.join(dupes)}")
    known = ", ".join(names) if names else "none"

    counts: dict[tuple[int, ...], list[int]] = {}
    for index, obs in enumerate(observations):
        try:
            subset, successes, trials = obs
        except (TypeError, ValueError):
            raise ValueError(
                f"observation {index}: expected (subset, successes, trials), got {obs!r}"
            ) from None
        if isinstance(subset, str):
            # A bare string would silently iterate over its characters.
            raise ValueError(
                f"observation {index}: subset must be an iterable of feature names, "
                f"not the string {subset!r}"
            )
        try:
            members = list(subset)
        except TypeError:
            raise ValueError(
                f"observation {index}: subset must be an iterable of feature names, got {subset!r}"
            ) from None
        idx = []
        for name in members:
            if name not in position:
                raise ValueError(f"observation {index}: unknown feature {name!r} (known: {known})")
            idx.append(position[name])
        if len(set(idx)) != len(idx):
            dup = next(n for n in members if members.count(n) > 1)
            raise ValueError(f"observation {index}: feature {dup!r} repeated in subset")
        s = _as_count(successes, "successes", index)
        n = _as_count(trials, "trials", index)
        if s > n:
            raise ValueError(f"observation {index}: successes {s} exceed trials {n}")
        if not idx:
            # The empty product is 1: an empty subset can only ever succeed.
            if s < n:
                raise ValueError(
                    f"observation {index}: empty subset with {n - s} failures in {n} trials "
                    "is inconsistent (an action using no feature always succeeds)"
                )
            continue
        if n == 0:
            continue
        key = tuple(sorted(idx))
        acc = counts.setdefault(key, [0, 0])
        acc[0] += s
        acc[1] += n

    keys = sorted(counts)  # deterministic row order, independent of observation order
    incidence = np.zeros((len(keys), len(names)))
    for j, key in enumerate(keys):
        incidence[j, list(key)] = 1.0
    return _Pooled(
        features=names,
        incidence=incidence,
        successes=np.array([counts[k][0] for k in keys], dtype=float),
        trials=np.array([counts[k][1] for k in keys], dtype=float),
        keys=tuple(tuple(names[i] for i in k) for k in keys),
    )


# --------------------------------------------------------------------------------------------
# The report, computed the same way for both methods


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


# --------------------------------------------------------------------------------------------
# method="maxent"


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
# Reduced-gradient tolerance for accepting the entropy maximiser as stationary (relative to the
# gradient's terms, _Face.relative_gradient).
_KKT_TOL = 1e-6


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
        return x, self.relative_gradient(best_t), n_eval

    def relative_gradient(self, t: np.ndarray) -> float:
        """The reduced gradient's largest entry over the largest of the terms it is the
        difference of (at least 1): dH/dx grows like log(1/(1 − p)) near p = 1, so an absolute
        tolerance would reject a maximiser SLSQP found to its own precision."""
        x = self.assemble(t)
        p = np.exp(np.minimum(x, -1e-12))
        dh = p * (np.log1p(-p) - np.log(p))
        scale = max(1.0, float(np.abs(dh[self.free]).max(initial=0.0)),
                    float(np.abs(self.M.T @ dh[self.basis]).max(initial=0.0)))  # fmt: skip
        return float(np.abs(self.neg_entropy(t)[1]).max()) / scale


def _binary_entropy(p: np.ndarray) -> np.ndarray:
    """H(p) in nats, exact 0 at p ∈ {0, 1}."""
    return entr(p) + entr(1.0 - p)


# --------------------------------------------------------------------------------------------
# method="paper"


# Constraint tolerance in log space for the paper method's success flag.
_PAPER_CONSTRAINT_TOL = 1e-6
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


# ---- the table of solvers --------------------------------------------------------------------
@dataclass(frozen=True)
class FeatureSolver:
    """A way to solve Eq. 4, a row of :data:`FEATURE_SOLVERS`.

    Parameters
    ----------
    name : str
        Its name, as ``method=`` takes it.
    description : str
        What it does.
    solve : callable
        ``solve(pooled)``: the result from the pooled counts of the observations.
    """

    name: str
    description: str
    solve: Callable[[_Pooled], FeatureSolveResult]


FEATURE_SOLVERS: Registry[FeatureSolver] = Registry(
    "method",
    (
        FeatureSolver(
            "maxent",
            "maximum likelihood, then maximum entropy: the exact Eq. 4 maximiser",
            _solve_maxent,
        ),
        FeatureSolver(
            "paper", "the paper's BFGS on the squared gradient of the Lagrangian", _solve_paper
        ),
    ),
)
"""The Eq. 4 solvers by name (the module docstring)."""
