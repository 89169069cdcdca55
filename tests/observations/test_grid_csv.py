"""The vectorised grid CSV reader agrees with the row-by-row reference: same trajectories, and
for bad files the same one-line message (file, line, problem)."""

from __future__ import annotations

import numpy as np
import pytest

import mirl.observations.trajectories as observations
from mirl.observations.trajectories import TrajectoryError, read_csv
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario

NAMES = ("I", "J")
GOOD = "t,robot,row,col,heading\n0,I,0,8,2\n0,J,16,8,2\n"


@pytest.fixture(scope="module")
def domain():
    return load_scenario("boyd2").domain


def outcome(fn, path, domain, horizon=None):
    try:
        tr = fn(path, domain, NAMES, horizon)
    except TrajectoryError as exc:
        return str(exc)
    return [a.tolist() for a in (tr.t, tr.robot, tr.row, tr.col, tr.heading)] + [tr.horizon]


@pytest.mark.parametrize(
    "text",
    [
        GOOD + "1,K,0,7,2\n",
        GOOD + "\n\n1,I,3,4,2\n",  # blank lines before the bad row: the line still counts them
        GOOD + "1,I,0,7,4\n",
        GOOD + "1,I,40,-1,2\n",
        GOOD + "-1,I,0,7,2\n",
        GOOD + "1,I,0,7,2\n\n0,J,16,7,2\n",
        GOOD + "1,I,0,7,2\n1,I,0,6,2\n",
        GOOD + "1,I,0,7,2\n2,K,3,4,9\n",  # several problems in one row: robot first
        GOOD + "1,I,zero,7,2\n",
        GOOD + "1, I ,0,7,2\n",
        GOOD + "1,I,0,7,2,extra\n",
        GOOD + ",,,,\n1,I,0,7,2\n",
        "robot, t ,heading,row,col\nJ,3,1,16,1\r\nI,0,2,0,4\r\n",
        "t,robot,row,col,heading\n",
        "t,robot,row,heading\n0,I,0,2\n",
        "",
    ],
)
def test_fast_reader_matches_reference(tmp_path, domain, text):
    path = tmp_path / "x.csv"
    path.write_text(text)
    assert outcome(read_csv, path, domain) == outcome(observations._read_csv_python, path, domain)


def test_clean_files_take_the_vectorised_path(tmp_path, domain, monkeypatch):
    res = simulate(load_scenario("boyd2"), 500, seed=1, observability=1.0)
    path = tmp_path / "obs.csv"
    res.observations.to_csv(path)
    reference = outcome(observations._read_csv_python, path, domain, 500)

    def refuse(*args, **kwargs):
        raise AssertionError("fell back to the row-by-row reader")

    monkeypatch.setattr(observations, "_read_csv_python", refuse)
    assert outcome(read_csv, path, domain, 500) == reference
    tr = read_csv(path, domain, NAMES)
    assert tr.t.dtype == np.int64 and len(tr) == len(res.observations)
    path.write_text(GOOD + "1,I,0,7,2\n1,I,0,6,2\n")
    with pytest.raises(TrajectoryError, match="line 5: duplicate row for robot I at t=1"):
        read_csv(path, domain, NAMES)
