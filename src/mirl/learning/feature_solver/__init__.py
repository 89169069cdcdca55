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

import math
import numbers
from collections.abc import Iterable, Sequence

import numpy as np

from mirl.learning.feature_solver._common import _METHODS, FeatureSolveResult, _Pooled
from mirl.learning.feature_solver.maxent import _solve_maxent
from mirl.learning.feature_solver.paper import _solve_paper

__all__ = ["solve_feature_probabilities"]


def solve_feature_probabilities(
    features: Sequence[str],
    observations: Iterable[tuple[Iterable[str], int, int]],
    method: str = "maxent",
) -> FeatureSolveResult:
    """Estimate p_τ for every feature from ``(subset, successes, trials)`` observations.

    Args:
        features: all transition features of the robot (distinct names).
        observations: ``(subset, successes, trials)``; ``subset`` names the features an action
            uses, ``successes`` counts arrivals in the intended state out of ``trials``.
            Identical subsets (in any order) are pooled by adding their counts.
        method: ``"maxent"`` (ML, then maximum entropy; exact Eq. 4 maximiser when the
            constraints are consistent) or ``"paper"`` (the paper's BFGS on the squared
            Lagrangian gradient). See the module docstring.

    Raises:
        ValueError: duplicate or non-string feature names; an observation that is not a
            triple, names an unknown or repeated feature, has negative, non-integer or
            inconsistent counts (successes > trials, or failures of an empty subset); an
            unknown method. The message names the offending observation by index.
    """
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; expected one of {', '.join(_METHODS)}")
    pooled = _pool(features, observations)
    if method == "paper":
        return _solve_paper(pooled)
    return _solve_maxent(pooled)


# --------------------------------------------------------------------------------------------
# Validation and pooling


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
