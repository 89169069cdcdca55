"""Scenarios as TOML data: the shipped ones carry the paper's values; every problem in a scenario
file is a ScenarioError naming the file and the field."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from mirl.world.domain import DEFAULT_FEATURE_MAP
from mirl.world.game import InteractionGame
from mirl.world.scenario import (
    HEALTHY_PROBABILITIES,
    Scenario,
    ScenarioError,
    load_scenario,
    shipped_scenarios,
)

HEALTHY = {"left_wheel": 0.95, "right_wheel": 0.95, "navigation": 0.97, "floor": 0.99}
DAMAGED_J = {**HEALTHY, "left_wheel": 0.70}
SPEC_A = [[-10, 2, 2], [0, 0, 0], [-1, -1, -1]]
SPEC_B = [[-10, 0, -1], [2, 0, -1], [2, 0, -1]]


def test_shipped_list():
    assert {"boyd2", "boyd2-healthy", "boydright"} <= set(shipped_scenarios())


@pytest.mark.parametrize(
    "name, j_probs", [("boyd2", DAMAGED_J), ("boyd2-healthy", HEALTHY)], ids=["damaged", "healthy"]
)
def test_boyd2_scenarios(name, j_probs):
    sc = load_scenario(name)
    assert sc.name == name
    assert sc.map.shape == (17, 9) and sc.map.n_patroller_cells == 31
    assert sc.robot_names == ("I", "J")
    assert dict(sc.robots[0].feature_probabilities) == HEALTHY
    assert dict(sc.robots[1].feature_probabilities) == j_probs
    assert sc.observer_start == (0, 0) and sc.goal == (9, 1)
    assert sc.observability == 0.14 and sc.detect_distance == 6
    assert sc.discount == 0.95 and sc.error_model == "uniform"
    assert sc.played == ("stop", "go")
    np.testing.assert_array_equal(sc.game.row_payoffs, SPEC_A)
    np.testing.assert_array_equal(sc.game.col_payoffs, SPEC_B)
    assert sc.played_equilibrium.label() == "stop/go"
    assert sc.feature_map == DEFAULT_FEATURE_MAP
    assert sc.reward_spec.names == ("moved", "upper_hallway", "lower_hallway", "turn_around")
    assert set(sc.reward_spec.feature("turn_around").cells) == {(0, 8), (16, 8)}
    assert set(sc.reward_spec.feature("upper_hallway").cells) == {(0, c) for c in range(2, 9)}
    assert set(sc.reward_spec.feature("lower_hallway").cells) == {(16, c) for c in range(2, 9)}
    # I and J start at opposite ends, heading west
    assert sc.robots[0].start == (0, 8, 2) and sc.robots[1].start == (16, 8, 2)
    for r in sc.robots:
        assert r.weights.shape == (4,) and r.weights[0] > 0


def test_boydright_scenario():
    sc = load_scenario("boydright")
    assert sc.map.shape == (14, 18) and sc.map.n_patroller_cells == 46
    assert sc.observer_start == (0, 17) and sc.goal == (13, 13)
    assert set(sc.map.goals) == {(1, 0), (13, 13)}
    assert dict(sc.robots[1].feature_probabilities) == DAMAGED_J
    assert sc.played_equilibrium.label() == "stop/go"


def test_healthy_defaults_constant():
    assert HEALTHY_PROBABILITIES == HEALTHY


def test_with_damage():
    sc = load_scenario("boyd2-healthy")
    hurt = sc.with_damage("I", "right_wheel", 0.7)
    assert hurt is not sc
    assert dict(hurt.robots[0].feature_probabilities) == {**HEALTHY, "right_wheel": 0.7}
    assert dict(hurt.robots[1].feature_probabilities) == HEALTHY
    assert dict(sc.robots[0].feature_probabilities) == HEALTHY  # original untouched
    # the new scenario's true model uses the damaged value
    T0 = sc.true_transitions(0).toarray()
    T1 = hurt.true_transitions(0).toarray()
    assert not np.allclose(T0, T1)
    np.testing.assert_allclose(sc.true_transitions(1).toarray(), hurt.true_transitions(1).toarray())
    with pytest.raises(ValueError, match="'K'"):
        sc.with_damage("K", "left_wheel", 0.5)
    with pytest.raises(ValueError, match="wheel"):
        sc.with_damage("J", "wheel", 0.5)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        sc.with_damage("J", "left_wheel", 1.5)


def test_parse_damage():
    from mirl.cli.flags import parse_damage

    assert parse_damage("J:left_wheel=0.7") == ("J", "left_wheel", 0.7)
    assert parse_damage(" I : right_wheel = 0.5") == ("I", "right_wheel", 0.5)
    for bad in ("J-left_wheel=0.7", "J:left_wheel", "J:left_wheel=abc", ""):
        with pytest.raises(ValueError, match="ROBOT:FEATURE=P"):
            parse_damage(bad)


def test_error_model_option():
    sc = load_scenario("boyd2").with_options(error_model="stop")
    assert sc.error_model == "stop"
    with pytest.raises(ScenarioError, match="error_model"):
        load_scenario("boyd2").with_options(error_model="teleport")


# --------------------------------------------------------------------------- TOML errors

GOOD = """\
name = "tiny"
map = "boyd2"

[reward]
upper_hallway = { from = [0, 2], to = [0, 8] }
turn_around = [[0, 8], [16, 8]]
weights = { moved = 1.0, turn_around = 0.3 }

[game]
played = ["stop", "go"]

[[robots]]
name = "I"
start = [0, 8, 2]
feature_probabilities = { left_wheel = 0.95 }

[[robots]]
name = "J"
start = [16, 8, 2]
feature_probabilities = { left_wheel = 0.7 }
"""


def write(tmp_path: Path, text: str, name: str = "scenario.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_good_toml_loads_with_defaults(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD))
    assert isinstance(sc, Scenario)
    assert sc.name == "tiny"
    assert dict(sc.robots[0].feature_probabilities) == HEALTHY  # unspecified → healthy
    assert dict(sc.robots[1].feature_probabilities) == DAMAGED_J
    assert sc.observer_start == (0, 0) and sc.goal == (9, 1)  # from the map
    assert sc.played_equilibrium == InteractionGame().pure("stop", "go")
    np.testing.assert_allclose(sc.robots[0].weights, [1.0, 0.05, 0.05, 0.3])


def test_a_toml_saved_with_a_bom_loads(tmp_path):
    # Windows editors write a BOM; tomllib alone calls it an invalid statement at line 1
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + textwrap.dedent(GOOD).encode())
    assert load_scenario(path).name == "tiny"


def test_a_file_s_defaults_are_the_scenario_s_fields(tmp_path):
    """A key a file leaves out takes the default the Scenario dataclass declares (one home)."""
    from dataclasses import fields

    declared = {f.name: f.default for f in fields(Scenario)}
    sc = load_scenario(write(tmp_path, GOOD.replace('played = ["stop", "go"]', "")))
    for key in ("detect_distance", "observability", "discount", "error_model", "played"):
        assert getattr(sc, key) == declared[key], key
    assert sc.played == ("stop", "go")  # the paper's


def test_map_path_relative_to_scenario(tmp_path):
    (tmp_path / "maps").mkdir()
    text = (Path(__file__).parents[2] / "src/mirl/data/maps/boyd2.txt").read_text()
    (tmp_path / "maps" / "mine.txt").write_text(text)
    sc = load_scenario(write(tmp_path, GOOD.replace('map = "boyd2"', 'map = "maps/mine.txt"')))
    assert sc.map.n_patroller_cells == 31


def test_a_goal_l_cannot_reach_is_refused(tmp_path):
    """boyd2 with its long hallway walled off at row 5: L's goal (9, 1) lies beyond the wall."""
    (tmp_path / "maps").mkdir()
    rows = (Path(__file__).parents[2] / "src/mirl/data/maps/boyd2.txt").read_text().splitlines()
    rows[5] = "#" * len(rows[5])
    (tmp_path / "maps" / "cut.txt").write_text("\n".join(rows) + "\n")
    text = GOOD.replace('map = "boyd2"', 'map = "maps/cut.txt"')
    with pytest.raises(ScenarioError, match=r"observer\.goal.*cannot be reached from L's start"):
        load_scenario(write(tmp_path, text))
    # the same goal on the side of the wall L starts on loads
    sc = load_scenario(write(tmp_path, text + "\n[observer]\ngoal = [3, 1]\n"))
    assert sc.goal == (3, 1)


def test_unnamed_patrollers_are_named_around_the_observer(tmp_path):
    """Four unnamed robots are I, J, K and M: L is the observer's name, which no patroller
    takes (a robot named L is refused)."""
    blocks = "".join(
        f"[[robots]]\nstart = [{r}, {c}, {h}]\n"
        for r, c, h in ((0, 8, 2), (16, 8, 2), (3, 1, 3), (12, 1, 1))
    )
    sc = load_scenario(write(tmp_path, GOOD.split("[[robots]]")[0] + blocks))
    assert sc.robot_names == ("I", "J", "K", "M")
    with pytest.raises(ScenarioError, match=r"robots\[1\]\.name.*observer's name"):
        load_scenario(write(tmp_path, GOOD.replace('name = "J"', 'name = "L"')))


def robots_block(n: int) -> str:
    return "\n".join(f'[[robots]]\nname = "R{i}"\nstart = [{i + 1}, 1, 3]\n' for i in range(n))


CASES = {
    "invalid_toml": (GOOD.replace('name = "tiny"', 'name = "tiny'), "invalid TOML"),
    "unknown_top_level": ('colour = "red"\n' + GOOD, "colour"),
    # typos inside tables must not be silently ignored (a misspelt key would drop the damage)
    "unknown_robot_field": (
        GOOD.replace("feature_probabilities = { left_wheel = 0.7 }", "feature_probabilites = {}"),
        "robots[1].feature_probabilites",
    ),
    "unknown_reward_field": (
        GOOD.replace("turn_around = [[", "turnaround = [["),
        "reward.turnaround",
    ),
    "unknown_game_field": (GOOD.replace("played =", "playd ="), "game.playd"),
    "unknown_observer_field": (GOOD + "\n[observer]\ngaol = [9, 1]\n", "observer.gaol"),
    "robot_not_table": ("robots = [1, 2]\n" + GOOD.split("[reward]")[0], "robots[0]"),
    "reward_not_table": (
        GOOD.split("[reward]")[0].replace('map = "boyd2"', 'map = "boyd2"\nreward = 3'),
        "reward",
    ),
    "reward_region_on_wall": (
        GOOD.replace("upper_hallway = { from = [0, 2], to = [0, 8] }", "upper_hallway = [[1, 3]]"),
        "reward.upper_hallway",
    ),
    "missing_map": (GOOD.replace('map = "boyd2"\n', ""), "map"),
    "start_on_wall": (GOOD.replace("start = [0, 8, 2]", "start = [3, 4, 0]"), "robots[0].start"),
    "start_bad_heading": (GOOD.replace("start = [0, 8, 2]", "start = [0, 8, 4]"), "start"),
    "start_not_cell": (GOOD.replace("start = [0, 8, 2]", 'start = "north"'), "robots[0].start"),
    "probability_1.5": (
        GOOD.replace("left_wheel = 0.7", "left_wheel = 1.5"),
        "robots[1].feature_probabilities.left_wheel",
    ),
    "unknown_transition_feature": (
        GOOD.replace("left_wheel = 0.7", "tyre = 0.7"),
        "robots[1].feature_probabilities.tyre",
    ),
    "unknown_reward_feature": (
        GOOD.replace("moved = 1.0", "speed = 1.0"),
        "reward.weights.speed",
    ),
    "unknown_robot_reward_feature": (
        GOOD + "weights = { loiter = 2.0 }\n",
        "robots[1].weights.loiter",
    ),
    "played_not_equilibrium": (
        GOOD.replace('played = ["stop", "go"]', 'played = ["stop", "stop"]'),
        "game.played",
    ),
    "played_unknown_action": (
        GOOD.replace('played = ["stop", "go"]', 'played = ["stop", "dance"]'),
        "game.played",
    ),
    "single_robot": (GOOD.split('[[robots]]\nname = "J"')[0], "robots"),
    "no_robots": (GOOD.split("[[robots]]")[0], "robots"),
    "duplicate_robot": (GOOD.replace('name = "J"', 'name = "I"'), "robots"),
    "observer_goal_on_wall": (GOOD + "\n[observer]\ngoal = [5, 5]\n", "observer.goal"),
    "observability": (
        GOOD.replace('map = "boyd2"', 'map = "boyd2"\nobservability = 2'),
        "observability",
    ),
    "discount": (GOOD.replace('map = "boyd2"', 'map = "boyd2"\ndiscount = 1.0'), "discount"),
    "error_model": (
        GOOD.replace('map = "boyd2"', 'map = "boyd2"\nerror_model = "teleport"'),
        "error_model",
    ),
    "missing_map_file": (GOOD.replace('map = "boyd2"', 'map = "nowhere.txt"'), "nowhere.txt"),
    "region_bad_cell": (GOOD.replace("from = [0, 2]", "from = [0]"), "reward.upper_hallway"),
    "transition_features_unknown": (
        GOOD.replace(
            'map = "boyd2"',
            'map = "boyd2"\n[transition_features]\nfeatures = ["floor"]\n'
            'actions = { forward = ["floor", "wheels"], turn_left = [], turn_right = [], '
            "stop = [] }",
        ),
        "wheels",
    ),
    "bad_payoffs": (GOOD + "\n[game]\n", "game"),
}
CASES["bad_payoffs"] = (
    GOOD.replace("[game]\n", "[game]\nrow_payoffs = [[1, 2], [3, 4]]\n"),
    "row_payoffs",
)


@pytest.mark.parametrize("case", list(CASES))
def test_toml_errors_name_file_and_field(tmp_path, case):
    text, field = CASES[case]
    path = write(tmp_path, text, f"bad-{case}.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert str(path) in msg
    assert field in msg
    assert "\n" not in msg.strip()


def test_missing_scenario_file(tmp_path):
    path = tmp_path / "absent.toml"
    with pytest.raises(ScenarioError, match="absent.toml") as info:
        load_scenario(path)
    assert "boyd2" in str(info.value)  # lists the shipped scenarios


def test_observer_start_from_the_scenario_sets_what_l_sees():
    base = load_scenario("boyd2")
    moved = base.with_options(observer_start=(0, 5))
    assert moved.map.observer_start == (0, 5) and moved.map.goals[0] == (9, 1)
    seen = set(map(tuple, np.argwhere(moved.map.visible_mask(0.14)).tolist()))
    assert seen == {(0, 6), (0, 7), (0, 8), (0, 4)}  # east of L first, then west
    assert seen != set(map(tuple, np.argwhere(base.map.visible_mask(0.14)).tolist()))
    assert moved.domain.visible_states(0.14).sum() == 4 * len(seen)


def test_observer_start_and_goal_read_from_toml(tmp_path):
    from mirl.world._resources import read_shipped_or_file

    text, _, _ = read_shipped_or_file("boyd2", "scenarios", ".toml", ScenarioError, "scenario")
    path = tmp_path / "moved.toml"
    path.write_text(text.replace("start = [0, 0]", "start = [0, 5]").replace(
        "goal = [9, 1]", "goal = [16, 2]"
    ))  # fmt: skip
    sc = load_scenario(path)
    assert (sc.observer_start, sc.goal) == ((0, 5), (16, 2))
    assert (sc.map.observer_start, sc.map.goals[0]) == ((0, 5), (16, 2))
    assert sc.map.visible_mask(0.14)[0, 6]


# ---- positions in metres and ROS maps' cell size -----------------------------------------------
TB3 = (
    Path(__file__).resolve().parents[2] / "docs" / "examples" / "turtlebot3-world.toml"
).read_text()


TB3_START = "start = { x = -2.25, y = 0.0 }   # L's hiding place, a nook off the west end\n"


def _tb3(tmp_path, old="", new="") -> Path:
    assert old in TB3
    path = tmp_path / "tb3.toml"
    path.write_text(TB3.replace(old, new) if old else TB3)
    return path


def test_ros_scenario_in_metres_at_any_cell_size(tmp_path):
    half = load_scenario(_tb3(tmp_path))
    assert half.map.frame.cell_size == 0.5 and half.map.shape == (39, 39)
    assert (half.observer_start, half.goal) == ((18, 15), (19, 24))
    assert half.robots[0].start == (17, 23, 2) and half.robots[1].start == (19, 23, 2)
    quarter = load_scenario(_tb3(tmp_path, "cell_size = 0.5", "cell_size = 0.25"))
    assert quarter.map.frame.cell_size == 0.25 and quarter.map.shape == (77, 77)
    for coarse, fine in (
        (half.observer_start, quarter.observer_start),
        (half.robots[0].start[:2], quarter.robots[0].start[:2]),
    ):  # the same point of the map frame, within a cell at either size
        xy = np.array(half.map.frame.cell_centre(*coarse))
        assert np.abs(xy - np.array(quarter.map.frame.cell_centre(*fine))).max() <= 0.25


def test_ros_scenario_rectangle_in_metres_keeps_hallway_cells(tmp_path):
    sc = load_scenario(_tb3(tmp_path))
    north = sc.reward_spec.feature("north_aisle").cells
    assert north == tuple((17, c) for c in range(16, 24))
    wide = "cells = { from = { x = -1.75, y = 0.5 }, to = { x = 1.75, y = -0.5 } }"
    sc = load_scenario(
        _tb3(
            tmp_path, "cells = { from = { x = -1.75, y = 0.5 }, to = { x = 1.75, y = 0.5 } }", wide
        )
    )
    cells = set(sc.reward_spec.feature("north_aisle").cells)
    assert cells == {c for c in cells if sc.map.patroller[c]} and (18, 16) in cells
    assert (18, 17) not in cells  # a wall inside the rectangle is skipped


@pytest.mark.parametrize(
    "old, new, field, problem",
    [
        ("start = { x = -2.25, y = 0.0 }", "start = { x = -1.25, y = 0.0 }", "observer.start",
         "not a free cell"),
        ("goal = { x = 2.25, y = -0.5 }", "goal = { x = 40.0, y = -0.5 }", "observer.goal",
         "off the map (x -10 to 9.5 m"),
        ("start = { x = 1.75, y = 0.5, yaw = 180 }", "start = { x = 1.75, y = 0.5 }",
         "robots[0].start", "missing field 'yaw'"),
        # a diagonal yaw has no nearest heading; rounding picked east without a word
        ("start = { x = 1.75, y = 0.5, yaw = 180 }", "start = { x = 1.75, y = 0.5, yaw = -135 }",
         "robots[0].start.yaw", "-135° is halfway between two headings"),
        # a yaw beyond a turn either way is a slip, not a heading (1e300 % 90 is 0)
        ("start = { x = 1.75, y = 0.5, yaw = 180 }", "start = { x = 1.75, y = 0.5, yaw = 1e300 }",
         "robots[0].start.yaw", "360"),
        ("to = { x = 1.75, y = 0.5 }", "to = { x = 1.25, y = 0.0 }",
         "reward.features[1].cells.to", "not a hallway cell"),
        ("cell_size = 0.5", "cell_size = 0.01", "frame.cell_size",
         "smaller than the map resolution"),
        ("cell_size = 0.5", "cell_size = 0.5\norigin = [0, 0]", "frame.origin", "YAML's 'origin'"),
        (TB3_START, "", "observer",
         "missing field 'start' (the map turtlebot3_world does not mark"),
    ],
)  # fmt: skip
def test_ros_scenario_errors_name_the_field(tmp_path, old, new, field, problem):
    with pytest.raises(ScenarioError) as exc:
        load_scenario(_tb3(tmp_path, old, new))
    msg = str(exc.value)
    assert f": {field}: " in msg and problem in msg and "\n" not in msg
    assert "`" not in msg  # a scenario's field, not a parameter the CLI would turn into a flag


def test_text_map_positions_in_metres_use_its_frame(tmp_path):
    from mirl.world._resources import read_shipped_or_file

    text, _, _ = read_shipped_or_file("boyd2", "scenarios", ".toml", ScenarioError, "scenario")
    metric = text.replace("start = [0, 8, 2]", "start = { x = 8.0, y = 0.2, yaw = 175 }")
    metric = metric.replace("goal = [9, 1]", "goal = { x = 1.1, y = -9.0 }")
    metric += "\n[frame]\ncell_size = 1.0\n"
    path = tmp_path / "boyd2-metres.toml"
    path.write_text(metric)
    sc, ref = load_scenario(path), load_scenario("boyd2")
    assert sc.robots[0].start == ref.robots[0].start and sc.goal == ref.goal


# ---- the worlds' own sections --------------------------------------------------------------------
def _with_section(tmp_path, section: str, top: str = "") -> Path:
    path = tmp_path / "s.toml"
    path.write_text(
        textwrap.dedent(f"""
        map = "boyd2"
        {top}
        [[robots]]
        start = [8, 1, 3]
        [[robots]]
        start = [0, 8, 0]
        {section}
    """)
    )
    return path


def test_a_worlds_section_is_kept_as_written_for_the_world_to_read(tmp_path):
    sc = load_scenario(_with_section(tmp_path, "[physics]\nmax_speed = 0.5\nnot_yet_read = 1"))
    assert sc.section("physics") == {"max_speed": 0.5, "not_yet_read": 1}
    assert load_scenario("boyd2-healthy").section("physics") == {}
    changed = sc.with_section("physics", {"max_speed": 0.4})
    assert changed.section("physics") == {"max_speed": 0.4}
    assert sc.section("physics")["max_speed"] == 0.5


def test_a_misspelt_or_malformed_world_section_is_refused_when_loaded(tmp_path):
    with pytest.raises(ScenarioError, match="s.toml: phyiscs: unknown field .known: .*physics"):
        load_scenario(_with_section(tmp_path, "[phyiscs]\nmax_speed = 0.5"))
    with pytest.raises(ScenarioError, match="s.toml: physics: expected a table"):
        load_scenario(_with_section(tmp_path, "", top="physics = 3"))
    with pytest.raises(ValueError, match="unknown world section 'phyiscs'"):
        load_scenario("boyd2").section("phyiscs")


@pytest.mark.parametrize("name", ["boyd2.txt", "turtlebot3_world.yaml"])
def test_a_map_given_as_a_scenario_is_named_as_a_map(name):
    """A map where a scenario goes failed as TOML, naming a key at line 1 and nothing else."""
    from importlib import resources

    path = resources.files("mirl.data.maps") / name
    with pytest.raises(ScenarioError, match=f"{name} looks like a map, not a scenario") as info:
        load_scenario(str(path))
    assert f'map = "{name}"' in str(info.value) and "\n" not in str(info.value)
