"""The stated chance's held-out calibration: the fit against an independent Newton solve, its
recovery of a known map, the shipped maps, and a statement mapped as the run states it."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import expit, logit

from mirl.learning.methods import get_method
from mirl.planning.chance_calibration import (
    CALIBRATION_FILE,
    FIXED_OBSERVATION,
    MIRL_RUN,
    ChanceMap,
    calibrate_chance,
    calibration_maps,
    calibration_protocols,
    choose_prior_precision,
    fit_calibration,
    maps_to_json,
)
from mirl.planning.posterior_chance import StatedChance


def _synthetic(theta, n, seed):
    rng = np.random.default_rng(seed)
    chance = rng.uniform(0.02, 0.98, n)
    width = rng.uniform(0.0, 0.5, n)
    view = rng.choice([0.13, 1.0], n)
    z = theta[0] + theta[1] * logit(chance) + theta[2] * width + theta[3] * view
    return chance, width, view, rng.random(n) < expit(z)


def _newton(chance, width, view, success):
    """Unpenalised logistic regression by iteratively reweighted least squares, written apart
    from the module's L-BFGS fit."""
    X = np.column_stack([np.ones_like(chance), logit(chance), width, view])
    y = success.astype(float)
    theta = np.zeros(4)
    for _ in range(50):
        p = expit(X @ theta)
        step = np.linalg.solve(X.T @ (X * (p * (1 - p))[:, None]), X.T @ (y - p))
        theta += step
        if np.abs(step).max() < 1e-12:
            break
    return theta


def test_fit_without_prior_is_the_maximum_likelihood_fit():
    data = _synthetic((0.3, 0.7, 0.8, -0.4), 3000, seed=1)
    m = fit_calibration(*data, prior_precision=0.0)
    np.testing.assert_allclose([m.intercept, m.slope, m.width, m.view], _newton(*data), atol=1e-4)


def test_fit_recovers_a_known_map():
    truth = np.array([0.4, 0.6, 1.0, -0.5])
    chance, width, view, success = _synthetic(truth, 40_000, seed=2)
    m = fit_calibration(chance, width, view, success)
    # within four standard errors (the inverse Fisher information at the truth)
    X = np.column_stack([np.ones_like(chance), logit(chance), width, view])
    p = expit(X @ truth)
    se = np.sqrt(np.diag(np.linalg.inv(X.T @ (X * (p * (1 - p))[:, None]))))
    assert np.all(np.abs([m.intercept, m.slope, m.width, m.view] - truth) < 4 * se)
    assert m.runs == 40_000


def test_a_calibrated_chance_is_left_nearly_as_it_is():
    rng = np.random.default_rng(3)
    chance = rng.uniform(0.05, 0.95, 4000)
    width, view = rng.uniform(0, 0.4, 4000), rng.choice([0.13, 1.0], 4000)
    m = fit_calibration(chance, width, view, rng.random(4000) < chance)
    assert np.abs(m(chance, width, view) - chance).max() < 0.05


@settings(max_examples=50, deadline=None)
@given(
    a=st.floats(-2, 2), b=st.floats(0.05, 3), c=st.floats(-2, 2), d=st.floats(-2, 2),
    x=st.lists(st.floats(0, 1), min_size=2, max_size=20),
)  # fmt: skip
def test_a_map_is_monotone_and_keeps_the_chance_in_its_interval(a, b, c, d, x):
    m = ChanceMap(a, b, c, d, runs=20, fitted_on="")
    xs = np.sort(np.array(x))
    ys = m(xs, 0.2, 0.5)
    assert np.all(np.diff(ys) >= 0)
    assert np.all((ys > 0) & (ys < 1))


def _held_out_loss(data, groups, precision):
    """Leave-one-range-out log loss written out apart from the module's loop."""
    chance, width, view, success = data
    total = 0.0
    for g in np.unique(groups):
        fit = groups != g
        m = fit_calibration(
            chance[fit], width[fit], view[fit], success[fit], prior_precision=precision
        )
        q = m(chance[~fit], width[~fit], view[~fit])
        total += -np.sum(success[~fit] * np.log(q) + (~success[~fit]) * np.log(1 - q))
    return total / len(success)


def test_the_precision_is_the_one_whose_maps_carry_best_across_ranges():
    data = _synthetic((0.3, 0.8, -0.5, 0.2), 900, seed=5)
    groups = np.repeat([9000, 77000, 0], 300)
    chosen, losses = choose_prior_precision(*data, groups, precisions=(1.0, 100.0, 1e4))
    for precision, loss in losses.items():
        assert loss == pytest.approx(_held_out_loss(data, groups, precision), rel=1e-9)
    assert losses[chosen] == min(losses.values())


def test_a_bias_the_ranges_share_is_kept_and_one_they_do_not_is_shrunk():
    # every range biased alike: the map must move (a small precision carries best)
    rng = np.random.default_rng(6)
    chance = rng.uniform(0.05, 0.95, 3000)
    width, view = rng.uniform(0, 0.4, 3000), rng.choice([0.13, 1.0], 3000)
    groups = np.repeat([1, 2, 3], 1000)
    biased = rng.random(3000) < expit(logit(chance) - 1.0)
    chosen, _ = choose_prior_precision(chance, width, view, biased, groups)
    assert chosen <= 10
    # a calibrated chance: whatever the precision chosen, the map stays near the identity
    calibrated = rng.random(3000) < chance
    chosen, _ = choose_prior_precision(chance, width, view, calibrated, groups)
    m = fit_calibration(chance, width, view, calibrated, prior_precision=chosen)
    assert np.abs(m(chance, width, view) - chance).max() < 0.05


def test_choosing_the_precision_needs_two_ranges():
    data = _synthetic((0.0, 1.0, 0.0, 0.0), 100, seed=7)
    with pytest.raises(ValueError, match="at least two seed ranges"):
        choose_prior_precision(*data, np.zeros(100))
    with pytest.raises(ValueError, match="100 chances, 100 outcomes and 99 groups"):
        choose_prior_precision(*data, np.zeros(99))


def test_bad_fits_are_refused():
    with pytest.raises(ValueError, match="slope must be positive"):
        ChanceMap(0.0, 0.0, 0.0, 0.0, runs=20, fitted_on="")
    with pytest.raises(ValueError, match="at least 20 runs"):
        fit_calibration([0.5] * 5, [0.1] * 5, [1.0] * 5, [True] * 5)
    with pytest.raises(ValueError, match="30 chances but 29 outcomes"):
        fit_calibration([0.5] * 30, [0.1] * 30, [1.0] * 30, [True] * 29)


def test_the_shipped_maps_are_for_methods_that_learn_under_each_protocol():
    protocols = calibration_protocols()
    assert set(protocols) == {MIRL_RUN, FIXED_OBSERVATION}
    assert protocols[MIRL_RUN].options == {}
    assert protocols[FIXED_OBSERVATION].options == {"watch_until_seen": None}
    for p in protocols.values():  # fitted in the grid world only, and saying so
        assert p.worlds == ("grid",)
        assert all("(grid)" in m.fitted_on and "(physics)" not in m.fitted_on
                   for m in p.maps.values())  # fmt: skip
    for protocol in protocols:
        maps = calibration_maps(protocol)
        assert set(maps) == {"mirl-t", "mirl", "known-r-t", "dbn-em"}
        for name, m in maps.items():
            assert get_method(name).learns
            assert m.slope > 0 and m.runs >= 200
            assert "seeds run_seed(" in m.fitted_on
    # the file is exactly what the fitting script writes for what it holds
    text = (resources.files("mirl") / "data" / CALIBRATION_FILE).read_text(encoding="utf-8")
    assert maps_to_json(protocols) == text


def test_a_protocol_without_maps_is_refused_by_name():
    with pytest.raises(ValueError, match="no stated-chance calibration for protocol 'paper'"):
        calibration_maps("paper")


def test_the_same_average_is_stated_through_its_protocols_map():
    s = StatedChance(0.7, (0.5, 0.85), 0.75, draws=(0.5, 0.7, 0.85))
    for protocol in (MIRL_RUN, FIXED_OBSERVATION):
        m = calibration_maps(protocol)["mirl-t"]
        assert s.calibrated("mirl-t", 0.13, protocol).mean == pytest.approx(
            float(m(0.7, 0.35, 0.13))
        )


def test_a_method_without_a_map_states_its_average():
    assert calibrate_chance("oracle", 0.7, (0.6, 0.8), 1.0) is None
    s = StatedChance(0.7, (0.6, 0.8), 0.75, draws=(0.6, 0.7, 0.8))
    assert s.calibrated("oracle", 1.0) is s


def test_a_statement_is_mapped_with_its_spread_and_keeps_its_average():
    s = StatedChance(0.7, (0.5, 0.85), 0.75, draws=(0.5, 0.7, 0.85))
    c = s.calibrated("mirl-t", 0.13)
    m = calibration_maps()["mirl-t"]
    assert c.averaged == 0.7 and c.point == 0.75 and c.draws == s.draws
    assert c.averaged_interval == (0.5, 0.85)  # what a refit of the map reads
    assert c.mean == pytest.approx(float(m(0.7, 0.35, 0.13)))
    assert c.interval == pytest.approx((float(m(0.5, 0.35, 0.13)), float(m(0.85, 0.35, 0.13))))
    assert c.interval[0] <= c.mean <= c.interval[1]
    assert c.calibrated("mirl-t", 0.13) is c  # mapped once only
    point_only = StatedChance(0.7, (0.7, 0.7), 0.7)  # nothing drawn: the point chance stands
    assert point_only.calibrated("mirl-t", 0.13) is point_only


@given(
    chance=st.floats(0.01, 0.99),
    lo_gap=st.floats(0.0, 0.3),
    hi_gap=st.floats(0.0, 0.3),
    view=st.floats(0.05, 1.0),
)
@settings(max_examples=60, deadline=None)
def test_a_mapped_interval_is_taken_back_through_its_map(chance, lo_gap, hi_gap, view):
    lo, hi = max(chance - lo_gap, 0.002), min(chance + hi_gap, 0.998)
    for name, m in calibration_maps(FIXED_OBSERVATION).items():  # DBN-EM's width weight is ~0
        mapped = calibrate_chance(name, chance, (lo, hi), view, FIXED_OBSERVATION)
        assert mapped is not None
        back = m.unmapped_interval(mapped[0], mapped[1], chance, view)
        assert back == pytest.approx((lo, hi), abs=1e-9)
