"""Conditions with a damaged part, and the verdicts experiment (mirl.experiments.conditions)."""

from __future__ import annotations

import pytest

from mirl.experiments.conditions import Condition, StoreError, get_experiment, in_world
from mirl.worlds import WORLDS


def test_damage_is_part_of_the_key_only_when_set():
    plain = Condition("mirl-t", "boyd2-healthy", 1.0)
    assert "damage" not in plain.key
    hurt = Condition("mirl-t", "boyd2-healthy", 1.0, damage="J:right_wheel")
    assert Condition.from_key(hurt.key) == hurt
    assert "J:right_wheel damaged" in hurt.label


def test_a_grid_condition_damages_the_feature_probability():
    c = Condition("mirl-t", "boyd2-healthy", 1.0, damage="I:right_wheel")
    scenario = c.scenario_object()
    assert (
        scenario.robots[0].feature_probabilities["right_wheel"] == WORLDS["grid"].experiment_damage
    )
    parts = WORLDS["grid"].load().damaged_parts(scenario)
    assert parts == {"I": ("right_wheel",), "J": ()}


def test_a_physics_condition_weakens_the_motor():
    pytest.importorskip("mujoco")
    c = Condition("mirl-t", "boyd2-healthy", 1.0, world="physics", damage="J:left_wheel")
    parts = WORLDS["physics"].load().damaged_parts(c.scenario_object())
    assert parts == {"I": (), "J": ("left_wheel",)}
    # the grid's probabilities are untouched: in physics the damage is the motor's
    assert c.scenario_object().robots[1].feature_probabilities["left_wheel"] == 0.95


def test_the_verdicts_experiment_spans_both_worlds_and_every_wheel():
    exp = get_experiment("verdicts")
    assert {c.world for c in exp.conditions} == set(WORLDS)
    assert {c.observability for c in exp.conditions} == {0.14, 1.0}
    damages = {c.damage for c in exp.conditions}
    assert damages == {None, "I:left_wheel", "I:right_wheel", "J:left_wheel", "J:right_wheel"}
    assert len(exp.conditions) * exp.default_runs >= 200
    with pytest.raises(StoreError, match="every world already"):
        in_world(exp, "physics")


def test_the_experiments_are_a_table_whose_rows_are_checked():
    from dataclasses import replace

    from mirl._registry import Registry
    from mirl.experiments.conditions import EXPERIMENTS, _check_experiment

    assert EXPERIMENTS.names[:4] == ("fig3", "fig4a", "fig4b", "fig4c")
    fig3 = EXPERIMENTS["fig3"]
    for change, message in (
        ({"default_runs": 0}, "default_runs must be at least 1"),
        ({"conditions": fig3.conditions[:2] * 2}, "each once"),
        ({"conditions": (Condition("mirl_t"),)}, "did you mean 'mirl-t'"),
        ({"conditions": (Condition("mirl-t", world="mujoco"),)}, "unknown world 'mujoco'"),
    ):
        with pytest.raises(ValueError, match=message):
            Registry("experiment", [replace(fig3, **change)], check=_check_experiment)


def test_an_unknown_experiment_names_the_nearest_listed_ones():
    with pytest.raises(StoreError, match=r"^unknown experiment 'tabel1' \(did you mean 'table1'"):
        get_experiment("tabel1")
    with pytest.raises(StoreError) as e:
        get_experiment("zzz")
    assert "selftest" not in str(e.value)  # hidden: runs when named, never offered
    assert get_experiment("selftest").hidden


def test_a_robot_never_seen_moving_is_stored_as_no_verdict():
    from types import SimpleNamespace

    from mirl.experiments.conditions import _verdict_metrics
    from mirl.learning.verdicts import Verdict

    seen = Verdict("left_wheel", 0.97)
    unseen = Verdict(None, 0.49, seen_moving=False)
    learned = SimpleNamespace(robots=[
        SimpleNamespace(name="I", verdict=unseen, feature_intervals={}),
        SimpleNamespace(name="J", verdict=seen, feature_intervals={}),
    ])  # fmt: skip
    out = _verdict_metrics(learned, {"I": (), "J": ("left_wheel",)})
    assert out["unseen.I"] == 1 and "unseen.J" not in out
    assert out["right.J"] == 1 and out["confidence.I"] == 0.49
