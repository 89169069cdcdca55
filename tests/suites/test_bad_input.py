"""Issue 13: a suite of malformed and edge-case inputs for every sub-command. Each bad input ends
with exactly one line on stderr naming the flag or file, exit code 2 and no traceback; each
valid edge case succeeds. Every case is cheap (refused before any simulation or learning)."""

from __future__ import annotations

import pytest

from mirl.cli import main

GOOD_CSV = "t,robot,row,col,heading\n0,I,0,4,2\n1,I,0,3,2\n2,I,0,2,2\n0,J,0,1,0\n1,J,0,2,0\n"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    (d / "empty.txt").write_bytes(b"")
    (d / "binary.txt").write_bytes(bytes(range(256)))
    (d / "huge.txt").write_text("L" + "." * 1499 + "\nG" + "." * 1499 + "\n")
    (d / "good.csv").write_text(GOOD_CSV)
    (d / "bom.csv").write_bytes(b"\xef\xbb\xbf" + GOOD_CSV.encode())
    (d / "header.csv").write_text("t,robot,row,col,heading\n")
    (d / "empty.csv").write_bytes(b"")
    (d / "binary.csv").write_bytes(b"t,robot,row,col,heading\n0,\xff\xfe,0,4,2\n")
    (d / "future.csv").write_text(GOOD_CSV + "999999999999,I,0,4,2\n")
    (d / "bigint.csv").write_text(GOOD_CSV + "3,I,0,4,99999999999999999999999\n")
    (d / "robot.csv").write_text(GOOD_CSV + "3,K,0,4,2\n")
    (d / "giant.csv").write_text(GOOD_CSV + "3," + "I" * 300_000 + ",0,4,2\n")
    (d / "teleport.csv").write_text(GOOD_CSV + "3,I,0,8,2\n")
    for name in ("results-empty", "results-garbage"):
        (d / name).mkdir()
    (d / "results-empty" / "results.sqlite").write_bytes(b"")
    (d / "results-garbage" / "results.sqlite").write_bytes(b"SQLite format 3\x00" + b"\x07" * 500)
    return d


S = ["--scenario", "boyd2"]
BAD = [
    # (argv, a substring the one line must contain)
    (["frobnicate"], "unknown command 'frobnicate'"),
    (["--bogus"], "--bogus"),
    (["show-map"], "NAME_OR_PATH"),
    (["show-map", "no-such-map"], "no-such-map"),
    (["show-map", "boyd2", "--observability", "2"], "--observability"),
    (["show-map", "boyd2", "--observability", "nan"], "--observability"),
    (["show-map", "boyd2", "--cell-size", "-1"], "--cell-size"),
    (["show-map", "boyd2", "--png", "{d}/no/dir/m.png"], "--png"),
    (["show-map", "boyd2", "--png", "{d}/m.jpg"], "--png"),
    (["show-map", "{d}/empty.txt"], "empty.txt"),
    (["show-map", "{d}/binary.txt"], "binary.txt"),
    (["show-map", "{d}/huge.txt"], "limit of 1000x1000"),
    (["show-map", "office-5000x5000"], "1000x1000"),
    (["show-map", "turtlebot3_world", "--cell-size", "0.01"], "--cell-size 0.01 m is smaller"),
    (["show-map", "turtlebot3_world", "--cell-size", "5"], "fewer than 2 free cells"),
    (["show-map", "turtlebot3_world", "--observability", "0.1"], "does not mark L's start"),
    (["simulate", *S, "--steps", "1000000000"], "--steps"),
    (["simulate", *S, "--steps", "0"], "--steps"),
    (["simulate", *S, "--steps", "ten"], "--steps"),
    (["simulate", *S, "--seed", "-1"], "--seed"),
    (["simulate", *S, "--seed", "1.5"], "--seed"),
    (["simulate", *S, "--observability", "-0.1"], "--observability"),
    (["simulate", *S, "--heading-noise", "2"], "--heading-noise"),
    (["simulate", "--scenario", "no-such-scenario"], "no-such-scenario"),
    (["simulate", *S, "--damage", "J:left_wheel=2"], "left_wheel"),
    (["simulate", *S, "--damage", "nonsense"], "nonsense"),
    (["simulate", *S, "--observations", "{d}/no/dir/o.csv"], "--observations"),
    (["simulate", *S, "--truth", "{d}"], "--truth"),
    (["learn-transitions", *S, "--observations", "{d}/missing.csv"], "missing.csv"),
    (["learn-transitions", *S, "--observations", "{d}/empty.csv"], "empty.csv"),
    (["learn-transitions", *S, "--observations", "{d}/header.csv"], "no observations"),
    (["learn-transitions", *S, "--observations", "{d}/binary.csv"], "binary.csv"),
    (["learn-transitions", *S, "--observations", "{d}/future.csv"], "beyond the limit"),
    (["learn-transitions", *S, "--observations", "{d}/bigint.csv"], "too large"),
    (["learn-transitions", *S, "--observations", "{d}/robot.csv"], "robot 'K'"),
    (["learn-transitions", *S, "--observations", "{d}/giant.csv"], "300000 characters"),
    (["learn-transitions", *S, "--observations", "{d}/good.csv", "--labels", "x"], "--labels"),
    (["learn", *S, "--observations", "{d}/header.csv"], "no observations"),
    (["learn", *S, "--observations", "{d}/good.csv", "--max-iterations", "0"], "--max-iter"),
    (["learn", *S, "--observations", "{d}/good.csv", "--label-tol", "1.5"], "--label-tol"),
    (["learn", *S, "--observations", "{d}/good.csv", "--p", "1.5"], "--p"),
    (["learn", *S, "--observations", "{d}/good.csv", "--em-init", "zeros"], "--em-init"),
    (["learn", *S, "--observations", "{d}/good.csv", "--method", "oracle"], "--method"),
    (["learn", *S], "--observations"),
    (["run", "--obs-steps", "1000000000"], "--obs-steps"),
    (["run", "--max-wait", "-5"], "--max-wait"),
    (["run", "--seed", "-1"], "--seed"),
    (["run", "--watch-until-seen", "0"], "--watch-until-seen"),
    (["run", "--obs-steps", "300", "--watch-until-seen", "5"], "exclude each other"),
    (["run", "--plot", "{d}/no/dir/run.png"], "--plot"),
    (["run", "--plot", "{d}/run.txt"], "--plot"),
    (["run", "--method", "nope"], "--method"),
    (["run", "--p", "2"], "--p"),
    (["run", "--observability", "inf"], "--observability"),
    (["experiment", "fig9", "--out", "{d}/x"], "unknown experiment 'fig9' (did you mean 'fig3'"),
    (["experiment", "fig3", "--runs", "0"], "--runs"),
    (["experiment", "fig3", "--workers", "0"], "--workers"),
    (["experiment", "fig3", "--progress-every", "0"], "--progress-every"),
    (["experiment", "fig3", "--em-init", "zeros"], "--em-init"),
    (["experiment", "fig3", "--em-init", "uniform"], "no dbn-em runs"),
    (["run", "--em-init", "uniform"], "--em-init applies to the method dbn-em only"),
    (["learn", *S, "--observations", "{d}/good.csv", "--em-init", "uniform"], "dbn-em only"),
    (["experiment", "selftest", "--out", "{d}/results-empty", "--resume"], "empty file"),
    (["experiment", "selftest", "--out", "{d}/results-garbage", "--resume"], "results.sqlite"),
    (["report", "{d}/nothing-here"], "nothing-here"),
    (["report", "{d}/results-empty"], "empty file"),
    (["report", "{d}/results-garbage"], "corrupt or truncated"),
    (["convert", "{d}/missing.bag", "{d}/out.csv", *S], "missing.bag"),
]

GOOD = [
    ["show-map", "boyd2", "--observability", "0"],
    ["show-map", "boyd2", "--observability", "1"],
    ["simulate", *S, "--steps", "1", "--seed", "0"],
    ["learn-transitions", *S, "--observations", "{d}/good.csv"],
    ["learn-transitions", *S, "--observations", "{d}/bom.csv", "--json"],
]


def _run(argv, capsys) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("argv, needle", BAD, ids=[" ".join(a)[:60] for a, _ in BAD])
def test_bad_input_is_one_line_and_exit_2(argv, needle, files, capsys):
    code, _, err = _run([a.format(d=files) for a in argv], capsys)
    assert code == 2, err
    assert "Traceback" not in err
    assert err.count("\n") == 1 and err.startswith("mirl"), err
    assert needle in err, err


@pytest.mark.parametrize("argv", GOOD, ids=[" ".join(a)[:60] for a in GOOD])
def test_valid_edge_cases_succeed(argv, files, capsys):
    code, out, err = _run([a.format(d=files) for a in argv], capsys)
    assert code == 0, err
    assert "Traceback" not in err and out


def test_refused_databases_are_left_byte_for_byte(files, capsys):
    for name in ("results-empty", "results-garbage"):
        db = files / name / "results.sqlite"
        before = db.read_bytes()
        assert _run(["report", str(files / name)], capsys)[0] == 2
        assert (
            _run(["experiment", "selftest", "--out", str(files / name), "--resume"], capsys)[0] == 2
        )
        assert db.read_bytes() == before
        assert sorted(p.name for p in db.parent.iterdir()) == ["results.sqlite"]


def test_unexplained_steps_warn_loudly(files, capsys):
    code, _, err = _run(
        ["learn-transitions", *S, "--observations", str(files / "teleport.csv")], capsys
    )
    assert code == 0
    assert "warning" in err and "explained by no action" in err and "t=2" in err


def test_every_flag_has_help_and_shows_its_default():
    import argparse

    from mirl.cli.parser import build_parser

    parser = build_parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sp in subs.choices.items():
        text = sp.format_help()
        for action in sp._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            assert action.help, f"mirl {name} {action.dest}: no help text"
        # a flag with a default shows it; one left out by default shows no "(default: None)"
        # beside a help that says what leaving it out means ("None: 0.9")
        shown = [
            a for a in sp._actions
            if a.option_strings and a.default not in (None, argparse.SUPPRESS)
        ]  # fmt: skip
        assert text.count("(default:") >= len(shown), name
        assert "(default: None)" not in text, name
