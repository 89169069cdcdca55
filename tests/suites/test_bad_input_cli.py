"""Flags a bad-input audit found unchecked: each is refused with one line naming the flag, exit
code 2, before any simulation or learning (so every case is cheap); their valid neighbours
still run."""

from __future__ import annotations

import pytest

from mirl.cli import main

S = ["simulate", "--scenario", "boyd2", "--steps", "5"]
GOOD_CSV = "t,robot,row,col,heading\n0,I,0,4,2\n1,I,0,3,2\n2,I,0,2,2\n0,J,0,1,0\n1,J,0,2,0\n"

BAD = [
    # (argv, a substring the one line must contain)
    (S + ["--step-seconds", "1e308", "--poses", "{d}/p.csv"], "--step-seconds"),
    (S + ["--step-seconds", "1e-300", "--poses", "{d}/p.csv"], "--step-seconds"),
    (S + ["--pose-rate", "1e9", "--poses", "{d}/p.csv"], "--pose-rate"),
    (S + ["--pose-rate", "1e-9", "--poses", "{d}/p.csv"], "--pose-rate"),
    (S + ["--pose-rate", "600", "--poses", "{d}/p.csv"], "poses per step"),
    (
        [
            "simulate",
            "--scenario",
            "boyd2",
            "--steps",
            "1000000",
            "--pose-rate",
            "100",
            "--poses",
            "{d}/p.csv",
        ],
        "poses per robot",
    ),  # fmt: skip
    (S + ["--pose-noise", "1e308", "1", "--poses", "{d}/p.csv"], "--pose-noise SIGMA_M"),
    (S + ["--pose-noise", "0.1", "1e9", "--poses", "{d}/p.csv"], "--pose-noise SIGMA_DEG"),
    (S + ["--pose-rate", "5"], "give --poses"),  # ignored without --poses: refused
    (S + ["--step-seconds", "1"], "give --poses"),
    (S + ["--observations", "{d}/o.csv", "--truth", "{d}/../{name}/o.csv"], "the same file"),
    (S + ["--observations", "{d}/o.csv", "--poses", "{d}/o.csv"], "the same file"),
    (S + ["--poses", "{d}/no/dir/p.mcap"], "--poses"),
    (S + ["--poses", "{d}/p.bag"], "ROS 1 bags are read"),
    (S + ["--poses", "{d}/old.mcap"], "not overwriting"),  # was refused after the simulation
    (["convert", "{d}/good.csv", "{d}/good.csv", "--scenario", "boyd2"], "the same file"),
    (["convert", "{d}/good.csv", "{d}/no/dir/out.csv", "--scenario", "boyd2"], "OUT"),
    (["learn", "--scenario", "boyd2", "--observations", "{d}/good.csv", "--p", "0.3"], "--p"),
    (
        [
            "learn",
            "--scenario",
            "boyd2",
            "--observations",
            "{d}/good.csv",
            "--step-seconds",
            "1e-300",
        ],
        "--step-seconds",
    ),  # fmt: skip
    (["run", "--method", "random", "--p", "0.5"], "--p applies"),
    (["run", "--method", "mirl-t", "--p", "0.5"], "--p applies"),
    (["experiment", "table1", "--out", "{d}/good.csv"], "is a file"),
    (["experiment", "table1", "--out", ""], "--out"),
    (["experiment", "table1", "--out", "{d}/x", "--dask-scheduler", "nonsense"], "HOST:PORT"),
    (["experiment", "table1", "--out", "{d}/x", "--dask-scheduler", "h:99999"], "HOST:PORT"),
]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("badcli")
    (d / "good.csv").write_text(GOOD_CSV)
    (d / "old.mcap").write_bytes(b"")
    return d


@pytest.mark.parametrize(("argv", "needle"), BAD, ids=[needle for _, needle in BAD])
def test_refused_in_one_line_before_any_work(files, capsys, argv, needle):
    argv = [a.format(d=files, name=files.name) for a in argv]
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse refuses a flag's value by exiting
        code = stop.code
    assert code == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], captured.err
    assert "Traceback" not in captured.err and captured.out == ""
    assert not (files / "o.csv").exists() and not (files / "x").exists()  # nothing written


def test_the_valid_neighbours_still_run(files, capsys):
    assert main(S + ["--poses", str(files / "p.csv"), "--pose-rate", "5", "--step-seconds",
                     "1", "--pose-noise", "0.05", "3"]) == 0  # fmt: skip
    assert "5 Hz, steps of 1 s" in capsys.readouterr().out
    assert main(["learn", "--scenario", "boyd2", "--observations", str(files / "good.csv"),
                 "--method", "mirl", "--p", "0.8", "--json"]) == 0  # fmt: skip
    assert main(["convert", str(files / "good.csv"), str(files / "grid.csv"), "--scenario",
                 "boyd2"]) == 0  # fmt: skip


def test_a_dead_motor_is_a_strength_of_zero_in_the_physics_world(capsys):
    pytest.importorskip("mujoco")
    assert main(["simulate", "--scenario", "boyd2", "--world", "physics", "--steps", "3",
                 "--damage", "J:left_wheel=0"]) == 0  # fmt: skip
    assert "J:left_wheel=0" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("tamper", "needle"),
    [
        ("DELETE FROM meta", "no experiment or base_seed"),
        ("UPDATE runs SET outcome = 'exploded' WHERE run = 0", "ended in 'exploded'"),
    ],
)
def test_report_refuses_runs_no_sweep_writes(tmp_path, capsys, tamper, needle):
    import sqlite3

    assert main(["experiment", "selftest", "--runs", "1", "--out", str(tmp_path), "--workers",
                 "1", "--quiet"]) == 0  # fmt: skip
    db = tmp_path / "results.sqlite"
    with sqlite3.connect(db) as con:
        con.execute(tamper)
    con.close()
    before = db.read_bytes()
    capsys.readouterr()
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0] and "results.sqlite" in err[0]
    assert db.read_bytes() == before  # left as it is


def _boyd2_with(tmp_path, after: str, text: str):
    """boyd2's scenario with ``text`` inserted after the line ``after``."""
    from mirl.world import scenario as scenario_module

    shipped = scenario_module.__file__.replace("world/scenario.py", "data/scenarios/boyd2.toml")
    toml = open(shipped, encoding="utf-8").read()
    assert after in toml
    path = tmp_path / "s.toml"
    path.write_text(toml.replace(after, after + "\n" + text, 1))
    return str(path)


@pytest.mark.parametrize(
    ("line", "field"),
    [
        ("timestep = 0.0", "physics.timestep"),
        ("control_hz = 0", "physics.control_hz"),
        ("step_seconds = 0.0", "physics.step_seconds"),
        ("timestep = 1e9", "physics.timestep"),  # longer than a control tick
        ("step_seconds = 0.01", "physics.step_seconds"),  # shorter than a control tick
        ("localisation_sigma = inf", "physics.localisation_sigma"),
        ("max_speed = nan", "physics.max_speed"),
    ],
)
def test_physics_values_that_cannot_work_are_refused(tmp_path, capsys, line, field):
    pytest.importorskip("mujoco")
    path = _boyd2_with(tmp_path, "[physics]", line)
    code = main(["simulate", "--scenario", path, "--world", "physics", "--steps", "3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and field in err[0] and "s.toml" in err[0], err


def test_transition_feature_actions_must_be_a_table(tmp_path, capsys):
    table = '[transition_features]\nfeatures = ["floor"]\nactions = 3\n'
    path = _boyd2_with(tmp_path, "detect_distance = 6", table)
    assert main(["simulate", "--scenario", path, "--steps", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "transition_features.actions" in err[0], err


def test_a_device_as_scenario_or_map_is_read_only_up_to_the_limit(capsys):
    # /dev/zero has no size to check first; it used to be read until memory ran out
    for argv in (["simulate", "--scenario", "/dev/zero"], ["show-map", "/dev/zero"]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "/dev/zero" in err[0] and "64 MB" in err[0], err


def test_a_scenario_with_windows_line_ends_reads_as_before(tmp_path, capsys):
    path = _boyd2_with(tmp_path, "detect_distance = 6", "")
    crlf = tmp_path / "crlf.toml"
    crlf.write_bytes(open(path, "rb").read().replace(b"\n", b"\r\n"))
    assert main(["simulate", "--scenario", str(crlf), "--steps", "3"]) == 0


def _boyd2_replaced(tmp_path, old: str, new: str) -> str:
    path = _boyd2_with(tmp_path, "detect_distance = 6", "")
    text = open(path, encoding="utf-8").read()
    assert old in text
    open(path, "w", encoding="utf-8").write(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ("start = [16, 8, 2]", "start = [0, 8, 2]", "robots[1].start"),  # I's start
        ('name = "J"', 'name = ""', "robots[1].name"),  # was renamed R1 silently
        ("turn_around = 0.3 }", "turn_around = 1e308 }", "reward.weights.turn_around"),
    ],
)
def test_scenario_content_that_cannot_be_meant_is_refused(tmp_path, capsys, old, new, field):
    path = _boyd2_replaced(tmp_path, old, new)
    assert main(["simulate", "--scenario", path, "--steps", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0] and "s.toml" in err[0], err
