"""The ``mirl`` command line, in-process through ``main([...])`` and once as a real process:
simulate's CSV files, --version, show-map, --damage, and one-line errors with exit code 2."""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import pytest

import mirl
from mirl.cli import main

SIM = ["simulate", "--scenario", "boyd2", "--steps", "300", "--seed", "1", "--observability"]
SIM += ["0.14", "--observations", "o.csv", "--truth", "t.csv"]
VISIBLE_014 = {(0, 1), (0, 2), (0, 3), (0, 4)}
BOYD2_TEXT = (Path(mirl.__file__).parent / "data" / "maps" / "boyd2.txt").read_text()


def read_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def check_simulate_outputs(directory: Path) -> None:
    header, truth = read_rows(directory / "t.csv")
    assert (directory / "t.csv").read_text().splitlines()[0] == "t,robot,row,col,heading"
    assert header == ["t", "robot", "row", "col", "heading"]
    assert len(truth) == 600  # 300 steps × 2 robots
    assert {(int(r[0]), r[1]) for r in truth} == {(t, n) for t in range(300) for n in "IJ"}
    obs_header, obs = read_rows(directory / "o.csv")
    assert obs_header == header
    expected = [r for r in truth if (int(r[2]), int(r[3])) in VISIBLE_014]
    assert obs == expected
    assert len(obs) > 0


def one_error_line(err: str, *needles: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert re.match(r"mirl [a-z-]+: error: ", lines[0]), lines[0]  # names the sub-command
    for n in needles:
        assert n in lines[0], (n, lines[0])


# --------------------------------------------------------------------------- simulate


def test_simulate_in_process(tmp_path, monkeypatch, capsys):
    runs = []
    for name in ("a", "b"):
        d = tmp_path / name
        d.mkdir()
        monkeypatch.chdir(d)
        assert main(SIM) == 0
        out = capsys.readouterr().out
        assert "wrote o.csv" in out and "wrote t.csv (600 rows)" in out
        assert "observability 0.14 (4/31 cells)" in out
        check_simulate_outputs(d)
        runs.append(((d / "o.csv").read_bytes(), (d / "t.csv").read_bytes()))
    assert runs[0] == runs[1]  # byte-identical


def test_simulate_as_a_process(tmp_path):
    """The real entry: a fresh interpreter running ``python -m mirl.cli``."""
    proc = subprocess.run(
        [sys.executable, "-m", "mirl.cli", *SIM],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    check_simulate_outputs(tmp_path)
    # the same bytes as the in-process run
    d = tmp_path / "again"
    d.mkdir()
    subprocess.run(
        [sys.executable, "-m", "mirl.cli", *SIM],
        cwd=d,
        check=True,
        timeout=120,
        capture_output=True,
    )
    for f in ("o.csv", "t.csv"):
        assert (d / f).read_bytes() == (tmp_path / f).read_bytes()


def test_error_as_a_process(tmp_path):
    bad = tmp_path / "ragged.txt"
    bad.write_text("L...\n#.#\n#G##\n")
    proc = subprocess.run(
        [sys.executable, "-m", "mirl.cli", "show-map", str(bad)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    one_error_line(proc.stderr, str(bad))


def test_a_reader_that_stops_early_is_not_an_error():
    # `mirl show-map boyd2 | head -0`: the pipe closes before mirl writes; no message, and the
    # shell's exit code for a writer stopped by SIGPIPE
    proc = subprocess.Popen(
        [sys.executable, "-m", "mirl.cli", "show-map", "boyd2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # mirl is still importing: its first write meets a closed pipe
    err = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait(timeout=120) == 141
    assert err == b""


def test_a_reader_that_stops_early_does_not_cost_the_files(tmp_path):
    # `mirl simulate ... --observations obs.csv | head -0`: the record is written all the same
    out = {k: tmp_path / f"{k}.csv" for k in ("obs", "truth", "poses")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mirl.cli", "simulate", "--scenario", "boyd2", "--steps", "20",
         "--observations", str(out["obs"]), "--truth", str(out["truth"]),
         "--poses", str(out["poses"])],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )  # fmt: skip
    proc.stdout.close()
    err = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait(timeout=120) == 141
    assert err == b""
    assert out["truth"].read_text().count("\n") == 1 + 2 * 20
    assert out["obs"].read_text().startswith("t,robot,row,col,heading")
    assert out["poses"].read_text().startswith("t,robot,x,y,yaw")


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"mirl {mirl.__version__}"


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "usage" in capsys.readouterr().out


def test_show_map_with_observability(capsys):
    assert main(["show-map", "boyd2", "--observability", "0.14"]) == 0
    out = capsys.readouterr().out.splitlines()
    grid = [ln for ln in out if ln and not ln.startswith(";")][:17]
    expected = BOYD2_TEXT.splitlines()
    expected[0] = "Loooo...."
    assert grid == expected
    assert "boyd2: 17x9 cells of 1 m, 31 patroller cells, 124 patroller states" in out[-3]
    assert out[-1] == (
        "  L's view at observability 0.14: 4 of 31 patroller cells, 4 of them in L's line of sight"
    )
    assert "; visible: 4 of 31 patroller cells (13 %)" in out


def test_show_map_plain(capsys):
    assert main(["show-map", "boyd2"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[:17] == BOYD2_TEXT.splitlines()
    assert (
        out[-2]
        == "boyd2: 17x9 cells of 1 m, 31 patroller cells, 124 patroller states (cell x heading)"
    )
    assert out[-1] == (
        "  frame: cell (0, 0) is centred at x = 0, y = 0 m; the grid spans x -0.5 to 8.5 m, "
        "y -16.5 to 0.5 m"
    )


def test_show_map_plain_ros_map(tmp_path, capsys):
    assert main(["show-map", "turtlebot3_world", "--png", str(tmp_path / "m.png")]) == 0
    out = capsys.readouterr().out
    assert "turtlebot3_world: 39x39 cells of 0.5 m, 40 patroller cells, 160 patroller states" in out
    assert "L's start and goal: not marked" in out and "L" not in out.split(";")[0]
    assert (tmp_path / "m.png").stat().st_size > 0
    assert main(["show-map", "turtlebot3_world", "--cell-size", "0.25"]) == 0
    assert "77x77 cells of 0.25 m, 255 patroller cells" in capsys.readouterr().out


def test_show_map_scenario(capsys):
    toml = str(Path(mirl.__file__).parent / "data" / "scenarios" / "boyd2.toml")
    assert main(["show-map", toml]) == 0
    out = capsys.readouterr().out
    assert "L's view at observability 0.14: 4 of 31 patroller cells" in out  # the scenario's
    assert "L's start: cell (0, 0), x = 0, y = 0 m" in out and "L's goal: cell (9, 1)" in out
    assert "I: starts on cell (0, 8) facing west" in out
    assert main(["show-map", toml, "--cell-size", "0.5"]) == 2
    assert "[frame] cell_size" in capsys.readouterr().err


def test_show_map_big_text_map_not_printed_with_png(tmp_path, capsys):
    assert main(["show-map", "office-80x80", "--png", str(tmp_path / "o.png")]) == 0
    out = capsys.readouterr().out
    assert "#" not in out and "office-80x80: 80x80 cells" in out
    assert main(["show-map", "office-40x30"]) == 0
    assert capsys.readouterr().out.count("\n") > 40  # small enough: printed


def test_damage_accepted(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    base = ["simulate", "--scenario", "boyd2-healthy", "--steps", "200", "--truth", "t.csv"]
    assert main(base) == 0
    healthy = (tmp_path / "t.csv").read_bytes()
    assert main([*base, "--damage", "J:left_wheel=0.5"]) == 0
    assert (tmp_path / "t.csv").read_bytes() != healthy  # the damage changes J's motion
    capsys.readouterr()


@pytest.mark.parametrize(
    "damage, needle",
    [
        ("J:wheel=0.5", "wheel"),
        ("K:left_wheel=0.5", "K"),
        ("J:left_wheel=1.2", "must be in [0, 1]"),
        ("J-left", "ROBOT:FEATURE=P"),
    ],
)
def test_bad_damage(capsys, damage, needle):
    rc = main(["simulate", "--scenario", "boyd2", "--steps", "5", "--damage", damage])
    assert rc == 2
    # one line naming the flag, the value it objects to and the problem
    one_error_line(capsys.readouterr().err, needle, f"--damage '{damage}'")


# --------------------------------------------------------------------------- one-line errors


def test_ragged_map(tmp_path, capsys):
    bad = tmp_path / "ragged.txt"
    bad.write_text("L...\n#.#\n#G##\n")
    assert main(["show-map", str(bad)]) == 2
    one_error_line(capsys.readouterr().err, str(bad))


def test_missing_map(tmp_path, capsys):
    missing = tmp_path / "nowhere.txt"
    assert main(["show-map", str(missing)]) == 2
    one_error_line(capsys.readouterr().err, str(missing))


@pytest.mark.parametrize(
    "text, field",
    [
        ('map = "boyd2"\n[[robots]]\nstart = [0, 8', "invalid TOML"),
        ('map = "boyd2"\n[[robots]]\nstart = [0, 8, 2]\n', "robots"),
        ('map = "boyd2"\nspeed = 3\n', "speed"),
    ],
)
def test_malformed_scenario(tmp_path, capsys, text, field):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    assert main(["simulate", "--scenario", str(bad), "--steps", "5"]) == 2
    one_error_line(capsys.readouterr().err, str(bad), field)


def test_missing_scenario(tmp_path, capsys):
    missing = tmp_path / "absent.toml"
    assert main(["simulate", "--scenario", str(missing)]) == 2
    one_error_line(capsys.readouterr().err, str(missing))


def test_scenario_with_malformed_map(tmp_path, capsys):
    (tmp_path / "ragged.txt").write_text("L...\n#.#\n#G##\n")
    scen = tmp_path / "s.toml"
    scen.write_text('map = "ragged.txt"\n')
    assert main(["simulate", "--scenario", str(scen)]) == 2
    one_error_line(capsys.readouterr().err, str(scen), "ragged.txt")


def test_argparse_rejects_bad_numbers(capsys):
    with pytest.raises(SystemExit) as info:
        main(["simulate", "--scenario", "boyd2", "--steps", "0"])
    assert info.value.code == 2
    assert "--steps: must be an integer in [1, " in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["simulate", "--scenario", "boyd2", "--observability", "1.5"])
    assert info.value.code == 2


def test_learn_and_run_give_intervals_and_verdicts(tmp_path, capsys):
    import json

    obs = tmp_path / "obs.csv"
    argv = ["simulate", "--scenario", "boyd2", "--steps", "300", "--seed", "1"]
    assert main([*argv, "--observability", "1", "--observations", str(obs)]) == 0
    capsys.readouterr()
    learn = ["learn", "--scenario", "boyd2", "--observations", str(obs), "--observability", "1"]
    assert main([*learn, "--json"]) == 0
    j = json.loads(capsys.readouterr().out)["robots"]["J"]
    assert set(j["feature_intervals"]) == set(j["feature_probabilities"])
    assert all(0 <= lo <= hi <= 1 for lo, hi in j["feature_intervals"].values())
    verdict = j["verdict"]
    named = [verdict["part"]] if verdict["part"] else verdict["candidates"]
    damage = verdict["damage_probabilities"]
    assert "left_wheel" in named and max(damage, key=damage.get) == "left_wheel"
    assert 0.5 < verdict["confidence"] <= 1 and verdict["fit"]["ok"]
    models = j["motion_models"]
    assert set(models) == {
        "paper/uniform", "paper/stop", "free-turns/uniform", "free-turns/stop",
        "paper-mirrored/stop",
    }  # fmt: skip
    assert abs(sum(models.values()) - 1) < 1e-3
    assert j["motion_model"] == "paper/uniform"  # the grid's own, which the record favours
    assert main(learn) == 0
    text = capsys.readouterr().out
    assert "left wheel" in text and "95 % interval" in text and "motion        " in text
    assert main([*learn, "--method", "mirl", "--json"]) == 0  # no feature probabilities
    assert "verdict" not in json.loads(capsys.readouterr().out)["robots"]["J"]
    run = ["run", "--obs-steps", "100", "--seed", "0", "--max-wait", "20"]
    assert main([*run, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["verdicts"]) == {"I", "J"} and set(out["feature_intervals"]) == {"I", "J"}
    assert main(run) == 0
    assert "verdict: " in capsys.readouterr().out


def test_the_readme_learn_example(tmp_path, capsys):
    """The README's learn example (boyd2, 450 steps, seed 1, L's door): J's lines exactly as the
    README shows them; Eq. 4's navigation lies outside the posterior's interval, so the
    features line is the posterior's and Eq. 4's the line below it."""
    import re

    import mirl

    readme = (Path(mirl.__file__).resolve().parents[2] / "README.md").read_text()
    block = re.search(r"```(?:text)?\nrobot J\n(.*?)```", readme, re.S)
    assert block is not None
    obs = tmp_path / "obs.csv"
    sim = ["simulate", "--scenario", "boyd2", "--steps", "450", "--seed", "1"]
    assert main([*sim, "--observations", str(obs)]) == 0
    capsys.readouterr()
    assert main(["learn", "--scenario", "boyd2", "--observations", str(obs)]) == 0
    lines = capsys.readouterr().out.splitlines()
    shown = block.group(1).splitlines()
    j = lines.index("robot J")
    assert [x for x in lines[j + 1 :] if x.startswith("  ") and x in shown] == shown
    j = lines.index("robot J")
    features, interval, eq4, motion, verdict = (line.strip() for line in lines[j + 2 : j + 7])
    # Eq. 4's navigation (0.842) lies below the posterior's interval: the features line is the
    # posterior's medians, Eq. 4's the line below, which L plans with
    assert features.startswith("features      left_wheel 0.")
    assert "(the posterior's medians)" in features
    assert "(navigation and floor: the steps cannot tell them apart)" in features
    assert interval.startswith("95 % interval left_wheel 0.")
    assert eq4.startswith("Eq. 4         left_wheel=0.541  right_wheel=1.000") and "L plans" in eq4
    assert motion.startswith("motion        turns need a wheel") and "L plans with it" in motion
    assert verdict.startswith("verdict       J's left wheel is damaged (confidence 0.9")


def test_features_line_gives_one_answer():
    """Where Eq. 4's estimate lies outside its interval, or reads a part as damaged where the
    posterior does not, the features line is the posterior's medians and Eq. 4's follows,
    labelled as what L plans with."""
    from mirl.cli.learn_report import feature_lines
    from mirl.world.faults import DamageDefinition

    record = {
        "feature_probabilities": {"left_wheel": 0.767, "right_wheel": 1.0},
        "feature_intervals": {"left_wheel": [0.75, 0.99], "right_wheel": [0.88, 0.99]},
        "feature_medians": {"left_wheel": 0.94, "right_wheel": 0.96},
        "indistinguishable": [],
    }
    lines = feature_lines(record, DamageDefinition())
    assert lines[0].startswith("features      left_wheel 0.94  right_wheel 0.96")
    assert "(the posterior's medians)" in lines[0]
    assert lines[2].startswith("Eq. 4         left_wheel=0.767") and "L plans with it" in lines[2]
    record["feature_probabilities"]["left_wheel"] = 0.93  # both read it healthy, inside
    lines = feature_lines(record, DamageDefinition())
    assert len(lines) == 2 and lines[0].startswith("features      left_wheel=0.930")
