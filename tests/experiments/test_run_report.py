"""`mirl run`'s readable report: what its sentences claim is what the run holds."""

from __future__ import annotations

import json
import re

import pytest

from mirl.cli import main
from mirl.experiments.run_report import _equilibrium_text
from mirl.world.game import GAME_ACTIONS, Equilibrium, InteractionGame


def _named_actions(sentence: str, robot: str) -> set[str]:
    """The game actions the sentence says ``robot`` plays."""
    part = next(p for p in re.split(r"[;:] ", sentence) if p.startswith(f"{robot} "))
    return {a for a in GAME_ACTIONS if re.search(rf"\b{a}\b", part)}


@pytest.mark.parametrize(
    "eq",
    [
        *InteractionGame().equilibria(),  # the paper's game: two pure, one mixed (go or stop)
        Equilibrium((0.5, 0.0, 0.5), (0.0, 0.25, 0.75)),  # go or turn / stop or turn
        Equilibrium((1.0, 0.0, 0.0), (0.2, 0.3, 0.5)),  # a pure side against a mixed one
    ],
    ids=lambda eq: eq.label(),
)
def test_a_mixed_equilibrium_names_exactly_the_actions_each_robot_plays(eq):
    sentence = _equilibrium_text(eq, "I", "J")
    if eq.is_pure:
        assert "mixed" not in sentence and sentence.startswith("when I and J meet")
        return
    for robot, strategy in (("I", eq.row), ("J", eq.col)):
        played = {a for a, p in zip(GAME_ACTIONS, strategy, strict=True) if p > 0}
        assert _named_actions(sentence, robot) == played, sentence
        for a, p in zip(GAME_ACTIONS, strategy, strict=True):
            if 0 < p < 1:
                assert f"{a} with probability {p:.2f}" in sentence


def test_the_paper_games_mixed_equilibrium_never_says_turn():
    mixed = next(e for e in InteractionGame().equilibria() if not e.is_pure)
    assert "turn" not in _equilibrium_text(mixed, "I", "J")


def _cells(text: str, pattern: str) -> int:
    return int(re.search(pattern, text)[1])


def test_the_office_runs_header_and_show_map_count_the_same_cells(capsys):
    """`show-map office` shows the floor the office scenario runs on (not the generated map the
    bare name would also name), so the two commands count the same patroller cells."""
    assert main(["show-map", "office"]) == 0
    shown = _cells(capsys.readouterr().out, r"(\d+) patroller cells,")
    code = main(["run", "--scenario", "office", "--method", "random", "--obs-steps", "10",
                 "--max-wait", "5"])  # fmt: skip
    assert code == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert shown == _cells(header, r"\(\d+/(\d+) cells\)") == 951


def test_a_chance_stated_without_seeing_a_patroller_says_what_it_assumes(capsys):
    """Seed 0 at L's door, 300 observed steps: J never comes into view before L goes. The chance
    L states then rests on where it supposes J, which its record cannot check; the report and
    the JSON say so, and a run that saw every patroller says nothing of the kind."""
    argv = ["run", "--method", "mirl", "--seed", "0", "--obs-steps", "300"]
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    unseen = {n for n, k in out["seen_steps"].items() if k == 0}
    assert out["never_seen"] and set(out["never_seen"]) <= unseen
    assert main(argv) == 0
    text = capsys.readouterr().out
    caveat = re.search(r"\(L had never seen ([A-Z, ]+) when it went: (.*?)\)", text, re.S)
    assert caveat and caveat[1].split(", ") == out["never_seen"]
    assert "can be far off" in caveat[2]
    assert main([*argv, "--observability", "1", "--json"]) == 0
    full = json.loads(capsys.readouterr().out)
    assert full["go_time"] is not None and "never_seen" not in full


def test_sightings_l_s_models_call_impossible_are_counted_and_said(capsys):
    """With p = 0 every intended move fails under L's models, so the patrollers' moves L sees
    are impossible to its belief: the JSON counts those steps and the report says so after the
    chance, with the same count. Models that fit say nothing of the kind."""
    argv = ["run", "--method", "mirl", "--seed", "0", "--obs-steps", "300"]
    assert main([*argv, "--p", "0", "--json"]) == 0
    wrong = json.loads(capsys.readouterr().out)
    assert wrong["go_time"] is not None and wrong["filter_fallbacks"] > 0
    assert main([*argv, "--p", "0"]) == 0
    text = capsys.readouterr().out
    said = re.search(r"\(on (\d+) of its steps up to then L saw what its models give", text)
    assert said and int(said[1]) == wrong["filter_fallbacks"]
    assert main([*argv, "--observability", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["filter_fallbacks"] == 0
    assert main([*argv, "--observability", "1"]) == 0
    assert "probability ~0" not in capsys.readouterr().out


def test_a_part_no_step_tested_is_named_in_the_run_report(tmp_path, capsys):
    """A floor that matters only on the upper hallway, which J's patrol never crosses: the
    report names it untested, and "no part of J" is no surer than the prior (0.83)."""
    from importlib.resources import files

    text = (files("mirl.data.scenarios") / "boyd2-healthy.toml").read_text()
    at = text.index("[[robots]]")
    wet = (
        "[transition_features]\n"
        'features = ["left_wheel", "right_wheel", "navigation", "floor"]\n'
        'actions = { forward = ["left_wheel", "right_wheel", "navigation"], turn_left = '
        '["right_wheel", "navigation"], turn_right = ["left_wheel", "navigation"], stop = [] }\n'
        "override = [ { cells = [[0, 2], [0, 3], [0, 4], [0, 5], [0, 6], [0, 7], [0, 8]], "
        'actions = ["forward", "turn_left", "turn_right", "stop"], add = ["floor"] } ]\n\n'
    )
    path = tmp_path / "wet.toml"
    path.write_text(text[:at] + wet + text[at:])
    argv = ["run", "--scenario", str(path), "--damage", "J:floor=0.6", "--observability", "1"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "J's floor: no step L kept could test it; the interval is the prior's" in out
    (conf,) = re.findall(r"verdict: no part of J is damaged \(confidence ([0-9.]+)\)", out)
    assert float(conf) <= 0.86
    assert out.count("could test") == 1  # I crossed the patch: nothing untested


def test_an_observer_with_no_room_is_not_said_to_hide_in_one(capsys):
    """A ROS map has no rooms: L waits on a hallway cell, and the report says so."""
    from pathlib import Path

    scenario = Path(__file__).parents[1] / "data/real/tb3-gazebo-nav/slam-map.toml"
    assert main(["run", "--scenario", str(scenario), "--obs-steps", "20", "--max-wait", "5"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "L waits at (6, 2), a hallway cell (no room there; detection is scored" in out
    assert "hides in its room" not in out
    assert main(["run", "--obs-steps", "5", "--max-wait", "1"]) == 0
    assert "L hides in its room at (0, 0)" in " ".join(capsys.readouterr().out.split())
