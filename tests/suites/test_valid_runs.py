"""A matrix of valid runs never crashes: every method on every shipped scenario in every world,
with ``mirl run``'s default protocol (L watches past its 300 steps until it has seen every
patroller), ends in an outcome and exit code 0. One seed of the grid world runs by default;
three more seeds of the grid world and one of every other world run with ``-m slow`` (a
physics run of the office watches its full hour: about 100 s)."""

from __future__ import annotations

import json

import pytest

from mirl.cli import main
from mirl.learning.methods import METHODS
from mirl.world.scenario import shipped_scenarios
from mirl.worlds import DEFAULT_WORLD, WORLDS

OUTCOMES = {"success", "detected", "timeout"}


def _cases(worlds, seeds):
    return [
        pytest.param(m, sc, w, k, id=f"{m}-{sc}-{w}-{k}")
        for w in worlds
        for sc in shipped_scenarios()
        for m in METHODS
        for k in seeds
    ]


def _run(capsys, method: str, scenario: str, world: str, seed: int) -> None:
    argv = ["run", "--method", method, "--scenario", scenario, "--world", world]
    code = main([*argv, "--seed", str(seed), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    record = json.loads(out)
    assert record["outcome"] in OUTCOMES
    assert record["method"] == method and record["scenario"] == scenario


@pytest.mark.parametrize(("method", "scenario", "world", "seed"), _cases([DEFAULT_WORLD], [0]))
def test_a_valid_run_ends_in_an_outcome(capsys, method, scenario, world, seed):
    _run(capsys, method, scenario, world, seed)


SLOW_CASES = _cases([DEFAULT_WORLD], [1, 2, 3]) + _cases(
    [w for w in WORLDS if w != DEFAULT_WORLD], [1]
)


@pytest.mark.slow
@pytest.mark.parametrize(("method", "scenario", "world", "seed"), SLOW_CASES)
def test_valid_runs_in_every_world_end_in_an_outcome(capsys, method, scenario, world, seed):
    _run(capsys, method, scenario, world, seed)
