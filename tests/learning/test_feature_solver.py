"""Tests for the transition-feature solver (paper Eq. 3–4).

Expected answers come from exact rational data (so "consistent" really is consistent), from
independent brute-force searches, or from an independent constrained optimiser in p space —
never from the solver under test.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
import timeit
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize, minimize_scalar
from scipy.special import entr

from mirl.learning.feature_solver import FeatureSolveResult, solve_feature_probabilities

LEFT, RIGHT, NAV, FLOOR = "left_wheel", "right_wheel", "navigation", "floor"
ROBOT = (LEFT, RIGHT, NAV, FLOOR)
# ξ of the four actions (docs/design.md, "Transition features").
XI = {
    "forward": (LEFT, RIGHT, NAV, FLOOR),
    "turn_left": (RIGHT, NAV, FLOOR),
    "turn_right": (LEFT, NAV, FLOOR),
    "stop": (FLOOR,),
}


def H(p: np.ndarray | float) -> np.ndarray:
    """Binary entropy in nats."""
    p = np.asarray(p, dtype=float)
    return entr(p) + entr(1.0 - p)


def exact_observations(
    p: dict[str, Fraction], subsets: list[tuple[str, ...]], scale: int = 1
) -> list[tuple[tuple[str, ...], int, int]]:
    """Counts whose rates are exactly ∏ p over each subset (consistent by construction)."""
    out = []
    for sub in subsets:
        q = math.prod((p[f] for f in sub), start=Fraction(1))
        out.append((sub, q.numerator * scale, q.denominator * scale))
    return out


def probs(result: FeatureSolveResult, names=ROBOT) -> np.ndarray:
    return np.array([result.probabilities[f] for f in names])


def total_entropy(result: FeatureSolveResult) -> float:
    return float(H(np.array(list(result.probabilities.values()))).sum())


def assert_sane(result: FeatureSolveResult) -> None:
    """Every probability is a number in [0, 1]; nothing is NaN."""
    p = np.array(list(result.probabilities.values()))
    assert np.all((p >= 0.0) & (p <= 1.0)), result
    assert not np.isnan(result.log_likelihood)
    assert not any(math.isnan(r) for r in result.residuals.values())


# --------------------------------------------------------------------------------------------
# Consistent data: the exact Eq. 4 maximiser


def test_identifiable_system_recovered_exactly():
    truth = {"a": Fraction(9, 10), "b": Fraction(4, 5), "c": Fraction(7, 10), "d": Fraction(19, 20)}
    subsets = [("a", "b", "c", "d"), ("b", "c", "d"), ("a", "c", "d"), ("d",)]
    res = solve_feature_probabilities(tuple("abcd"), exact_observations(truth, subsets))
    assert res.success, res.message
    assert "consistent" in res.message
    np.testing.assert_allclose(probs(res, "abcd"), [float(truth[f]) for f in "abcd"], atol=1e-9)
    assert max(abs(r) for r in res.residuals.values()) < 1e-9
    assert res.informed == ("a", "b", "c", "d")


@pytest.mark.parametrize("left", [Fraction(95, 100), Fraction(70, 100)])
def test_spec_robot_all_four_actions_identify_every_feature(left):
    truth = {LEFT: left, RIGHT: Fraction(95, 100), NAV: Fraction(97, 100), FLOOR: Fraction(99, 100)}
    res = solve_feature_probabilities(ROBOT, exact_observations(truth, list(XI.values())))
    assert res.success
    np.testing.assert_allclose(probs(res), [float(truth[f]) for f in ROBOT], atol=1e-9)
    assert res.n_evaluations == 0  # identified: closed form, no iterative search


@pytest.mark.parametrize(
    "q", [Fraction(64, 100), Fraction(1, 4), Fraction(1, 10), Fraction(6, 100)]
)
def test_symmetric_pair_split_equally_while_sqrt_q_above_inflection(q):
    # Max entropy on a·b = q is symmetric only while √q is above ≈ 0.2178 (q ≳ 0.0474).
    res = solve_feature_probabilities(ROBOT, [((LEFT, RIGHT), q.numerator, q.denominator)])
    assert res.success
    root = math.sqrt(q)
    np.testing.assert_allclose(probs(res), [root, root, 0.5, 0.5], atol=1e-7)


def brute_force_pair(q: float) -> tuple[float, float]:
    """argmax over a of H(a) + H(q/a), a ∈ [q, 1]: dense grid, then bounded polish."""
    a = np.linspace(q, 1.0, 400_001)
    i = int(np.argmax(H(a) + H(q / a)))
    lo, hi = a[max(i - 1, 0)], a[min(i + 1, len(a) - 1)]
    best = minimize_scalar(
        lambda x: -(H(x) + H(q / x)),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return float(best.x), float(-best.fun)


@pytest.mark.parametrize("q", [0.001, 0.01, 0.03, 0.045])
def test_small_q_pair_has_asymmetric_maximum(q):
    # Below the inflection the symmetric point √q is a saddle: the maximiser puts one feature
    # near 0.3–0.45 and the other low. Two mirror-image maximisers exist; the earlier-listed
    # feature gets the larger value and the message says the maximiser is not unique.
    s, n = round(q * 100_000), 100_000
    res = solve_feature_probabilities(ROBOT, [((LEFT, RIGHT), s, n)])
    a_star, h_star = brute_force_pair(s / n)
    p = probs(res)
    assert res.success
    assert p[0] > p[1]
    assert p[0] * p[1] == pytest.approx(s / n, rel=1e-9)
    assert H(p[0]) + H(p[1]) == pytest.approx(h_star, abs=1e-10)
    assert H(p[0]) + H(p[1]) > 2 * H(math.sqrt(s / n)) + 1e-6  # strictly beats symmetric
    assert p[0] == pytest.approx(a_star, abs=1e-4)
    assert "not unique" in res.message


def test_underdetermined_chain_matches_brute_force():
    # a·b = 0.3, b·c = 0.5: one free coordinate (p_b), p_a = 0.3/p_b, p_c = 0.5/p_b.
    res = solve_feature_probabilities(tuple("abc"), [(("a", "b"), 3, 10), (("b", "c"), 1, 2)])
    b = np.linspace(0.5, 1.0, 1_000_001)
    values = H(b) + H(0.3 / b) + H(0.5 / b)
    i = int(np.argmax(values))
    p = probs(res, "abc")
    assert res.success
    assert float(H(p).sum()) == pytest.approx(values[i], abs=1e-9)
    assert p[1] == pytest.approx(b[i], abs=1e-5)
    assert p[0] * p[1] == pytest.approx(0.3, rel=1e-9)
    assert p[1] * p[2] == pytest.approx(0.5, rel=1e-9)


def test_two_free_coordinates_match_grid_search_plus_polish():
    # a·b·c = 0.2, c·d = 0.6 on four features: two free coordinates (p_c, p_a).
    res = solve_feature_probabilities(tuple("abcd"), [(("a", "b", "c"), 1, 5), (("c", "d"), 3, 5)])

    def total(pc: np.ndarray, pa: np.ndarray) -> np.ndarray:
        pb, pd = 0.2 / (pa * pc), 0.6 / pc
        ok = (pb <= 1) & (pd <= 1) & (pa >= 0.2 / pc)
        return np.where(ok, H(pa) + H(np.minimum(pb, 1)) + H(pc) + H(np.minimum(pd, 1)), -np.inf)

    pc, pa = np.meshgrid(np.linspace(0.6, 1, 801), np.linspace(0.2, 1, 1601), indexing="ij")
    grid = total(pc, pa)
    i = np.unravel_index(np.argmax(grid), grid.shape)
    polish = minimize(
        lambda v: -total(np.array(v[0]), np.array(v[1])),
        [pc[i], pa[i]],
        method="Nelder-Mead",
        options={"xatol": 1e-10, "fatol": 1e-13},
    )
    p = probs(res, "abcd")
    assert res.success
    assert float(H(p).sum()) == pytest.approx(-polish.fun, abs=1e-8)
    assert float(H(p).sum()) >= -polish.fun - 1e-12


def p_space_oracle(k: int, subsets: list[tuple[int, ...]], q: np.ndarray, starts: int = 12):
    """Multi-start SLSQP directly on Eq. 4 in p space (a different method and parametrisation)."""
    A = np.zeros((len(subsets), k))
    for j, sub in enumerate(subsets):
        A[j, list(sub)] = 1.0
    cons = {"type": "eq", "fun": lambda p: A @ np.log(p) - np.log(q), "jac": lambda p: A / p}
    rng = np.random.default_rng(0)
    best = -np.inf
    for _ in range(starts):
        r = minimize(
            lambda p: -H(p).sum(),
            rng.uniform(0.05, 0.999, k),
            jac=lambda p: -np.log((1 - p) / p),
            method="SLSQP",
            bounds=[(1e-9, 1 - 1e-12)] * k,
            constraints=[cons],
            options={"ftol": 1e-14, "maxiter": 500},
        )
        if np.abs(A @ np.log(r.x) - np.log(q)).max() < 1e-8:
            best = max(best, float(H(r.x).sum()))
    return best


@pytest.mark.parametrize(
    ("subsets", "p_true"),
    [
        ([(0, 1, 2)], ("1/2", "1/3", "1/4")),
        ([(0, 1), (1, 2, 3)], ("9/10", "1/2", "3/4", "2/5")),
        ([(0, 1, 2, 3), (2, 3)], ("3/5", "2/3", "1/7", "1/2")),
        ([(0, 2), (1, 2), (0, 1, 3)], ("4/5", "1/3", "5/6", "1/2")),
    ],
)
def test_matches_independent_p_space_optimiser(subsets, p_true):
    names = [f"f{i}" for i in range(len(p_true))]
    truth = {name: Fraction(v) for name, v in zip(names, p_true, strict=True)}
    named = [tuple(names[i] for i in sub) for sub in subsets]
    obs = exact_observations(truth, named)
    res = solve_feature_probabilities(names, obs)
    q = np.array([s / n for _, s, n in obs])
    assert res.success
    assert max(abs(r) for r in res.residuals.values()) < 1e-9
    assert total_entropy(res) >= p_space_oracle(len(names), subsets, q) - 1e-8


def test_occluded_turns_are_informed_through_shared_features():
    # Only forward and stop observed (turns happen where L cannot see): the wheels and
    # navigation are interchangeable in the data, so they share forward's rate equally; floor
    # is pinned by stop. The unseen turns still get a prediction from the shared features.
    res = solve_feature_probabilities(ROBOT, [(XI["forward"], 85, 100), (XI["stop"], 99, 100)])
    p = probs(res)
    assert res.success
    assert p[3] == pytest.approx(0.99, abs=1e-12)
    expected = (0.85 / 0.99) ** (1 / 3)
    np.testing.assert_allclose(p[:3], expected, atol=1e-7)


def test_noisy_counts_recover_truth_within_sampling_error():
    rng = np.random.default_rng(7)
    for left in (0.95, 0.70):
        truth = {LEFT: left, RIGHT: 0.95, NAV: 0.97, FLOOR: 0.99}
        n = 200_000
        obs = []
        worst_var = 0.0
        for sub in XI.values():
            q = math.prod(truth[f] for f in sub)
            obs.append((sub, int(rng.binomial(n, q)), n))
            worst_var = max(worst_var, (1 - q) / (q * n))  # var of log q̂ (delta method)
        res = solve_feature_probabilities(ROBOT, obs)
        assert res.success
        # Each log p̂ is a ±-combination of at most four log q̂.
        tol = 5 * math.sqrt(4 * worst_var)
        np.testing.assert_allclose(np.log(probs(res)), np.log([truth[f] for f in ROBOT]), atol=tol)


# --------------------------------------------------------------------------------------------
# Degenerate data


def test_zero_successes_alone_zero_one_feature():
    res = solve_feature_probabilities(ROBOT, [((FLOOR,), 0, 10)])
    assert res.success
    assert res.probabilities == {LEFT: 0.5, RIGHT: 0.5, NAV: 0.5, FLOOR: 0.0}
    assert res.residuals == {(FLOOR,): 0.0}
    assert res.log_likelihood == 0.0


def test_zero_successes_on_a_pair_zero_the_later_feature_only():
    # Either feature at 0 explains it; zeroing both would lose log 2 nats for nothing.
    res = solve_feature_probabilities(ROBOT, [((NAV, LEFT), 0, 7)])
    assert res.success
    assert res.probabilities == {LEFT: 0.5, RIGHT: 0.5, NAV: 0.0, FLOOR: 0.5}


def test_zero_successes_conflicting_with_successes_give_ml_compromise():
    # stop 0/5 says floor = 0, forward 80/100 says floor >= 0.8: ML is floor = 80/105 with
    # the forward-only features at 1, and nothing is NaN.
    res = solve_feature_probabilities(ROBOT, [(XI["forward"], 80, 100), (XI["stop"], 0, 5)])
    assert_sane(res)
    assert res.success
    assert "inconsistent" in res.message
    np.testing.assert_allclose(probs(res), [1.0, 1.0, 1.0, 80 / 105], atol=1e-9)
    assert res.residuals[(FLOOR,)] == math.inf


def test_all_successes_give_exact_ones():
    res = solve_feature_probabilities(ROBOT, [((FLOOR,), 10, 10)])
    assert res.probabilities == {LEFT: 0.5, RIGHT: 0.5, NAV: 0.5, FLOOR: 1.0}
    res = solve_feature_probabilities(ROBOT, [(XI["forward"], 3, 3)])
    assert res.success
    assert res.probabilities == dict.fromkeys(ROBOT, 1.0)


def test_feature_in_no_subset_is_half_and_not_informed():
    res = solve_feature_probabilities(ROBOT + ("carpet",), [(XI["stop"], 9, 10)])
    assert res.probabilities["carpet"] == 0.5
    assert "carpet" not in res.informed
    assert res.informed == (FLOOR,)


def test_more_subsets_than_features_consistent_is_exact():
    truth = {"a": Fraction(1, 2), "b": Fraction(2, 3), "c": Fraction(3, 4)}
    subsets = [("a",), ("b",), ("c",), ("a", "b"), ("b", "c"), ("a", "b", "c")]
    res = solve_feature_probabilities(tuple("abc"), exact_observations(truth, subsets, scale=3))
    assert res.success and "consistent" in res.message
    np.testing.assert_allclose(probs(res, "abc"), [0.5, 2 / 3, 0.75], atol=1e-12)


def test_more_subsets_than_features_inconsistent_is_maximum_likelihood():
    obs = [(("a",), 10, 10), (("b",), 10, 10), (("a", "b"), 5, 10), (("a", "c"), 3, 10)]
    res = solve_feature_probabilities(tuple("abc"), obs)
    assert_sane(res)
    assert res.success and "inconsistent" in res.message

    def loglik(p: np.ndarray) -> float:
        a, b, c = np.clip(p, 1e-12, 1.0)
        q = np.array([a, b, a * b, a * c])
        s, n = np.array([10, 10, 5, 3]), np.array([10, 10, 10, 10])
        return float(np.sum(s * np.log(q) + (n - s) * np.log1p(-np.minimum(q, 1 - 1e-15))))

    grid = np.linspace(0.01, 1, 100)
    candidates = [(x, y, z) for x in grid for y in grid for z in grid[::9]]
    start = max(candidates, key=lambda v: loglik(np.array(v)))
    best = minimize(
        lambda v: -loglik(v),
        start,
        method="Nelder-Mead",
        options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 5000},
    )
    assert loglik(probs(res, "abc")) >= -best.fun - 1e-9


def test_zero_trials_and_empty_input():
    for obs in ([], [(XI["forward"], 0, 0), ((LEFT,), 0, 0)], [((), 4, 4)]):
        res = solve_feature_probabilities(ROBOT, obs)
        assert res.success
        assert res.probabilities == dict.fromkeys(ROBOT, 0.5)
        assert res.informed == ()
        assert res.residuals == {}
        assert res.log_likelihood == 0.0


def test_identical_subsets_pool_counts_not_rates():
    # 1/2 and 50/100 pool to 51/102 = 0.5; 0/1 and 99/100 pool to 99/101, not to 0.495.
    res = solve_feature_probabilities(ROBOT, [((FLOOR,), 0, 1), ((FLOOR,), 99, 100)])
    assert res.probabilities[FLOOR] == pytest.approx(99 / 101, abs=1e-12)
    res = solve_feature_probabilities(ROBOT, [((LEFT, FLOOR), 1, 4), ((FLOOR, LEFT), 3, 4)])
    assert list(res.residuals) == [(LEFT, FLOOR)]  # order of ``features``, one pooled key


def test_log_likelihood_is_the_binomial_log_pmf():
    res = solve_feature_probabilities(ROBOT, [((FLOOR,), 7, 10)])
    assert res.log_likelihood == pytest.approx(
        math.log(math.comb(10, 7) * 0.7**7 * 0.3**3), rel=1e-12
    )


# --------------------------------------------------------------------------------------------
# Properties


@st.composite
def consistent_problems(draw):
    k = draw(st.integers(1, 4))
    names = [f"f{i}" for i in range(k)]
    truth = {}
    for name in names:
        den = draw(st.integers(1, 8))
        truth[name] = Fraction(draw(st.integers(1, den)), den)
    all_subsets = [
        tuple(n for i, n in enumerate(names) if mask >> i & 1) for mask in range(1, 2**k)
    ]
    subsets = draw(st.lists(st.sampled_from(all_subsets), min_size=1, max_size=5, unique=True))
    return names, exact_observations(truth, subsets, scale=draw(st.integers(1, 3)))


@st.composite
def arbitrary_problems(draw):
    k = draw(st.integers(1, 5))
    names = [f"f{i}" for i in range(k)]
    obs = []
    for _ in range(draw(st.integers(0, 6))):
        sub = draw(st.lists(st.sampled_from(names), max_size=k, unique=True))
        n = draw(st.sampled_from([0, 1, 2, 3, 10, 50, 1000]))
        s = n if not sub else draw(st.integers(0, n))
        obs.append((tuple(sub), s, n))
    return names, obs


@settings(max_examples=60, deadline=None)
@given(consistent_problems())
def test_property_consistent_constraints_are_met(problem):
    names, obs = problem
    res = solve_feature_probabilities(names, obs)
    assert_sane(res)
    assert res.success, res.message
    assert max(abs(r) for r in res.residuals.values()) < 1e-6


@settings(max_examples=80, deadline=None)
@given(arbitrary_problems())
# two features pinned near p = 1, where dH/dx is large: an absolute stationarity tolerance
# rejected SLSQP's maximiser at a reduced gradient of 1.2e-6 (relative 1.7e-7)
@example((["f0", "f1", "f2", "f3"], [(("f0", "f1", "f2", "f3"), 519, 1000), ((), 0, 0),
                                     (("f0", "f1"), 26, 50)]))  # fmt: skip
def test_property_any_data_gives_probabilities_without_nan(problem):
    names, obs = problem
    res = solve_feature_probabilities(names, obs)
    assert_sane(res)
    assert set(res.probabilities) == set(names)
    assert res.success, res.message


@settings(max_examples=40, deadline=None)
@given(arbitrary_problems(), st.randoms(use_true_random=False))
def test_property_observation_order_does_not_matter(problem, rnd):
    names, obs = problem
    shuffled = list(obs)
    rnd.shuffle(shuffled)
    shuffled = [(tuple(reversed(sub)), s, n) for sub, s, n in shuffled]
    a = solve_feature_probabilities(names, obs)
    b = solve_feature_probabilities(names, shuffled)
    assert a.probabilities == b.probabilities


@settings(max_examples=40, deadline=None)
@given(arbitrary_problems(), st.data())
def test_property_splitting_counts_does_not_matter(problem, data):
    names, obs = problem
    split = []
    for sub, s, n in obs:
        n1 = data.draw(st.integers(0, n))
        s1 = data.draw(st.integers(max(0, s - (n - n1)), min(s, n1)))
        split += [(sub, s1, n1), (sub, s - s1, n - n1)]
    a = solve_feature_probabilities(names, obs)
    b = solve_feature_probabilities(names, split)
    assert a.probabilities == b.probabilities


# --------------------------------------------------------------------------------------------
# The paper's procedure (BFGS on the squared Lagrangian gradient)


def test_paper_method_agrees_on_easy_consistent_cases():
    truth = {
        LEFT: Fraction(70, 100),
        RIGHT: Fraction(95, 100),
        NAV: Fraction(97, 100),
        FLOOR: Fraction(99, 100),
    }
    for obs in (
        exact_observations(truth, list(XI.values())),
        [(XI["forward"], 85, 100), (XI["stop"], 99, 100)],
        [((LEFT, RIGHT), 64, 100)],
    ):
        ours = solve_feature_probabilities(ROBOT, obs)
        paper = solve_feature_probabilities(ROBOT, obs, method="paper")
        assert paper.success, paper.message
        assert paper.method == "paper"
        np.testing.assert_allclose(probs(paper), probs(ours), atol=1e-3)


def test_paper_method_stops_at_the_symmetric_saddle_for_small_q():
    # Its stationarity conditions cannot tell a maximum from a saddle: with q = 0.01 on {a, b}
    # it meets the constraint at a = b = 0.1, 0.14 nats below the true maximum.
    obs = [((LEFT, RIGHT), 1, 100)]
    ours = solve_feature_probabilities(ROBOT, obs)
    paper = solve_feature_probabilities(ROBOT, obs, method="paper")
    assert paper.success  # constraints are met ...
    np.testing.assert_allclose(probs(paper)[:2], 0.1, atol=1e-4)
    assert total_entropy(paper) < total_entropy(ours) - 0.1  # ... but it is not the maximum


def test_paper_method_fails_on_inconsistent_data():
    obs = [((LEFT,), 10, 10), ((NAV,), 10, 10), ((LEFT, NAV), 5, 10)]
    ours = solve_feature_probabilities(ROBOT, obs)
    paper = solve_feature_probabilities(ROBOT, obs, method="paper")
    assert_sane(paper)
    assert not paper.success and "constraints not met" in paper.message
    assert paper.log_likelihood < ours.log_likelihood - 0.1


def assert_zero_rate_alone_is_honest(paper: FeatureSolveResult) -> None:
    """The paper's BFGS on a lone q = 0 (floor 0 of 10), whatever the CPU.

    The squared gradient has a cliff at the clip, and where BFGS ends depends on the last bits
    of BLAS's dot products: with OpenBLAS's Haswell, Zen and SkylakeX kernels it meets the
    clipped constraint (floor <= 1e-6); with its Nehalem, Sandybridge, Prescott and Atom kernels
    its line search loses precision at L' = 33 (floor 2.5e-5 to 4.3e-5, the other features
    0.14-0.18). Either way floor is near 0 and ``success`` says which of the two happened.
    """
    assert_sane(paper)
    floor = paper.probabilities[FLOOR]
    assert floor < 1e-4
    met = floor <= 1e-6 * math.exp(1e-6)
    assert paper.success == met, paper.message
    if not met:
        assert "constraints not met" in paper.message


def test_paper_method_on_zero_and_one_rates():
    # q = 0 beside successes: log 0 is replaced by log 1e-6, which cannot be met.
    obs = [(XI["forward"], 80, 100), (XI["stop"], 0, 5)]
    paper = solve_feature_probabilities(ROBOT, obs, method="paper")
    assert_sane(paper)
    assert not paper.success
    assert "q = 0" in paper.message
    # q = 0 alone: floor is driven towards the clip at 1e-6 rather than 0.
    assert_zero_rate_alone_is_honest(
        solve_feature_probabilities(ROBOT, [((FLOOR,), 0, 10)], method="paper")
    )
    # q = 1: stationarity needs λ → ∞ (log p̄ at p̄ = 0); BFGS runs out of iterations near 1.
    paper = solve_feature_probabilities(ROBOT, [((FLOOR,), 10, 10)], method="paper")
    assert_sane(paper)
    assert not paper.success
    assert paper.probabilities[FLOOR] > 0.999


_ZERO_RATE_ALONE = """
import json
from mirl.learning.feature_solver import solve_feature_probabilities
r = solve_feature_probabilities(
    ("left_wheel", "right_wheel", "navigation", "floor"), [(("floor",), 0, 10)], method="paper"
)
print(json.dumps({"p": r.probabilities, "success": r.success, "message": r.message}))
"""


@pytest.mark.parametrize("kernel", ["Haswell", "Nehalem", "Sandybridge", "Prescott"])
def test_paper_method_on_a_zero_rate_is_honest_under_every_blas_kernel(kernel):
    # OpenBLAS picks its kernels by CPU; OPENBLAS_CORETYPE makes this machine use another CPU's
    # (ignored where OpenBLAS was built for one CPU: the check then repeats this machine's).
    env = dict(os.environ, OPENBLAS_CORETYPE=kernel)
    out = subprocess.run(
        [sys.executable, "-c", _ZERO_RATE_ALONE], env=env, capture_output=True, text=True,
        check=True,
    ).stdout  # fmt: skip
    got = json.loads(out)
    assert set(got["p"]) == set(ROBOT)
    floor = got["p"][FLOOR]
    assert 0.0 <= floor < 1e-4
    met = floor <= 1e-6 * math.exp(1e-6)
    assert got["success"] == met, got["message"]
    assert met or "constraints not met" in got["message"]


# --------------------------------------------------------------------------------------------
# Input validation


@pytest.mark.parametrize(
    ("features", "observations", "match"),
    [
        (
            ROBOT,
            [((FLOOR,), 1, 2), ((FLOOR, "carpet"), 1, 2)],
            r"observation 1: unknown feature 'carpet' \(known: left_wheel, right_wheel",
        ),
        (ROBOT, [((FLOOR,), 5, 3)], r"observation 0: successes 5 exceed trials 3"),
        (ROBOT, [((FLOOR,), -1, 3)], r"observation 0: successes must be non-negative"),
        (ROBOT, [((FLOOR,), 1, -3)], r"observation 0: trials must be non-negative"),
        (ROBOT, [((FLOOR,), 2.5, 3)], r"observation 0: successes must be an integer"),
        (ROBOT, [((FLOOR,), True, 3)], r"observation 0: successes must be an integer"),
        (ROBOT, [((FLOOR,), 1, float("nan"))], r"observation 0: trials must be an integer"),
        (ROBOT, [((), 1, 3)], r"observation 0: empty subset with 2 failures"),
        (ROBOT, [("floor", 1, 3)], r"observation 0: subset must be an iterable .* not the string"),
        (ROBOT, [((FLOOR, FLOOR), 1, 3)], r"observation 0: feature 'floor' repeated"),
        (ROBOT, [((FLOOR,), 1)], r"observation 0: expected \(subset, successes, trials\)"),
        (ROBOT, [(5, 1, 2)], r"observation 0: subset must be an iterable"),
        ((LEFT, FLOOR, LEFT), [], r"duplicate feature names: left_wheel"),
        ("floor", [], r"not a single string"),
    ],
)
def test_bad_input_names_the_offending_item(features, observations, match):
    with pytest.raises(ValueError, match=match):
        solve_feature_probabilities(features, observations)


def test_unknown_method_rejected_and_integral_counts_accepted():
    with pytest.raises(ValueError, match="unknown method 'nelder'"):
        solve_feature_probabilities(ROBOT, [], method="nelder")
    res = solve_feature_probabilities(
        ROBOT, [((FLOOR,), np.int64(3), 4.0), ([FLOOR], 1, np.uint8(1))]
    )
    assert res.probabilities[FLOOR] == pytest.approx(0.8)


def test_one_robot_program_solves_in_milliseconds():
    truth = {
        LEFT: Fraction(70, 100),
        RIGHT: Fraction(95, 100),
        NAV: Fraction(97, 100),
        FLOOR: Fraction(99, 100),
    }
    obs = exact_observations(truth, list(XI.values()))
    times = timeit.repeat(lambda: solve_feature_probabilities(ROBOT, obs), number=1, repeat=100)
    assert statistics.median(times) < 0.02
