"""The robot-data round trip over five seeds (slow): simulate -> MCAP poses -> learn --json equals
the grid CSV path, and 5 cm / 3 degree pose noise moves no feature probability by 0.02."""

from __future__ import annotations

import json

import pytest

from mirl.cli import main

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("seed", range(5))
def test_round_trip_five_seeds(tmp_path, capsys, seed):
    sim = ["simulate", "--scenario", "boyd2", "--steps", "300", "--seed", str(seed)]
    assert main([*sim, "--observations", str(tmp_path / "o.csv")]) == 0
    assert main([*sim, "--poses", str(tmp_path / "p.mcap")]) == 0
    assert main([*sim, "--poses", str(tmp_path / "n.mcap"), "--pose-noise", "0.05", "3"]) == 0
    capsys.readouterr()
    # the poses are a simulation of the scenario, so they are scored against its truth too
    topics = ["--topic", "/I/pose=I", "--topic", "/J/pose=J", "--start-time", "0"]
    topics += ["--compare", "truth"]
    results = []
    for obs, extra in (("o.csv", []), ("p.mcap", topics), ("n.mcap", topics)):
        argv = ["learn", "--scenario", "boyd2", "--json", "--observations", str(tmp_path / obs)]
        assert main([*argv, *extra]) == 0
        res = json.loads(capsys.readouterr().out)
        res.pop("observations"), res.pop("timings")
        results.append(res)
    grid, clean, noisy = results
    assert clean == grid
    for robot, r in grid["robots"].items():
        for f, p in r["feature_probabilities"].items():
            assert abs(noisy["robots"][robot]["feature_probabilities"][f] - p) <= 0.02
