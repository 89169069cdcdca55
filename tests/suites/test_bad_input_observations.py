"""Robot data a third bad-input pass found crashing, allocating gigabytes or silently accepted:
each is refused in one line naming the file (and line or field), exit code 2, nothing printed
before it; the valid neighbours still read."""

from __future__ import annotations

import contextlib
import io
import shutil
import warnings

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mirl.cli import main
from mirl.observations.sources import load_observations
from mirl.world.scenario import load_scenario

GRID = "t,robot,row,col,heading\n0,I,0,4,2\n1,I,0,3,2\n"
POSES = "t,robot,x,y,yaw\n0,I,4.0,0.0,3.14159\n2,I,3.0,0.0,3.14159\n"

BAD = [
    # (file name, content, extra flags, what the one line must contain)
    ("long.csv", GRID + "2,I,0,2,2,9\n", [], "line 4: expected 5 cells, got 6"),
    ("dup.csv", "t,robot,row,col,heading,row\n0,I,0,4,2,0\n", [], "column 'row' appears twice"),
    ("us.csv", GRID + "6_0,I,0,2,2\n", [], "'6_0' is not an integer"),  # int() read 60
    ("digits.csv", GRID + "2,I,0,\u0663,2\n", [], "is not an integer"),  # Arabic-Indic 3
    ("huge.csv", GRID + "2,I,0," + "9" * 5000 + ",2\n", [], "is too large"),
    ("px.csv", POSES + "4,I,1e300,0.0,0\n", [], "beyond the limits"),  # numpy warnings first
    ("pt.csv", POSES + "1e300,I,2.0,0.0,0\n", [], "beyond the limits"),  # OverflowError
    ("mix.csv", POSES + "1700000000,I,2.0,0.0,0\n", [], "limit of 1000000 steps"),  # GBs
    ("pdup.csv", "t,robot,x,y,yaw,x\n0,I,4.0,0.0,0,1\n", [], "column 'x' appears twice"),
    ("both.csv", "t,robot,x,y,yaw,qz,qw\n0,I,4.0,0.0,0,0,1\n", [], "not both"),
    ("plong.csv", POSES + "4,I,2.0,0.0,0,7\n", [], "line 4: expected 5 cells, got 6"),
    ("p.csv", POSES, ["--start-time=-1e300"], "start time"),
    ("p2.csv", POSES, ["--topic", "I=I", "--topic", "I=J"], "given twice"),
]


@pytest.mark.parametrize(("name", "text", "flags", "needle"), BAD, ids=[b[0] for b in BAD])
def test_refused_in_one_line(tmp_path, capsys, name, text, flags, needle):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning printed before the error line is a failure
        code = main(["learn", "--scenario", "boyd2", "--observations", str(path), *flags])
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and needle in lines[0], captured.err
    assert name in lines[0] or "--topic" in lines[0]
    assert captured.out == ""


def test_the_valid_neighbours_still_read(tmp_path):
    sc = load_scenario("boyd2")
    (tmp_path / "g.csv").write_text(GRID + "2,I,+0,2,2\n")  # a sign is a plain integer
    assert len(load_observations(tmp_path / "g.csv", sc).trajectories) == 3
    (tmp_path / "p.csv").write_text(POSES)
    loaded = load_observations(tmp_path / "p.csv", sc, start_time=1700000000.0 - 1e9)
    assert len(loaded.trajectories) == 0  # far before: nothing binned, nothing allocated
    loaded = load_observations(tmp_path / "p.csv", sc, topics=[("I", "J")])
    assert loaded.trajectories.robot.tolist() == [1, 1]


def test_a_conversion_with_no_steps_writes_nothing(tmp_path, capsys):
    (tmp_path / "p.csv").write_text(POSES)
    out = tmp_path / "out.csv"
    argv = ["convert", str(tmp_path / "p.csv"), str(out), "--scenario", "boyd2"]
    assert main([*argv, "--start-time=100"]) == 2  # every pose before step 0: the flag's
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"mirl convert: error: {tmp_path / 'p.csv'}: nothing to convert: --start-time 100 s is "
        "after every pose (the last at t = 2 s)"
    ]
    # a start within the poses whose steps none lies near: the reason, counted
    assert main([*argv, "--start-time=0.5", "--step-seconds=2", "--tolerance=0.1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nothing to convert: none of its 2 poses was placed" in err[0]
    assert "dropped 2 no step within the tolerance" in err[0] and "--start-time" not in err[0]
    assert not out.exists()
    assert main(argv) == 0 and out.read_text().count("\n") == 3


def test_learning_from_poses_none_of_which_is_placed_says_why(tmp_path, capsys):
    """`learn` said "no observations (a header and no rows)" of a pose file whose rows a late
    --start-time had all left before step 0; it now names the flag and the last pose's time,
    as `convert` does, and says why by the drops when the start is not after every pose."""
    (tmp_path / "p.csv").write_text(POSES)
    for argv in (["learn", "--scenario", "boyd2"], ["learn-transitions", "--scenario", "boyd2"]):
        code = main([*argv, "--observations", str(tmp_path / "p.csv"), "--start-time=100"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and "header and no rows" not in err[0]
        assert err[0].endswith(
            "p.csv: nothing to learn from: --start-time 100 s is after every pose (the last at "
            "t = 2 s)"
        )
        late = ["--start-time=0.5", "--step-seconds=2", "--tolerance=0.1"]
        code = main([*argv, "--observations", str(tmp_path / "p.csv"), *late])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1
        assert "nothing to learn from: none of its 2 poses was placed" in err[0]


def test_a_start_time_after_every_pose_of_a_bag_names_the_flag(tmp_path, capsys):
    """An MCAP's last read pose bounds --start-time as a pose CSV's does, for `learn` and
    `convert`; the unread topic is not counted in the last pose's time."""
    mcap = tmp_path / "p.mcap"
    assert main(["simulate", "--scenario", "boyd2", "--steps", "30", "--seed", "1",
                 "--poses", str(mcap)]) == 0  # fmt: skip
    capsys.readouterr()
    from mirl.observations.bags import read_bag

    last = float(read_bag(mcap, {"/I/pose": "I"}).t.max())
    flags = ["--topic", "/I/pose=I", "--start-time", "1e5"]
    for argv in (
        ["learn", "--scenario", "boyd2", "--observations", str(mcap)],
        ["convert", str(mcap), str(tmp_path / "o.csv"), "--scenario", "boyd2"],
    ):
        assert main([*argv, *flags]) == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]  # after the left-out warning
        assert err.endswith(
            f"p.mcap: nothing to {'convert' if argv[0] == 'convert' else 'learn from'}: "
            f"--start-time 100000 s is after every pose (the last at t = {last:g} s)"
        )


def test_a_bag_in_capitals_is_told_as_a_bag(tmp_path, capsys):
    # it was read as a CSV; rosbags picks the storage by the suffix as written, so the one
    # line says to rename it, and the renamed file reads
    from tests.helpers.bags import pose_message, typestore, write_bag

    ts = typestore(False)
    recs = [("/i", 100.0 + k, pose_message(ts, "stamped", 100.0 + k, 4.0 - k, 0.0, 3.14159))
            for k in range(3)]  # fmt: skip
    shutil.move(write_bag(tmp_path / "p.bag", recs, fmt="ros1"), tmp_path / "P.BAG")
    flags = ["--scenario", "boyd2", "--topic", "/i=I", "--step-seconds", "1"]
    assert main(["convert", str(tmp_path / "P.BAG"), str(tmp_path / "o.csv"), *flags]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rename it to P.bag" in err[0], err
    shutil.move(tmp_path / "P.BAG", tmp_path / "P.bag")
    assert main(["convert", str(tmp_path / "P.bag"), str(tmp_path / "o.csv"), *flags]) == 0
    assert (tmp_path / "o.csv").read_text().count("\n") == 4


def test_observed_rows_where_l_sees_nothing(tmp_path, capsys):
    obs = tmp_path / "g.csv"
    assert main(["simulate", "--scenario", "boyd2", "--steps", "120", "--seed", "1",
                 "--observations", str(obs)]) == 0  # fmt: skip
    capsys.readouterr()
    learn = ["learn", "--scenario", "boyd2", "--observations", str(obs), "--method", "mirl"]
    assert main([*learn, "--observability", "0"]) == 2  # was learned from, as if unseen
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--observability 0: L sees no cell" in err[0], err
    assert main([*learn, "--observability", "0.05"]) == 0  # rows outside the view: one warning
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lie on cells L cannot see at observability 0.05" in err[0], err
    assert main(learn) == 0  # recorded at the scenario's 0.14: all in view, no warning
    assert capsys.readouterr().err == ""


CELLS = ["0", "1", "4", "-1", "2.5", "nan", "inf", "1e300", " 3", "I", "J", "K", "", "\u0663",
         "6_0", "+2", "0x1f", "9" * 30, '"3"']  # fmt: skip
HEADERS = [
    ["t", "robot", "row", "col", "heading"],
    ["t", "robot", "x", "y", "yaw"],
    ["t", "robot", "x", "y", "qz", "qw"],
]


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    header=st.sampled_from(HEADERS),
    extra=st.sampled_from([None, "t", "x", "row", "extra"]),
    rows=st.lists(st.lists(st.sampled_from(CELLS), min_size=4, max_size=7), max_size=5),
    end=st.sampled_from(["\n", "", "\r\n"]),
)
def test_any_hostile_csv_converts_or_is_one_line(tmp_path, header, extra, rows, end):
    # a property over hostile cells, short and long rows and repeated columns: convert either
    # works or says one line with exit code 2 (no traceback, no warning before it)
    head = header + ([extra] if extra else [])
    path, out = tmp_path / "f.csv", tmp_path / "o.csv"
    path.write_text("\n".join([",".join(head)] + [",".join(r) for r in rows]) + end, "utf-8")
    out.unlink(missing_ok=True)
    err = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stderr(err):
        warnings.simplefilter("error")
        with contextlib.redirect_stdout(io.StringIO()):
            code = main(["convert", str(path), str(out), "--scenario", "boyd2"])
    lines = err.getvalue().strip().splitlines()
    assert code == 0 or (code == 2 and len(lines) == 1 and "f.csv" in lines[0]), err.getvalue()
    assert code == 2 or out.exists()


PNG = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256))  # a figure given by mistake


@pytest.mark.parametrize(
    "argv",
    [
        ["learn", "--scenario", "boyd2", "--observations", "{f}"],
        ["learn-transitions", "--scenario", "boyd2", "--observations", "{f}"],
        ["convert", "{f}", "{d}/grid.csv", "--scenario", "boyd2"],
    ],
    ids=lambda argv: argv[0],
)
def test_a_file_that_is_not_text_is_answered_with_the_formats_mirl_reads(tmp_path, capsys, argv):
    path = tmp_path / "run.png"
    path.write_bytes(PNG)
    code = main([a.format(f=path, d=tmp_path) for a in argv])
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2 and not out and len(lines) == 1, err
    assert str(path) in lines[0] and "not a file of observations mirl reads" in lines[0]
    assert "grid CSV" in lines[0] and "pose CSV" in lines[0] and ".mcap" in lines[0]
    assert "codec" not in lines[0]
    assert "line 1" not in lines[0]  # an image has no lines


def test_the_csv_readers_say_a_file_is_not_text(tmp_path):
    from mirl.observations.poses import PoseError, read_pose_csv
    from mirl.observations.trajectories import TrajectoryError, read_csv

    path = tmp_path / "run.png"
    path.write_bytes(PNG)
    domain = load_scenario("boyd2").domain
    for read, error in ((read_pose_csv, PoseError), (lambda p: read_csv(p, domain, ("I",)),
                                                      TrajectoryError)):  # fmt: skip
        with pytest.raises(error, match=r"run.png: .*not UTF-8 text \(byte 0x89") as e:
            read(path)
        assert "codec" not in str(e.value)
