"""Stored runs grouped by condition: rates with their standard errors, means over the runs
that recorded a value, and the methods named as the paper names them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mirl.experiments.conditions import Condition
from mirl.viz.aggregate import PAPER_NAMES, Group, groups, method_name


def _row(condition: Condition, outcome: str, **values):
    return {"condition_key": condition.key, "outcome": outcome, **values}


def test_methods_are_named_as_the_paper_names_them_with_their_settings():
    assert method_name(Condition("mirl-t")) == PAPER_NAMES["mirl-t"]
    assert method_name(Condition("mirl", p=0.9)) == f"{PAPER_NAMES['mirl']} (p=0.9)"
    named = method_name(Condition("dbn-em", em_init="uniform"))
    assert named == f"{PAPER_NAMES['dbn-em']} (uniform init)"
    assert method_name(Condition("no-such-method")) == "no-such-method"


def test_runs_are_grouped_by_condition_in_first_seen_order_without_errors():
    a, b = Condition("mirl-t"), Condition("random", observability=0.3)
    rows = [
        _row(b, "success"),
        _row(a, "detected"),
        _row(a, "error"),
        _row(b, "timeout"),
        _row(a, "success"),
    ]
    got = groups(rows)
    assert [g.condition for g in got] == [b, a]
    assert [g.n for g in got] == [2, 2]  # the error run is not a run of its condition


def test_rates_means_and_their_spread():
    g = Group(
        Condition("mirl-t"),
        [
            {"outcome": "success", "go_time": 10.0, "accuracy": 0.5},
            {"outcome": "success", "go_time": 20.0, "accuracy": None},
            {"outcome": "detected", "go_time": float("nan")},
            {"outcome": "success", "go_time": 30.0},
        ],
    )
    assert g.rate("success") == 0.75 and g.rate("timeout") == 0.0
    assert g.rate_se("success") == pytest.approx(math.sqrt(0.75 * 0.25 / 4))
    np.testing.assert_array_equal(g.values("go_time"), [10.0, 20.0, 30.0])  # NaN left out
    assert g.mean_std("go_time") == pytest.approx((20.0, 10.0))  # sample std, ddof 1
    assert g.mean_std("accuracy") == (0.5, 0.0)  # one value: no spread
    mean, std = g.mean_std("missing")
    assert math.isnan(mean) and math.isnan(std)
    empty = Group(Condition("mirl-t"), [])
    assert math.isnan(empty.rate("success")) and math.isnan(empty.rate_se("success"))
