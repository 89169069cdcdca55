"""The command line's checks of what argparse cannot see: output files refused before any work,
two flags naming one file, pose flags within their limits, observations that say nothing, and
the counts behind a learned probability."""

from __future__ import annotations

import argparse
import os

import numpy as np
import pytest

from mirl.cli import checks
from mirl.cli.checks import (
    DEFAULT_POSE_RATE,
    MAX_POSES,
    MAX_POSES_PER_STEP,
    UsageError,
    check_distinct,
    check_experiment_flags,
    check_observations,
    check_output,
    check_pose_flags,
    check_poses_output,
    check_visible,
    feature_trials,
    unique_lowest,
    warn,
)
from mirl.learning.transitions import SubsetCounts
from mirl.observations.trajectories import Trajectories
from mirl.world.actions import STEP_SECONDS
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def domain():
    return load_scenario("boyd2").domain


def test_an_output_that_can_be_written_is_returned_as_a_path(tmp_path):
    assert check_output(str(tmp_path / "run.png"), "--plot", (".png",)) == tmp_path / "run.png"
    assert check_output(tmp_path / "any.name", "--out") == tmp_path / "any.name"


@pytest.mark.parametrize(
    "name, needle",
    [
        ("run.jpg", "--plot {p}: expected a file ending in .png, .pdf, .svg"),
        ("sub", "--plot {p}: is a directory"),
        ("missing/run.png", "--plot {p}: directory {parent} does not exist"),
    ],
)
def test_an_output_that_cannot_be_written_is_refused_naming_the_flag(tmp_path, name, needle):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub.png").mkdir()
    path = tmp_path / (name if name != "sub" else "sub.png")
    expected = needle.format(p=path, parent=path.parent)
    with pytest.raises(UsageError, match="^" + expected.replace(".", r"\.") + "$"):
        check_output(path, "--plot", checks.FIGURE_SUFFIXES)


@pytest.mark.parametrize("name", ["t.json", "o.MCAP", "o.yaml", "o.parquet"])
def test_a_csv_output_named_as_another_format_is_refused(tmp_path, capsys, name):
    """`--truth t.json` wrote CSV into t.json; every reader would take the name at its word."""
    from mirl.cli import main

    assert checks.check_csv_output(tmp_path / "o.txt", "--truth") == tmp_path / "o.txt"
    path = tmp_path / name
    argv = ["simulate", "--scenario", "boyd2", "--steps", "3", "--truth", str(path)]
    assert main(argv) == 2 and not path.exists()
    err = capsys.readouterr().err.strip()
    assert err == f"mirl simulate: error: --truth {path}: mirl writes it as CSV, which a " \
        f"{path.suffix} name would misname (name it .csv)", err


def test_an_output_in_a_directory_that_cannot_be_written_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "access", lambda path, mode: False)  # as for a user without rights
    with pytest.raises(UsageError, match="not writable"):
        check_output(tmp_path / "run.png", "--plot")


def test_two_flags_naming_one_file_are_refused(tmp_path):
    target = tmp_path / "o.csv"
    target.write_text("")
    (tmp_path / "link.csv").symlink_to(target)
    check_distinct(("--observations", str(target)), ("--truth", None), ("--poses", ""))
    with pytest.raises(UsageError) as info:
        check_distinct(("--observations", str(target)), ("--truth", str(tmp_path / "link.csv")))
    assert str(info.value) == (
        f"--truth {tmp_path / 'link.csv'}: the same file as --observations {target}; one would "
        "overwrite the other"
    )


def pose_args(**kw):
    values = dict(
        poses=None, pose_rate=None, pose_noise=None, step_seconds=None, steps=450, world="grid"
    )
    return argparse.Namespace(**{**values, **kw})


def test_pose_flags_get_their_defaults_with_poses():
    args = pose_args(poses="p.csv")
    check_pose_flags(args)
    assert (args.pose_rate, args.step_seconds) == (DEFAULT_POSE_RATE, STEP_SECONDS)


@pytest.mark.parametrize(
    "kw, needle",
    [
        ({"pose_rate": 5.0}, "--pose-rate shapes the poses --poses writes"),
        ({"poses": "p.csv", "world": "physics", "step_seconds": 1.0},
         "--step-seconds: the physics"),
        ({"poses": "p.csv", "pose_rate": MAX_POSES_PER_STEP + 1.0, "step_seconds": 1.0},
         f"poses per step; at most {MAX_POSES_PER_STEP}"),
        ({"poses": "p.csv", "pose_rate": 500.0, "steps": MAX_POSES // 999},
         "poses per robot; at most"),
        ({"poses": "p.csv", "pose_noise": (0.0, 361.0)}, "SIGMA_DEG must be at most 360 deg"),
        ({"poses": "p.csv", "pose_noise": (101.0, 0.0)}, "SIGMA_M must be at most 100 m"),
    ],
)  # fmt: skip
def test_pose_flags_beyond_their_limits_are_refused(kw, needle):
    with pytest.raises(UsageError, match=needle.replace("(", r"\(")):
        check_pose_flags(pose_args(**kw))


def test_a_pose_output_is_a_file_or_bag_the_world_writes(tmp_path):
    check_poses_output(None, "grid")
    check_poses_output(str(tmp_path / "poses.csv"), "physics")
    check_poses_output(str(tmp_path / "bag"), "grid")  # a ROS 2 bag directory to create
    with pytest.raises(UsageError, match="or a bag directory"):
        check_poses_output(str(tmp_path / "poses.bag"), "grid")
    with pytest.raises(UsageError, match=r"expected a \.csv or \.mcap file$"):
        check_poses_output(str(tmp_path / "bag"), "physics")  # its tracks are files only
    (tmp_path / "old.mcap").write_bytes(b"")
    with pytest.raises(UsageError, match="not overwriting an MCAP file"):
        check_poses_output(str(tmp_path / "old.mcap"), "grid")
    (tmp_path / "taken").mkdir()  # the message says why: it exists, not that it cannot be
    with pytest.raises(UsageError, match="taken: exists already, not overwriting a bag direc"):
        check_poses_output(str(tmp_path / "taken"), "grid")
    with pytest.raises(UsageError, match="cannot create a bag directory there"):
        check_poses_output(str(tmp_path / "nowhere" / "bag"), "grid")
    for world in ("grid", "physics"):  # mirl would refuse to read it back
        with pytest.raises(UsageError, match=r"lower-case suffix .*; name it poses\.mcap$"):
            check_poses_output(str(tmp_path / "poses.MCAP"), world)
    assert not (tmp_path / "poses.MCAP").exists()


def test_an_experiment_directory_is_a_directory(tmp_path):
    check_experiment_flags(argparse.Namespace(out=None))
    check_experiment_flags(argparse.Namespace(out=str(tmp_path)))
    (tmp_path / "file").write_text("")
    with pytest.raises(UsageError, match="is a file, not a directory"):
        check_experiment_flags(argparse.Namespace(out=str(tmp_path / "file")))
    with pytest.raises(UsageError, match="an empty path"):
        check_experiment_flags(argparse.Namespace(out="  "))


def observations(rows):
    t, robot, row, col, heading = (np.array(c, dtype=int) for c in zip(*rows, strict=True))
    return Trajectories(("I", "J"), t, robot, row, col, heading, horizon=int(t.max()) + 1)


def test_observations_without_rows_are_refused(domain):
    empty = Trajectories(("I", "J"), *(np.zeros(0, int) for _ in range(5)), horizon=10)
    with pytest.raises(UsageError, match="obs.csv: no observations"):
        check_observations("obs.csv", empty, domain)


def test_an_observed_step_no_action_explains_is_warned_about(domain, capsys):
    r, c, h = (int(x) for x in domain.states[0])
    far = next(s for s in domain.states if abs(int(s[0]) - r) + abs(int(s[1]) - c) > 2)
    check_observations("obs.csv", observations([(0, 0, r, c, h), (1, 0, *far)]), domain)
    err = capsys.readouterr().err
    assert err.startswith("mirl: warning: obs.csv: 1 of robot I's 1 observed steps are ")
    assert f"(first: t=0 {(r, c, h)} -> {tuple(int(x) for x in far)})" in err
    check_observations("obs.csv", observations([(0, 0, r, c, h), (1, 0, r, c, h)]), domain)
    assert capsys.readouterr().err == ""  # staying put is an action


def test_rows_outside_the_view_are_warned_about_once_and_none_visible_refused(domain, capsys):
    visible = np.zeros(domain.n_states, dtype=bool)
    r, c, h = (int(x) for x in domain.states[0])
    obs = observations([(0, 0, r, c, h), (1, 1, r, c, h)])
    with pytest.raises(UsageError, match=r"--observability 0: L sees no cell, yet o.csv has 2"):
        check_visible("o.csv", obs, domain, visible, 0.0)
    visible[:] = True
    visible[obs.states(domain)] = False  # every state but the rows'
    check_visible("o.csv", obs, domain, visible, 0.5)
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "2 of 2 observed rows lie on cells L cannot see at observability 0.5" in err
    visible[:] = True
    full = observations([(t, i, r, c, h) for t in (0, 1) for i in (0, 1)])
    check_visible("o.csv", full, domain, visible, 1.0)
    assert capsys.readouterr().err == ""


def test_robots_missing_from_a_record_that_claims_full_view_are_warned_about(domain, capsys):
    """At full view a robot missing from a step was out of a view that has no outside: a grid
    CSV recorded at L's door, learned with `--observability 1`, was taken without a word."""
    r, c, h = (int(x) for x in domain.states[0])
    obs = observations([(0, 0, r, c, h), (1, 1, r, c, h)])  # I missing at 1, J at 0
    check_visible("o.csv", obs, domain, np.ones(domain.n_states, dtype=bool), 1.0)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "L sees every cell at observability 1, yet the robots are " \
        "missing from 2 of 4 robot-steps (first: I at t=1)" in err, err


def test_warnings_are_one_line_on_stderr(capsys):
    warn("obs.csv: something")
    out = capsys.readouterr()
    assert out.out == "" and out.err == "mirl: warning: obs.csv: something\n"


def test_a_features_trials_are_those_of_every_subset_it_is_in():
    counts = SubsetCounts(
        subsets=(("left_wheel", "floor"), ("right_wheel", "floor"), ("floor",)),
        successes=np.array([1, 2, 3]),
        trials=np.array([4, 5, 6]),
    )
    assert feature_trials(counts) == {"left_wheel": 4, "floor": 15, "right_wheel": 5}


def test_the_unique_lowest_probability_names_a_part_and_a_tie_names_none():
    assert unique_lowest({"left_wheel": 0.6, "right_wheel": 0.9}) == "left_wheel"
    assert unique_lowest({"left_wheel": 0.6, "right_wheel": 0.6 + 1e-9}) is None
    assert unique_lowest({"left_wheel": 0.6, "right_wheel": 0.61}, tol=0.02) is None
    assert unique_lowest({"floor": 0.9}) == "floor"
    assert unique_lowest({}) is None
