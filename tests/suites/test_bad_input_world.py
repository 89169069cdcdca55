"""Maps and scenarios a third bad-input pass found crashing or silently accepted: each is
refused in one line naming the file and field, exit code 2, nothing printed before it."""

from __future__ import annotations

import pytest

from mirl.cli import main

ROS_KEYS = "mirl_observer_start: [0, 0]\nmirl_goals: [[1, 1]]\n"


def _refused(argv, capsys, *needles):
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and captured.out == "", captured
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def _ros_map(tmp_path, yaml_body: str, pgm: bytes = b"P5\n4 4\n255\n" + b"\xfe" * 16) -> str:
    (tmp_path / "m.pgm").write_bytes(pgm)
    (tmp_path / "m.yaml").write_text(yaml_body + ROS_KEYS)
    return str(tmp_path / "m.yaml")


GOOD_YAML = "image: m.pgm\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\n"


def test_the_good_ros_map_loads(tmp_path, capsys):
    assert main(["show-map", _ros_map(tmp_path, GOOD_YAML)]) == 0
    assert main(["show-map", _ros_map(tmp_path, GOOD_YAML), "--cell-size", "1.0"]) == 0


@pytest.mark.parametrize(
    ("body", "pgm", "needles"),
    [
        # PyYAML recursed once per level: a RecursionError traceback
        ("a: " + "[" * 100_000 + "\n", None, ("m.yaml", "nested too deeply")),
        # a header of 400 M pixels: Pillow's DecompressionBombError traceback
        (GOOD_YAML, b"P5\n20000 20000\n255\n" + b"\xfe" * 100, ("m.pgm", "64 M pixels")),
        # 81 M pixels: Pillow only warns (the warning was printed before the error line)
        (GOOD_YAML, b"P5\n9000 9000\n255\n" + b"\xfe" * 100, ("9000 x 9000", "64 M pixels")),
        (GOOD_YAML.replace("0.5", "1.0e+308"), None, ("m.yaml", "'resolution'")),
        (GOOD_YAML.replace("[0.0, 0.0", "[1.0e+300, 0.0"), None, ("m.yaml", "'origin'")),
        # a misspelt threshold left the map at the default 0.196 without a word
        (GOOD_YAML + "free_tresh: 0.5\n", None, ("m.yaml", "unknown key 'free_tresh'")),
        (GOOD_YAML + "mirl_goal: [[1, 1]]\n", None, ("m.yaml", "unknown key 'mirl_goal'")),
    ],
)
def test_ros_maps_that_cannot_be_used(tmp_path, capsys, body, pgm, needles):
    path = _ros_map(tmp_path, body, *([pgm] if pgm else []))
    with _no_warnings():
        _refused(["show-map", path], capsys, *needles)


class _no_warnings:
    """Every warning is an error inside (a warning line before the error is what users saw)."""

    def __enter__(self):
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        return self._ctx.__exit__(*exc)


def test_cell_size_on_a_text_map_is_refused_not_ignored(capsys):
    _refused(["show-map", "boyd2", "--cell-size", "0.1"], capsys, "--cell-size", "boyd2")


def test_an_empty_scenario_name_names_what_is_wrong(capsys):
    _refused(["simulate", "--scenario", "", "--steps", "3"], capsys, "empty scenario name")


def _boyd2(tmp_path, old: str, new: str) -> str:
    from mirl.world import scenario as scenario_module

    shipped = scenario_module.__file__.replace("world/scenario.py", "data/scenarios/boyd2.toml")
    toml = open(shipped, encoding="utf-8").read()
    assert old in toml
    path = tmp_path / "s.toml"
    path.write_text(toml.replace(old, new, 1))
    return str(path)


ALL = '["left_wheel", "right_wheel", "navigation", "floor"]'
FEATURES = (
    f"[transition_features]\nfeatures = {ALL}\nactions = {{{{ forward = {ALL}, "
    'turn_left = ["right_wheel", "navigation", "floor"], '
    'turn_right = ["left_wheel", "navigation", "floor"], stop = ["floor"] }}\n'
    'override = [{{ cells = [{cell}], remove = ["floor"] }}]\n'
)

NO_FEATURES = (
    "[transition_features]\nfeatures = []\n"
    "actions = { forward = [], turn_left = [], turn_right = [], stop = [] }\n"
)


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ('name = "boyd2"', 'name = ""', "name"),
        ('name = "boyd2"', 'name = "two\\nlines"', "name"),
        ("[observer]", "[frame]\ncell_size = 1e308\n[observer]", "frame"),
        ("[observer]", "[frame]\norigin = [1e308, 0.0]\n[observer]", "frame"),
        ("[observer]", FEATURES.format(cell="[5, 5]") + "[observer]", "override[0].cells[0]"),
        # --topic /J/pose=J=K read robot K, and --damage ' J:left_wheel=0.5' robot J: these
        # robots could never be named on the command line
        ('name = "J"', 'name = "J=K"', "robots[1].name"),
        ('name = "J"', 'name = " J"', "robots[1].name"),
        ('name = "J"', 'name = "J\\r"', "robots[1].name"),
        # `mirl learn` printed the unnamed feature's weight as "=7.522"
        (
            '{ name = "moved", kind = "moved" }',
            '{ name = "", kind = "moved" }',
            "reward.features[0].name",
        ),
        (
            "[observer]",
            FEATURES.format(cell="[0, 5]").replace('"floor"]\nactions', '"floor="]\nactions')
            + "[observer]",
            "transition_features.features[3]",
        ),
        # an empty region made a feature that is 0 everywhere, whose weight learned nothing
        ("cells = { from = [0, 2], to = [0, 8] }", "cells = []", "reward.features[1].cells"),
        ("cells = [[0, 8], [16, 8]]", "cells = []", "reward.features[3].cells"),
        # `mirl run` on it stopped on a ZeroDivisionError traceback
        ("[observer]", NO_FEATURES + "[observer]", "transition_features"),
        # a feature added without a weight named only robots[0].weights, a table the file does
        # not have: the weight belongs in reward.weights as well
        (
            '{ name = "moved", kind = "moved" },',
            '{ name = "moved", kind = "moved" },\n  { name = "extra", kind = "moved" },',
            "robots[0].weights: no weight for reward feature 'extra' (neither reward.weights "
            "nor robots[0].weights gives one)",
        ),
        # overrides that changed no ξ(s, a) and loaded without a word
        (
            "[observer]",
            FEATURES.format(cell="") + "[observer]",
            "override[0].cells: expected at least 1",
        ),
        (
            "[observer]",
            FEATURES.format(cell="[0, 5]").replace("cells", "actions = [], cells") + "[observer]",
            "override[0].actions: expected at least 1",
        ),
        (
            "[observer]",
            FEATURES.format(cell="[0, 5]").replace('remove = ["floor"]', "remove = []")
            + "[observer]",
            "override[0]: adds and removes no feature",
        ),
        # an override that adds a feature its actions have already (forward has the floor)
        (
            "[observer]",
            FEATURES.format(cell="[0, 5]").replace(
                'remove = ["floor"]', 'actions = ["forward"], add = ["floor"]'
            )
            + "[observer]",
            "transition_features: override 1 changes no action's features on its cells",
        ),
        # ... and a feature no action depends on, whose probability would stay at its prior
        (
            "[observer]",
            FEATURES.format(cell="[0, 5]").replace(
                'features = ["left_wheel"', 'features = ["carpet", "left_wheel"', 1
            )
            + "[observer]",
            "transition_features: transition feature 'carpet' is in no action's subset",
        ),
    ],
)
def test_scenarios_that_cannot_be_meant(tmp_path, capsys, old, new, field):
    path = _boyd2(tmp_path, old, new)
    _refused(["simulate", "--scenario", path, "--steps", "3"], capsys, "s.toml", field)


def test_an_override_on_a_hallway_cell_is_still_read(tmp_path, capsys):
    path = _boyd2(tmp_path, "[observer]", FEATURES.format(cell="[0, 5]") + "[observer]")
    assert main(["simulate", "--scenario", path, "--steps", "3"]) == 0
