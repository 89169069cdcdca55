"""The ``[physics]`` table: every field checked where it is read, damage as a motor's strength,
and ξ as this world's motion has it."""

from __future__ import annotations

import pytest

from mirl.physics.config import (
    SECTION,
    PhysicsConfig,
    physical_feature_map,
    physics_config,
    scenario_physics,
    with_motor_strength,
)
from mirl.world.domain import DEFAULT_FEATURE_MAP
from mirl.world.scenario import load_scenario


def test_an_empty_table_is_the_documented_defaults():
    cfg = physics_config(None)
    assert cfg == PhysicsConfig()
    assert cfg.ticks_per_step == 20  # 2 s at 10 Hz
    assert cfg.substeps == 10  # 0.1 s ticks of 0.01 s steps
    assert cfg.strength("I", "left_wheel") == 1.0


@pytest.mark.parametrize(
    "table, problem",
    [
        ({"max_speed": "fast"}, "physics.max_speed: expected a non-negative number"),
        ({"max_speed": True}, "physics.max_speed: expected a non-negative number"),
        ({"max_speed": -1.0}, "physics.max_speed: expected a non-negative number"),
        ({"control_hz": 0}, "physics.control_hz: must be positive"),
        ({"camera_pose": [1, 2]}, r"physics.camera_pose: expected \[x, y, yaw_deg\]"),
        ({"motor_strength": 0.5}, "physics.motor_strength: expected a table of robots"),
        ({"motor_strength": {"Q": {"left_wheel": 0.5}}}, "motor_strength.Q: unknown robot"),
        ({"motor_strength": {"I": 0.5}}, "motor_strength.I: expected a table"),
        ({"motor_strength": {"I": {"floor": 0.5}}}, "motor_strength.I.floor: expected"),
        ({"timestep": 0.2}, "physics.timestep: 0.2 s is longer than a control tick"),
        ({"step_seconds": 0.01}, "physics.step_seconds: 0.01 s is shorter than a control tick"),
    ],
)
def test_a_bad_field_is_one_line_naming_the_file_and_the_field(table, problem):
    with pytest.raises(ValueError, match=problem) as exc:
        physics_config(table, "floor.toml", ("I", "J"))
    assert str(exc.value).startswith("floor.toml: ") and "\n" not in str(exc.value)


def test_numbers_are_kept_as_floats_and_the_camera_pose_as_a_tuple():
    cfg = physics_config({"max_speed": 1, "camera_pose": [1, 2, 90]}, "x.toml")
    assert cfg.max_speed == 1.0 and isinstance(cfg.max_speed, float)
    assert cfg.camera_pose == (1.0, 2.0, 90.0)
    assert physics_config({"camera_range": 3}).camera_range == 3.0


def test_damage_is_a_wheel_motors_strength_written_into_the_scenarios_table():
    sc = load_scenario("boyd2-healthy")
    hurt = with_motor_strength(sc, "J", "right_wheel", 0.6)
    assert hurt.section(SECTION)["motor_strength"] == {"J": {"right_wheel": 0.6}}
    cfg = scenario_physics(hurt)
    assert cfg.strength("J", "right_wheel") == 0.6 and cfg.strength("J", "left_wheel") == 1.0
    assert scenario_physics(sc).motor_strength == {}  # the original is untouched
    again = with_motor_strength(hurt, "I", "left_wheel", 0.5)
    assert scenario_physics(again).motor_strength == {
        "J": {"right_wheel": 0.6},
        "I": {"left_wheel": 0.5},
    }
    with pytest.raises(ValueError, match="unknown robot 'Q'"):
        with_motor_strength(sc, "Q", "left_wheel", 0.5)
    with pytest.raises(ValueError, match=r"must be in \[0, 1\]"):
        with_motor_strength(sc, "I", "left_wheel", 1.5)


def test_the_turns_need_no_wheel_here_and_everything_else_is_kept():
    xi = physical_feature_map(DEFAULT_FEATURE_MAP)
    assert xi.features == DEFAULT_FEATURE_MAP.features
    assert xi.action_subsets["turn_left"] == ("navigation", "floor")
    assert xi.action_subsets["turn_right"] == ("navigation", "floor")
    assert xi.action_subsets["forward"] == DEFAULT_FEATURE_MAP.action_subsets["forward"]
    assert xi.action_subsets["stop"] == ("floor",)
