"""The calibration atlas (mirl.experiments.atlas): a seeded design, faults as the command line
takes them, the data paths' round trips through ``mirl simulate`` / ``mirl convert``, scoring
of ``mirl learn --json`` records, and a sweep that resumes without losing or repeating a run."""

from __future__ import annotations

import collections
import csv
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from mirl.cli import main
from mirl.experiments.atlas import (
    DAMAGED_PER_STRATUM,
    DATA_PATHS,
    FAULT_KINDS,
    LENGTHS,
    POSE_NOISE,
    SCENARIO_ROBOTS,
    STRENGTHS,
    VIEWS,
    AtlasFault,
    atlas_design,
    atlas_run,
    damage_flags,
    damaged_truth,
    fault_kind,
    format_damage,
    parse_damage,
    run_commands,
    simulation_seed,
    verdict_metrics,
)
from mirl.experiments.conditions import EXPERIMENTS, Condition
from mirl.experiments.store import load_results
from mirl.experiments.sweep import run_experiment
from mirl.world.scenario import load_scenario

QUIET = {"log": lambda msg: None}
ONE = {"progress": False, "workers": 1}  # sweep options: quiet, one worker


def _faults(point) -> tuple[AtlasFault, ...]:
    return parse_damage(point["damage"])


# ---------------------------------------------------------------------------------------------
# The design


def test_the_design_is_seeded_deterministic_and_the_experiments():
    design = atlas_design()
    assert design == atlas_design()
    assert atlas_design(seed=1) != design
    assert [Condition(**p) for p in design] == list(EXPERIMENTS["atlas"].conditions)
    assert len({Condition(**p).key for p in design}) == len(design)  # no point twice


def test_the_design_covers_every_axis_in_balance():
    design = atlas_design()
    kinds = collections.Counter((p["world"], fault_kind(_faults(p))) for p in design)
    cells = len(SCENARIO_ROBOTS) * len(VIEWS) * len(LENGTHS)
    for world in STRENGTHS:
        assert kinds[(world, "none")] == cells  # every healthy cell once
        for kind in FAULT_KINDS[1:]:
            assert kinds[(world, kind)] == DAMAGED_PER_STRATUM
    n = len(design)
    for field, values in (("scenario", SCENARIO_ROBOTS), ("observability", VIEWS),
                          ("obs_steps", LENGTHS), ("world", STRENGTHS)):  # fmt: skip
        counts = collections.Counter(p[field] for p in design)
        assert set(counts) == set(values)
        for v in values:  # a cell short of faults hands its point on, so within 20 %
            assert abs(counts[v] - n / len(values)) <= 0.2 * n / len(values), (field, counts)
    for world, strengths in STRENGTHS.items():
        values = collections.Counter(
            f.value for p in design if p["world"] == world for f in _faults(p)[:1]
        )
        assert set(values) == set(strengths)
        share = 3 * DAMAGED_PER_STRATUM / len(strengths)
        assert all(abs(c - share) <= 0.1 * share for c in values.values()), values
    for p in design:  # every fault names the scenario's robots, one value per point
        faults = _faults(p)
        assert {f.robot for f in faults} <= set(SCENARIO_ROBOTS[p["scenario"]])
        assert len({f.value for f in faults}) <= 1


def test_any_prefix_of_the_design_mixes_the_worlds():
    head = atlas_design()[:40]
    worlds = collections.Counter(p["world"] for p in head)
    assert min(worlds.values()) >= 10


def test_the_scenarios_robots_are_listed_as_the_scenarios_have_them():
    for name, robots in SCENARIO_ROBOTS.items():
        assert load_scenario(name).robot_names == robots


def test_pose_noise_is_the_physical_cameras():
    from mirl.physics.config import PhysicsConfig

    cfg = PhysicsConfig()
    assert POSE_NOISE == (cfg.measurement_sigma, cfg.measurement_sigma_deg)


# ---------------------------------------------------------------------------------------------
# Faults and the truth


def test_damage_fields_round_trip_and_name_their_kind():
    faults = (AtlasFault("I", "left_wheel", 0.6), AtlasFault("J", "right_wheel", 0.6))
    assert format_damage(faults) == "I:left_wheel=0.6,J:right_wheel=0.6"
    assert parse_damage(format_damage(faults)) == faults
    assert parse_damage("none") == () and format_damage(()) == "none"
    assert fault_kind(()) == "none"
    assert fault_kind(faults[:1]) == "one wheel"
    assert fault_kind(faults) == "two robots"
    assert fault_kind((faults[0], AtlasFault("I", "right_wheel", 0.6))) == "two wheels"
    with pytest.raises(ValueError, match="ROBOT:FEATURE=VALUE"):
        parse_damage("I:left_wheel")


def _truth(world, name, faults):
    from mirl.experiments.atlas import _with_flags

    scenario = load_scenario(name)
    flags = damage_flags(world, scenario, faults)
    return flags, damaged_truth(world, _with_flags(world, scenario, flags))


def test_a_scenarios_own_damage_is_healed_so_the_point_states_all_of_it():
    # boydright ships J's left wheel at 0.70 on the grid and every motor healthy in physics
    flags, truth = _truth("grid", "boydright", ())
    assert flags == ["J:left_wheel=0.95"]
    assert truth == {"I": (), "J": ()}
    flags, truth = _truth("physics", "boydright", ())
    assert flags == [] and truth == {"I": (), "J": ()}
    # boyd2's J motor is weak in physics: healed unless the point names it, to what a robot the
    # scenario leaves alone has there (full strength; the grid's 0.95 would leave it weakened)
    faults = (AtlasFault("I", "left_wheel", 0.6),)
    flags, truth = _truth("physics", "boyd2", faults)
    assert flags == ["J:left_wheel=1", "I:left_wheel=0.6"]
    assert truth == {"I": ("left_wheel",), "J": ()}
    faults = (AtlasFault("J", "left_wheel", 0.7), AtlasFault("J", "right_wheel", 0.7))
    flags, truth = _truth("grid", "boydright-3", faults)
    assert flags == ["J:left_wheel=0.7", "J:right_wheel=0.7"]
    assert truth == {"I": (), "J": ("left_wheel", "right_wheel"), "K": ()}


def test_the_commands_are_a_users_and_the_learner_never_sees_the_damage():
    cond = Condition("mirl-t", "boydright", 0.14, 150, world="grid", damage="J:right_wheel=0.7")
    cmds = run_commands(cond, 7, ["J:left_wheel=0.95", "J:right_wheel=0.7"], ("I", "J"))
    assert set(cmds) == {"simulate", "simulate-mcap", *(f"learn.{p}" for p in DATA_PATHS)}
    sim = " ".join(cmds["simulate"])
    assert "--damage J:left_wheel=0.95 --damage J:right_wheel=0.7" in sim
    assert "--seed 7 --observability 0.14" in sim and "--pose-noise 0.05 5" in sim
    # the MCAP's simulation is the first one, into other files
    k = cmds["simulate"].index("--observations")
    assert cmds["simulate-mcap"][:k] == cmds["simulate"][:k]
    assert "poses.mcap" in cmds["simulate-mcap"] and "--pose-noise" in cmds["simulate-mcap"]
    for path in DATA_PATHS:
        learn = cmds[f"learn.{path}"]
        assert learn[0] == "learn" and "--damage" not in learn and "--json" in learn
    assert "--topic" in cmds["learn.mcap"] and "/J/pose=J" in cmds["learn.mcap"]
    physics = run_commands(replace(cond, world="physics"), 7, [], ("I", "J"))
    assert "--pose-noise" not in physics["simulate"]  # the physical camera has its own


def test_simulation_seeds_differ_between_points_and_runs():
    a = Condition("mirl-t", "boydright", 0.14, 150, world="grid", damage="none")
    b = replace(a, obs_steps=450)
    seeds = {simulation_seed(s, c) for s in range(50) for c in (a, b)}
    assert len(seeds) == 100
    assert simulation_seed(3, a) == simulation_seed(3, a)
    assert all(0 <= s < 2**63 for s in seeds)


# ---------------------------------------------------------------------------------------------
# Scoring a record


def _record(verdicts: dict) -> dict:
    return {"robots": {r: {"verdict": v} for r, v in verdicts.items()}}


def _verdict(part=None, confidence=0.95, candidates=(), **extra):
    return {"part": part, "confidence": confidence, "candidates": list(candidates), **extra}


def test_a_verdict_is_right_when_it_names_a_damaged_part_or_no_part_of_a_healthy_robot():
    truth = {"I": (), "J": ("left_wheel",), "K": ("left_wheel", "right_wheel"), "M": ()}
    record = _record(
        {
            "I": _verdict(None, 0.99),  # no part, healthy: right
            "J": _verdict(None, 0.97),  # no part, damaged: false
            "K": _verdict(None, 0.9, ("navigation", "right_wheel")),  # among: right
            "M": _verdict("floor", 0.92, fit={"ok": False, "reason": "moves longer than a cell"}),
        }
    )
    record["robots"]["J"]["observed_moves"] = {"unexplained": 13}
    m = verdict_metrics("pose-csv", record, truth)
    assert [m[f"right.pose-csv.{r}"] for r in "IJKM"] == [1, 0, 1, 0]
    assert m["verdict.pose-csv.I"] == "" and m["verdict.pose-csv.K"] == "navigation,right_wheel"
    assert m["confidence.pose-csv.J"] == 0.97
    assert m["fit.pose-csv.M"] == "moves longer than a cell" and "fit.pose-csv.I" not in m
    assert m["unexplained.pose-csv.J"] == 13
    # a record without verdicts (a method with no feature probabilities) gives nothing
    assert verdict_metrics("mcap", {"robots": {"I": {"weights": {}}}}, {"I": ()}) == {}


# ---------------------------------------------------------------------------------------------
# The data paths, end to end


def _rows(path: Path) -> dict[tuple[str, str], tuple[str, str, str]]:
    with path.open(newline="") as fh:
        rows = csv.DictReader(fh)
        return {(r["t"], r["robot"]): (r["row"], r["col"], r["heading"]) for r in rows}


def _convert(learn: list[str], out: str) -> list[str]:
    """``mirl convert`` with the same file and pose-data flags as a ``mirl learn`` command."""
    args = list(learn[1:])
    i = args.index("--observations")
    source = args[i + 1]
    del args[i : i + 2]
    args = [a for a in args if a != "--json"]
    j = args.index("--observability")
    del args[j : j + 2]
    return ["convert", source, out, *args]


@pytest.mark.parametrize("world", ["grid", "physics"])
def test_each_data_path_round_trips_to_the_grid_states(world, tmp_path, monkeypatch):
    """The pose CSV and the MCAP file the atlas writes, read with the flags it learns with,
    give the grid CSV's observations: exactly in the physical world (L's camera measures one
    pose per step) and in the grid world at the camera's noise on all but a few steps."""
    if world == "physics":
        pytest.importorskip("mujoco")
    cond = Condition("mirl-t", "boydright-3", 1.0, 60, world=world, damage="K:left_wheel=0.7")
    scenario = load_scenario(cond.scenario)
    flags = damage_flags(world, scenario, parse_damage(cond.damage))
    cmds = run_commands(cond, 11, flags, scenario.robot_names)
    monkeypatch.chdir(tmp_path)
    for step in ("simulate", "simulate-mcap"):
        assert main(cmds[step]) == 0
    assert (tmp_path / "obs.csv").read_bytes() == (tmp_path / "obs-mcap.csv").read_bytes()
    assert main(_convert(cmds["learn.pose-csv"], "from-csv.csv")) == 0
    assert main(_convert(cmds["learn.mcap"], "from-mcap.csv")) == 0
    grid, from_csv = _rows(tmp_path / "obs.csv"), _rows(tmp_path / "from-csv.csv")
    assert from_csv == _rows(tmp_path / "from-mcap.csv")
    assert len(grid) == 3 * 60 and from_csv.keys() == grid.keys()
    same = sum(from_csv[k] == v for k, v in grid.items())
    assert same == len(grid) if world == "physics" else same >= 0.97 * len(grid)


def test_a_run_learns_from_every_path_and_scores_every_robot():
    cond = Condition("mirl-t", "boydright", 1.0, 40, world="grid", damage="J:right_wheel=0.7")
    out = atlas_run(cond, 3)
    assert out["outcome"] == "learned" and out["mcap_same_run"] == 1
    assert out["truth.I"] == "" and out["truth.J"] == "right_wheel"
    assert out["weakened.J"] == "right_wheel" and out["seen.I"] == out["seen.J"] == 40
    for path in DATA_PATHS:
        for robot in ("I", "J"):
            assert 0.0 <= out[f"confidence.{path}.{robot}"] <= 1.0
            assert out[f"right.{path}.{robot}"] in (0, 1)
        assert out["timings"][f"learn.{path}"] > 0
    assert out["command.simulate"].startswith("mirl simulate --scenario boydright")
    # the same poses in two formats: the same verdicts
    for robot in ("I", "J"):
        assert out[f"verdict.pose-csv.{robot}"] == out[f"verdict.mcap.{robot}"]


# ---------------------------------------------------------------------------------------------
# The sweep


def _small_points(n: int) -> list[dict]:
    """``n`` short grid points, as the fields of their conditions."""
    damages = ["none", "I:left_wheel=0.7", "J:right_wheel=0.7", "none"]
    return [
        {"method": "mirl-t", "scenario": "boyd2-healthy", "observability": 1.0,
         "obs_steps": 30 + 5 * k, "world": "grid", "damage": damage}
        for k, damage in enumerate(damages[:n])
    ]  # fmt: skip


def _small_atlas(n: int):
    """The atlas on ``n`` short grid points (the sweep is the real one)."""
    points = tuple(Condition(**p) for p in _small_points(n))
    return replace(EXPERIMENTS["atlas"], conditions=points)


def _stored(out: Path) -> list[dict]:
    return sorted(load_results(out)[1], key=lambda r: (r["condition_key"], r["run"]))


def _instant_run(condition: Condition, seed: int) -> dict:
    return {"outcome": "learned", "seed_seen": seed, "steps": condition.obs_steps}


def test_the_whole_design_resumes_from_a_partial_sweep_without_repeating_a_point(tmp_path):
    """The design's keys are stable between processes, so a sweep stopped after any prefix
    (here a stand-in run, the sweep and the design the real ones) resumes exactly the rest."""
    atlas = replace(EXPERIMENTS["atlas"], run_function=_instant_run)
    head = replace(atlas, conditions=atlas.conditions[:100])
    run_experiment(head, tmp_path, ONE, **QUIET)
    first = {(r["condition_key"], r["run"]): r["finished_at"] for r in _stored(tmp_path)}
    summary = run_experiment(atlas, tmp_path, ONE | {"resume": True}, **QUIET)
    assert (summary.already_done, summary.finished) == (100, len(atlas.conditions) - 100)
    rows = _stored(tmp_path)
    keys = [(r["condition_key"], r["run"]) for r in rows]
    assert len(keys) == len(set(keys)) == len(atlas.conditions)
    assert {r["condition_key"] for r in rows} == {c.key for c in atlas.conditions}
    assert all(r["finished_at"] == first[k] for k, r in zip(keys, rows, strict=True) if k in first)


@pytest.mark.slow
def test_a_resumed_atlas_keeps_finished_runs_and_runs_each_missing_one_once(tmp_path):
    run_experiment(_small_atlas(2), tmp_path, ONE, **QUIET)
    first = _stored(tmp_path)
    assert len(first) == 2
    with pytest.raises(ValueError, match="already holds 2 runs"):
        run_experiment(_small_atlas(3), tmp_path, ONE, **QUIET)
    summary = run_experiment(_small_atlas(3), tmp_path, ONE | {"resume": True}, **QUIET)
    assert (summary.already_done, summary.finished) == (2, 1)
    rows = _stored(tmp_path)
    keys = [(r["condition_key"], r["run"]) for r in rows]
    assert len(keys) == len(set(keys)) == 3
    kept = {(r["condition_key"], r["run"]): r for r in rows}
    for r in first:  # untouched: not recomputed
        assert kept[(r["condition_key"], r["run"])]["finished_at"] == r["finished_at"]
    assert all(r["outcome"] == "learned" for r in rows)


@pytest.mark.slow
def test_an_atlas_killed_mid_sweep_resumes_without_loss_or_duplication(tmp_path):
    script = "\n".join(
        [
            "import json, sys",
            "from dataclasses import replace",
            "from mirl.experiments.conditions import EXPERIMENTS, Condition",
            "from mirl.experiments.sweep import run_experiment",
            "points = tuple(Condition(**p) for p in json.loads(sys.argv[1]))",
            "atlas = replace(EXPERIMENTS['atlas'], conditions=points)",
            "run_experiment(atlas, sys.argv[2], {'progress': False, 'workers': 1}, "
            "log=lambda m: None)",
        ]
    )
    argv = [sys.executable, "-c", script, json.dumps(_small_points(4)), str(tmp_path)]
    # its own session, so the kill reaches the sweep and the mirl processes it runs at once
    proc = subprocess.Popen(argv, start_new_session=True)
    db = tmp_path / "results.sqlite"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        if db.exists():
            with sqlite3.connect(db) as con:
                n = con.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
            if n >= 1:
                break
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = _stored(tmp_path)
    assert 1 <= len(before) < 4
    run_experiment(_small_atlas(4), tmp_path, ONE | {"resume": True}, **QUIET)
    rows = _stored(tmp_path)
    keys = [(r["condition_key"], r["run"]) for r in rows]
    assert len(keys) == len(set(keys)) == 4
    kept = {(r["condition_key"], r["run"]): r["finished_at"] for r in rows}
    assert all(kept[(r["condition_key"], r["run"])] == r["finished_at"] for r in before)


def test_the_atlas_is_not_moved_to_one_world():
    from mirl.experiments.conditions import StoreError, in_world

    with pytest.raises(StoreError, match="'atlas' runs in every world already"):
        in_world(EXPERIMENTS["atlas"], "physics")
