"""Scenario files as data: reward features of every kind with per-robot weights,
per-pair equilibria, and strict typed reading — every value of the wrong type, non-finite,
fractional where a count belongs, off the map, or a section of the wrong shape is one
ScenarioError naming the file and the field path; any bytes give a Scenario or a ScenarioError."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mirl.world.domain import FORWARD, TURN_LEFT, TURN_RIGHT
from mirl.world.scenario import Scenario, ScenarioError, load_scenario

NEW = """\
name = "routes"
map = "boyd2"

[observer]
start = [0, 0]
goal = [9, 1]

[reward]
features = [
  { name = "moved", kind = "moved" },
  { name = "top", kind = "region", cells = [{ from = [0, 2], to = [0, 8] }, [1, 1]] },
  { name = "bottom", kind = "region", cells = { from = [16, 2], to = [16, 8] } },
  { name = "ends", kind = "turn_around", cells = [[0, 8], [16, 8]] },
  { name = "west_on_top", kind = "heading_in_region", cells = [[0, 5]], headings = ["west", 1] },
]
weights = { moved = 1.0, top = 0.0, bottom = 0.0, ends = 0.3, west_on_top = 0.0 }

[game]
played = ["stop", "go"]
pairs = [{ robots = ["K", "I"], played = ["go", "stop"] }]

[[robots]]
name = "I"
start = [0, 8, 2]
weights = { top = 0.5 }

[[robots]]
name = "J"
start = [16, 8, 2]
weights = { bottom = 0.5 }

[[robots]]
name = "K"
start = [8, 1, 1]
"""


def _write(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_reward_features_as_data(tmp_path):
    sc = load_scenario(_write(tmp_path, NEW))
    d = sc.domain
    assert d.reward_feature_names == ("moved", "top", "bottom", "ends", "west_on_top")
    phi = d.reward_features
    assert phi.shape == (d.n_states, 4, 5)
    top = {(0, c) for c in range(2, 9)} | {(1, 1)}
    for s, (r, c, h) in enumerate(d.states.tolist()):
        assert phi[s, :, 1].tolist() == [float((r, c) in top)] * 4
        assert phi[s, :, 2].tolist() == [float(r == 16 and 2 <= c <= 8)] * 4
        end = (r, c) in {(0, 8), (16, 8)}
        assert phi[s, [TURN_LEFT, TURN_RIGHT], 3].tolist() == [float(end)] * 2
        assert phi[s, FORWARD, 3] == 0.0
        assert phi[s, 0, 4] == float((r, c) == (0, 5) and h in (1, 2))
    # per-robot weights: the table's, updated by each robot's own
    np.testing.assert_array_equal(sc.robots[0].weights, [1.0, 0.5, 0.0, 0.3, 0.0])
    np.testing.assert_array_equal(sc.robots[1].weights, [1.0, 0.0, 0.5, 0.3, 0.0])
    np.testing.assert_array_equal(sc.robots[2].weights, [1.0, 0.0, 0.0, 0.3, 0.0])
    # different weights, different routes: I's policy differs from J's somewhere
    assert (sc.true_policy(0) != sc.true_policy(1)).any()
    # per-pair equilibrium, stored with the lower index as row player: (I, K) -> I plays stop
    assert sc.pair_equilibrium(0, 2).label() == "stop/go"
    assert sc.pair_equilibrium(0, 1).label() == "stop/go"
    assert sc.pairs == ((0, 1), (0, 2), (1, 2))


def test_pair_equilibrium_override(tmp_path):
    text = NEW.replace('played = ["go", "stop"] }', 'played = ["stop", "go"] }')
    sc = load_scenario(_write(tmp_path, text))
    assert sc.pair_equilibrium(0, 2).label() == "go/stop"  # K stops, I (row) goes


BAD = {
    "bool_probability": (
        "start = [16, 8, 2]",
        "start = [16, 8, 2]\nfeature_probabilities = { floor = true }",
        "robots[1].feature_probabilities.floor",
    ),  # fmt: skip
    "string_weight": ("ends = 0.3", 'ends = "high"', "reward.weights.ends"),
    "nan_weight": ("ends = 0.3", "ends = nan", "reward.weights.ends"),
    "inf_weight": ("ends = 0.3", "ends = inf", "reward.weights.ends"),
    "nan_probability": (
        "start = [16, 8, 2]",
        "start = [16, 8, 2]\nfeature_probabilities = { floor = nan }",
        "robots[1].feature_probabilities.floor",
    ),  # fmt: skip
    "fraction_start": ("start = [0, 8, 2]", "start = [0, 8.5, 2]", "robots[0].start"),
    "fraction_detect": ('map = "boyd2"', 'map = "boyd2"\ndetect_distance = 2.5', "detect_distance"),
    "bool_detect": ('map = "boyd2"', 'map = "boyd2"\ndetect_distance = true', "detect_distance"),
    "string_observability": (
        'map = "boyd2"',
        'map = "boyd2"\nobservability = "0.1"',
        "observability",
    ),
    "nan_discount": ('map = "boyd2"', 'map = "boyd2"\ndiscount = nan', "discount"),
    "payoff_string": (
        "[game]",
        '[game]\nrow_payoffs = [[-10, 2, 2], [0, "x", 0], [-1, -1, -1]]',
        "game.row_payoffs[1][1]",
    ),  # fmt: skip
    "payoff_shape": ("[game]", "[game]\ncol_payoffs = [1, 2, 3]", "game.col_payoffs[0]"),
    "reward_not_table": ("[reward]\nfeatures", "[reward]\nx = 1\nfeatures", "reward.x"),
    "features_not_list": ("features = [", "features = 3\nold = [", "reward"),
    "start_table": ("start = [8, 1, 1]", "start = { row = 8 }", "robots[2].start"),
    "offmap_goal": ("goal = [9, 1]", "goal = [900, 1]", "observer.goal"),
    "negative_goal": ("goal = [9, 1]", "goal = [-1, 1]", "observer.goal"),
    "negative_start": ("start = [0, 8, 2]", "start = [-16, 8, 2]", "robots[0].start"),
    "offmap_region": ("[1, 1]]", "[1, 99]]", "reward.features[1].cells[1]"),
    "goal_is_start": ("goal = [9, 1]", "goal = [0, 0]", "observer.goal"),
    "unknown_kind": ('kind = "moved"', 'kind = "speed"', "reward.features[0].kind"),
    "region_without_cells": (
        ", cells = { from = [16, 2], to = [16, 8] }",
        "",
        "reward.features[2]",
    ),
    "bad_heading": (
        'headings = ["west", 1]',
        'headings = ["up"]',
        "reward.features[4].headings[0]",
    ),
    "duplicate_feature": ('name = "bottom"', 'name = "top"', "reward.features[2].name"),
    "missing_weight": (", west_on_top = 0.0 }", " }", "robots[0].weights"),
    "legacy_and_features": ("[reward]\n", "[reward]\nupper_hallway = [[0, 2]]\n", "reward"),
    "pair_unknown_robot": ('robots = ["K", "I"]', 'robots = ["K", "Q"]', "game.pairs[0].robots[1]"),
    "pair_not_equilibrium": (
        'played = ["go", "stop"] }',
        'played = ["go", "go"] }',
        "game.pairs[0].played",
    ),  # fmt: skip
    "name_number": ('name = "routes"', "name = 3", "name"),
    "map_number": ('map = "boyd2"', "map = 3", "map"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_values_name_file_and_path(tmp_path, case):
    old, new, field = BAD[case]
    assert old in NEW, case
    path = _write(tmp_path, NEW.replace(old, new, 1), f"bad-{case}.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: "), msg
    assert field in msg, msg
    assert "\n" not in msg


VALUES = st.one_of(
    st.booleans(),
    st.integers(-(10**20), 10**20),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.lists(st.integers(-3, 30), max_size=4),
)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.binary(max_size=300))
def test_any_bytes_give_a_scenario_or_a_scenario_error(tmp_path, data):
    path = tmp_path / "fuzz.toml"
    path.write_bytes(data)
    try:
        assert isinstance(load_scenario(path), Scenario)
    except ScenarioError as exc:
        assert "\n" not in str(exc)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    field=st.sampled_from(["start", "goal", "weights", "cells", "headings", "played", "top"]),
    value=VALUES,
)
def test_any_value_in_any_field_is_accepted_or_named(tmp_path, field, value):
    """Replace one value of the good scenario with anything TOML can hold."""
    import json

    text = json.dumps(value) if not isinstance(value, float) else repr(value)
    text = {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(text, text)
    if isinstance(value, bool):
        text = str(value).lower()
    targets = {
        "start": ("start = [0, 8, 2]", f"start = {text}"),
        "goal": ("goal = [9, 1]", f"goal = {text}"),
        "weights": ("weights = { top = 0.5 }", f"weights = {{ top = {text} }}"),
        "cells": ("cells = [[0, 5]]", f"cells = {text}"),
        "headings": ('headings = ["west", 1]', f"headings = {text}"),
        "played": ('played = ["stop", "go"]', f"played = {text}"),
        "top": ("ends = 0.3", f"ends = {text}"),
    }
    old, new = targets[field]
    path = tmp_path / "one.toml"
    path.write_text(NEW.replace(old, new, 1))
    try:
        load_scenario(path)
    except ScenarioError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)


@pytest.mark.parametrize("name", ["boyd2", "boyd2-healthy", "boydright"])
def test_shipped_scenarios_keep_the_paper_features(name):
    sc = load_scenario(name)
    assert sc.domain.reward_feature_names == (
        "moved",
        "upper_hallway",
        "lower_hallway",
        "turn_around",
    )
    for r in sc.robots:
        np.testing.assert_array_equal(r.weights, [1.0, 0.05, 0.05, 0.3])


@pytest.mark.parametrize("text", ["", "  ", " J", "J ", "J=K", "a:b", "a,b", "two\nlines", "J\r"])
def test_a_name_the_command_line_cannot_give_is_refused(text):
    """--damage ROBOT:FEATURE=P and --topic TOPIC=ROBOT split on , : = and strip what they
    read, and a report prints name=value: such a name could never be given or read back."""
    from mirl.world import schema

    with pytest.raises(schema.FieldError, match=r"robots\[0\]\.name: .* is not a usable robot"):
        schema.name(text, "robots[0].name", "robot")
    assert schema.name("left wheel", "f", "transition feature") == "left wheel"
