"""What "damaged" means (mirl.world.faults) and the scenario's [faults] table."""

from __future__ import annotations

import pytest

from mirl.world.faults import (
    HEALTHY_PROBABILITIES,
    WHEELS,
    DamageDefinition,
    read_faults,
)
from mirl.world.scenario import ScenarioError, load_scenario
from mirl.world.schema import FieldError

FEATURES = ("left_wheel", "right_wheel", "navigation", "floor")


def test_default_threshold_is_healthy_minus_margin():
    d = DamageDefinition()
    assert d.threshold("left_wheel") == pytest.approx(0.80)
    assert d.damaged("left_wheel", 0.7) and not d.damaged("left_wheel", 0.85)
    assert d.damaged_parts({"left_wheel": 0.7, "right_wheel": 0.95}) == ("left_wheel",)
    assert d.threshold("custom") == pytest.approx(0.80)


def test_wheels_and_healthy_levels_have_one_home():
    """The wheels and the healthy levels are defined here and only imported elsewhere: the
    scenario's default robots, the verdicts and the physical world read these objects."""
    from mirl.learning import verdicts
    from mirl.physics import config
    from mirl.world import scenario, scenario_sections
    from mirl.world.domain import DEFAULT_FEATURE_MAP

    assert verdicts.WHEELS is WHEELS and config.WHEELS is WHEELS
    assert scenario.HEALTHY_PROBABILITIES is HEALTHY_PROBABILITIES
    assert scenario_sections.HEALTHY_PROBABILITIES is HEALTHY_PROBABILITIES
    assert set(WHEELS) <= set(DEFAULT_FEATURE_MAP.features) == set(HEALTHY_PROBABILITIES)
    assert DamageDefinition().healthy == HEALTHY_PROBABILITIES


def test_shipped_scenarios_have_the_default():
    assert load_scenario("boyd2").faults == DamageDefinition()


def test_faults_table_is_read_and_checked():
    d = read_faults({"healthy": {"left_wheel": 0.9}, "margin": 0.1}, FEATURES)
    assert d.threshold("left_wheel") == pytest.approx(0.8)
    assert d.threshold("navigation") == pytest.approx(0.87)
    with pytest.raises(FieldError, match="faults.healthy.wheel"):
        read_faults({"healthy": {"wheel": 0.9}}, FEATURES)
    with pytest.raises(FieldError, match="faults.margin"):
        read_faults({"margin": 1.5}, FEATURES)
    with pytest.raises(FieldError, match="faults.colour"):
        read_faults({"colour": 1}, FEATURES)
    with pytest.raises(ValueError, match="`margin`"):
        DamageDefinition(margin=0.0)


def test_a_scenario_file_sets_its_faults(tmp_path):
    from importlib.resources import files

    text = files("mirl.data.scenarios").joinpath("boyd2.toml").read_text()
    path = tmp_path / "s.toml"
    path.write_text(text + "\n[faults]\nmargin = 0.2\n")
    assert load_scenario(path).faults.threshold("left_wheel") == pytest.approx(0.75)
    path.write_text(text + "\n[faults]\nmargin = 'x'\n")
    with pytest.raises(ScenarioError, match="faults.margin"):
        load_scenario(path)


def test_the_faults_table_says_how_a_weak_wheel_drifts():
    d = read_faults({"drift": {"per_gap": 0.3, "spread": 0.2}}, FEATURES)
    assert d.drift.per_gap == 0.3 and d.drift.spread == 0.2 and d.drift.tolerance == 0.02
    assert read_faults({}, FEATURES).drift.per_gap is None
    with pytest.raises(FieldError, match="faults.drift.slope"):
        read_faults({"drift": {"slope": 0.3}}, FEATURES)
    with pytest.raises(FieldError, match="faults.drift.per_gap"):
        read_faults({"drift": {"per_gap": 0}}, FEATURES)
    with pytest.raises(FieldError, match="faults.drift.spread"):
        read_faults({"drift": {"spread": "wide"}}, FEATURES)
