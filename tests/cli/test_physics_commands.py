"""``--world physics`` on the command line."""

from __future__ import annotations

import json
import sys

import pytest

mujoco = pytest.importorskip("mujoco")

from mirl.cli import main  # noqa: E402
from mirl.observations.poses import read_pose_csv  # noqa: E402


def test_simulate_physics_writes_true_and_observed_pose_tracks(tmp_path, capsys):
    out = tmp_path / "poses.csv"
    obs = tmp_path / "obs.csv"
    code = main(["simulate", "--scenario", "boyd2", "--world", "physics", "--steps", "40",
                 "--random-starts", "--poses", str(out), "--observations", str(obs)])  # fmt: skip
    assert code == 0
    text = capsys.readouterr().out
    assert "J:left_wheel=0.6" in text and "real-time factor" in text
    observed, truth = read_pose_csv(out), read_pose_csv(tmp_path / "poses.true.csv")
    assert set(truth.robot_names) == {"I", "J", "L"}
    assert len(truth) == 3 * 39 * 20  # every robot at 10 Hz over 39 steps of 2 s
    assert len(observed) == sum(1 for _ in open(obs)) - 1  # one measurement per grid observation


def test_simulate_in_physics_refuses_misread_headings(capsys):
    """Its camera measures headings with its own noise: --heading-noise would be ignored."""
    code = main(["simulate", "--scenario", "boyd2", "--world", "physics", "--steps", "3",
                 "--heading-noise", "0.1"])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--heading-noise applies to the grid world" in err[0]


def test_run_physics_json_and_plot(tmp_path, capsys):
    png = tmp_path / "run.png"
    code = main(["run", "--world", "physics", "--scenario", "boyd2", "--obs-steps", "40",
                 "--max-wait", "15", "--method", "random", "--json",
                 "--plot", str(png)])  # fmt: skip
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["world"] == "physics" and out["outcome"] in ("success", "detected", "timeout")
    assert out["mujoco"] == mujoco.__version__  # physics results depend on MuJoCo's release
    assert "contacts" in out and png.stat().st_size > 10_000


def test_run_report_names_the_motor_strengths_physics_drives_with(capsys):
    # the scenario's grid probability (J:left_wheel=0.7) is not what the physics world runs
    code = main(["run", "--world", "physics", "--scenario", "boyd2", "--obs-steps", "20",
                 "--max-wait", "5", "--method", "random",
                 "--damage", "I:right_wheel=0.8"])  # fmt: skip
    assert code == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "physics, motor strength: J:left_wheel=0.6, I:right_wheel=0.8" in header
    assert "0.7" not in header


def test_damage_in_physics_is_motor_strength(capsys):
    code = main(["simulate", "--scenario", "boyd2-healthy", "--world", "physics", "--steps", "3",
                 "--damage", "I:right_wheel=0.5"])  # fmt: skip
    assert code == 0 and "I:right_wheel=0.5" in capsys.readouterr().out
    code = main(["simulate", "--scenario", "boyd2", "--world", "physics", "--steps", "3",
                 "--damage", "J:floor=0.5"])  # fmt: skip
    assert code == 2 and "motor's strength" in capsys.readouterr().err


def test_missing_mujoco_names_the_extra(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco -> ImportError
    code = main(["simulate", "--scenario", "boyd2", "--world", "physics", "--steps", "3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and 'pip install "mirl[physics]"' in err[0]


def test_a_broken_mujoco_release_is_refused_with_the_reason(monkeypatch, capsys):
    import types

    monkeypatch.setitem(sys.modules, "mujoco", types.SimpleNamespace(__version__="4.0.0"))
    code = main(["simulate", "--scenario", "boyd2", "--world", "physics", "--steps", "3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "MuJoCo 4.0.0" in err[0] and "!=4.0.0" in err[0]


def test_experiment_in_physics_world():
    from mirl.experiments.conditions import Condition, get_experiment, in_world

    exp = in_world(get_experiment("table1"), "physics")
    assert {c.world for c in exp.conditions} == {"physics"}
    assert "physics world" in exp.description
    grid = Condition("mirl-t")
    assert "world" not in grid.key  # grid keys unchanged: old result stores still resume
    assert Condition.from_key(exp.conditions[0].key).world == "physics"


def test_a_physics_run_records_the_mujoco_it_ran_on():
    from mirl.experiments.conditions import Condition, code_version
    from mirl.experiments.sweep import run_version

    assert run_version(Condition("mirl-t")) == code_version()  # grid rows: as before
    physics = run_version(Condition("mirl-t", world="physics"))
    assert physics == f"{code_version()}+mujoco.{mujoco.__version__}"


def test_physics_run_reports_each_robots_drift(capsys):
    """Poses carry which way a robot veers: the physical world's run records and reports it
    (full view, so both patrollers are seen driving)."""
    code = main(["run", "--world", "physics", "--scenario", "boyd2", "--obs-steps", "60",
                 "--max-wait", "5", "--observability", "1", "--json"])  # fmt: skip
    assert code == 0
    drifts = json.loads(capsys.readouterr().out)["lateral_drifts"]
    assert set(drifts) == {"I", "J"}
    assert all(abs(d["mean"]) < 0.5 and d["se"] >= 0 and d["steps"] >= 5 for d in drifts.values())
    code = main(["run", "--world", "physics", "--scenario", "boyd2", "--obs-steps", "60",
                 "--max-wait", "5", "--observability", "1"])  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    assert "drift of I:" in out and "drift of J:" in out and "forward steps" in out
