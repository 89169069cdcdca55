"""``mirl convert``, ``--observations`` of any kind, ``simulate --poses`` and the round trip
simulate → MCAP poses → learn; bad robot data ends in one line on stderr and exit code 2."""

from __future__ import annotations

import json
import math
import re

import pytest

from mirl.cli import main
from tests.helpers.bags import pose_message, typestore, write_bag
from tests.observations.test_bags import EXPECTED, records

TOPIC_ARGS = ["--topic", "/tb_i/amcl_pose=I", "--topic", "/tb_j/odom=J"]


def one_error_line(capsys, code, *needles):
    out, err = capsys.readouterr()
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert re.match(r"mirl [a-z-]+: error: ", lines[0]), lines[0]  # names the sub-command
    for n in needles:
        assert str(n) in lines[0], (n, lines[0])


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_convert_hand_built_bag(tmp_path, capsys, fmt):
    bag = write_bag(tmp_path / ("b.bag" if fmt == "ros1" else "b"), records(fmt != "ros1"), fmt=fmt)
    out = tmp_path / "grid.csv"
    code = main(["convert", str(bag), str(out), "--scenario", "boyd2", *TOPIC_ARGS])
    text = capsys.readouterr().out
    assert code == 0
    # too few moves to tell the robots' pace: the paper's 2 s, and the summary says so
    assert (
        "7 steps of 2 s from t = 100.000 s (tolerance 1 s, the paper's 2 s: the robots were not "
        "seen moving enough to tell their pace); 4 cells visible to L" in text
    )
    assert (
        "I: 6 poses read, 6 binned, 1 snapped, 5 steps observed, 3 outside L's visible cells; "
        "dropped: 1 duplicate of a step (the nearest kept)" in text
    )
    assert "J: 4 poses read, 4 binned, 0 snapped, 4 steps observed" in text
    rows = [line.split(",") for line in out.read_text().splitlines()[1:]]
    got = [(int(t), "IJ".index(r), int(a), int(b), int(h)) for t, r, a, b, h in rows]
    assert got == EXPECTED
    # --start-time earlier than the first pose: L watched before any robot was seen
    main(["convert", str(bag), str(out), "--scenario", "boyd2", *TOPIC_ARGS])
    code = main(
        ["convert", str(bag), str(out), "--scenario", "boyd2", *TOPIC_ARGS, "--start-time", "96"]
    )
    assert code == 0 and out.read_text().splitlines()[1].startswith("2,I,0,8,2")


def test_simulate_poses_and_round_trip_json(tmp_path, capsys):
    """One seed here; five seeds and the pose noise are measured in bench_robot_data.py."""
    d = tmp_path
    sim = ["simulate", "--scenario", "boyd2", "--steps", "300", "--seed", "4"]
    sim += ["--observability", "0.5", "--observations", str(d / "o.csv")]
    assert main([*sim, "--poses", str(d / "p.mcap"), "--pose-rate", "15"]) == 0
    assert main([*sim, "--poses", str(d / "p.csv"), "--pose-noise", "0.05", "3"]) == 0
    assert "noise 0.05 m / 3 deg" in capsys.readouterr().out
    learn = ["learn", "--scenario", "boyd2", "--observability", "0.5", "--json"]
    learn += ["--max-iterations", "2"]
    results = []
    for extra in (
        ["--observations", str(d / "o.csv")],
        ["--observations", str(d / "p.mcap"), "--topic", "/I/pose=I", "--topic", "/J/pose=J"],
        ["--observations", str(d / "p.csv")],
    ):
        # poses simulated from the scenario: their truth is the scenario's, if asked for
        start = ["--start-time", "0", "--compare", "truth"] if "o.csv" not in extra[1] else []
        assert main([*learn, *extra, *start]) == 0
        res = json.loads(capsys.readouterr().out)
        for key in ("observations", "timings"):
            res.pop(key)
        results.append(res)
    # poses also say where in its cell a robot drove (the lateral drift the verdicts weigh):
    # these, simulated at the cells' centres, drift by no more than their noise
    drifts = [{n: r.pop("lateral_drift", None) for n, r in res["robots"].items()}
              for res in results]  # fmt: skip
    assert drifts[0] == {"I": None, "J": None}
    for drift in drifts[1:]:
        found = [d for d in drift.values() if d is not None]  # None: < 5 forward steps seen
        assert found and all(abs(d["mean"]) <= 2 * d["se"] + 0.01 for d in found)

    # read at the robots' own pace, which is the simulation's 2 s
    assert all(res.pop("step_seconds") == 2.0 for res in results[1:])
    assert all("the robots' pace" in res.pop("step_chosen") for res in results[1:])
    # and say, as the text summary does, what became of every pose: each step L saw is one
    rows = len((d / "o.csv").read_text().splitlines()) - 1
    for res in results[1:]:
        counts = res.pop("poses")
        assert sum(c["observed_steps"] for c in counts.values()) == rows
        for c in counts.values():
            assert c["read"] == c["observed_steps"] + sum(c["dropped"].values())

    # everything learned from grid states is the same from poses (the posterior weighs the
    # drift too)
    posterior = ("feature_intervals", "feature_medians", "motion_models", "verdict")

    def states_only(res):
        return {
            **res,
            "robots": {
                n: {k: v for k, v in r.items() if k not in posterior}
                for n, r in res["robots"].items()
            },
        }  # noqa: E501

    assert states_only(results[1]) == states_only(results[0])
    # 5 cm / 3 degrees never moves a pose to another cell
    assert states_only(results[2]) == states_only(results[0])
    # robot data is not compared with a truth unless asked: scored on the observed moves
    assert main([*learn, "--observations", str(d / "p.csv"), "--start-time", "0"]) == 0
    robot = json.loads(capsys.readouterr().out)["robots"]["I"]
    assert robot["behavior_accuracy"] is None
    moves = robot["observed_moves"]
    assert 0 < moves["followed"] <= moves["moves"] and moves["unexplained"] >= 0


def test_learn_transitions_from_pose_csv(tmp_path, capsys):
    sim = ["simulate", "--scenario", "boyd2", "--steps", "200", "--seed", "1"]
    assert main([*sim, "--observations", str(tmp_path / "o.csv")]) == 0
    assert main([*sim, "--poses", str(tmp_path / "p.csv")]) == 0
    capsys.readouterr()
    base = ["learn-transitions", "--scenario", "boyd2", "--json", "--observations"]
    assert main([*base, str(tmp_path / "o.csv")]) == 0
    a = json.loads(capsys.readouterr().out)
    assert main([*base, str(tmp_path / "p.csv"), "--start-time", "0"]) == 0
    got = capsys.readouterr()
    assert json.loads(got.out) == a
    # the poses' summary (the step chosen, the poses dropped) is said, on stderr beside JSON
    assert got.err.startswith(f"{tmp_path / 'p.csv'}: 190 steps of 2 s from t = 0.000 s")
    assert main(base[:-2] + ["--observations", str(tmp_path / "p.csv")]) == 0
    out = capsys.readouterr().out
    assert "  I: " in out and "poses read" in out and "dropped: " in out


def test_damage_on_robot_data_only_where_learning_reads_the_truth(tmp_path, capsys):
    """Robot data is scored against the observed moves: --damage (the truth) changes what
    learn says only with --compare truth or with known-r-t (its labels are the true
    policies'); anywhere else it is refused in one line."""
    sim = ["simulate", "--scenario", "boyd2", "--steps", "60", "--seed", "1"]
    poses = str(tmp_path / "p.csv")
    assert main([*sim, "--observability", "1", "--poses", poses]) == 0
    capsys.readouterr()
    learn = ["learn", "--scenario", "boyd2", "--observations", poses, "--start-time", "0",
             "--observability", "1", "--json"]  # fmt: skip
    damage = ["--damage", "J:left_wheel=0.3"]
    for method in ("mirl-t", "mirl", "known-r", "dbn-em"):
        one_error_line(capsys, main([*learn, "--method", method, *damage]),
                       "mirl learn: error: --damage J:left_wheel=0.3: changes nothing here: "
                       f"{method} reads no truth", "--compare truth")  # fmt: skip
    one_error_line(capsys, main([*learn, "--compare", "observed", "--method", "known-r",
                                 *damage]), "changes nothing here")  # fmt: skip
    for extra in (["--method", "known-r", "--compare", "truth"], ["--method", "known-r-t"]):
        assert main([*learn, *extra]) == 0
        plain = json.loads(capsys.readouterr().out)
        assert main([*learn, *extra, *damage]) == 0
        damaged = json.loads(capsys.readouterr().out)
        assert damaged["robots"] != plain["robots"], extra  # it does change what learn says


def test_bad_robot_data_one_line_exit_2(tmp_path, capsys):
    bag = write_bag(tmp_path / "b", records(True), fmt="mcap")
    base = ["convert", str(bag), str(tmp_path / "o.csv"), "--scenario", "boyd2"]
    one_error_line(capsys, main([*base, "--topic", "/nope=I"]), bag, "/nope", "not in the bag")
    one_error_line(
        capsys, main([*base, "--topic", "/tb_i/scan=I"]), bag, "/tb_i/scan", "unsupported"
    )
    one_error_line(capsys, main([*base, "--topic", "/tb_i/amcl_pose=K"]), "/tb_i/amcl_pose", "'K'")
    one_error_line(capsys, main(base), bag, "--topic TOPIC=ROBOT", "/tb_j/odom")
    one_error_line(capsys, main([*base, "--topic", "nonsense"]), "expected TOPIC=ROBOT")
    # a truncated bag
    data = next(bag.glob("*.mcap"))
    data.write_bytes(data.read_bytes()[:300])
    one_error_line(capsys, main([*base, *TOPIC_ARGS]), bag, "cannot read bag")
    # NaN and time going backwards within a topic (ROS 1)
    ts = typestore(False)
    nan = [
        ("/p", t, pose_message(ts, "stamped", t, math.nan if t == 2 else 1.0, 0, 0))
        for t in (1.0, 2.0)
    ]
    bag1 = write_bag(tmp_path / "nan.bag", nan, fmt="ros1")
    args = ["convert", str(bag1), str(tmp_path / "o.csv"), "--scenario", "boyd2"]
    one_error_line(capsys, main([*args, "--topic", "/p=I"]), bag1, "topic /p", "NaN")
    back = [
        ("/p", log, pose_message(ts, "stamped", t, 1.0, 0, 0))
        for t, log in ((2.0, 1.0), (1.0, 2.0))
    ]
    bag2 = write_bag(tmp_path / "back.bag", back, fmt="ros1")
    args = ["convert", str(bag2), str(tmp_path / "o.csv"), "--scenario", "boyd2"]
    one_error_line(capsys, main([*args, "--topic", "/p=I"]), bag2, "topic /p", "backwards")
    # a pose far off the hallway, and the explicit way to drop it
    csv = tmp_path / "p.csv"
    csv.write_text("t,robot,x,y,yaw\n0,I,1,0,0\n2,I,5,-5,0\n")
    args = ["convert", str(csv), str(tmp_path / "o.csv"), "--scenario", "boyd2"]
    one_error_line(capsys, main(args), csv, "robot I", "more than 0.5 cell")
    assert main([*args, "--drop-off-map"]) == 0
    assert "I: 2 poses read, 2 binned, 0 snapped, 1 steps observed; dropped: 1 off-map" in (
        capsys.readouterr().out
    )
    sim = ["simulate", "--scenario", "boyd2", "--steps", "5", "--poses", str(tmp_path / "s.bag")]
    one_error_line(capsys, main(sim), "s.bag", "ROS 1 bags are read, not written")
    # pose options on a grid CSV are an error, not ignored
    grid = tmp_path / "g.csv"
    grid.write_text("t,robot,row,col,heading\n0,I,0,8,2\n")
    learn = ["learn-transitions", "--scenario", "boyd2", "--observations", str(grid)]
    one_error_line(capsys, main([*learn, "--step-seconds", "1"]), grid, "--step-seconds")
    one_error_line(capsys, main([*learn[:-1], str(tmp_path / "x.txt")]), "x.txt")


def test_a_pose_csv_with_yaws_in_degrees_is_refused_in_one_line(tmp_path, capsys):
    sim = ["simulate", "--scenario", "boyd2", "--steps", "200", "--seed", "1"]
    assert main([*sim, "--observability", "1", "--poses", str(tmp_path / "p.csv")]) == 0
    lines = (tmp_path / "p.csv").read_text().splitlines()
    head = lines[0].split(",")
    assert head == ["t", "robot", "x", "y", "yaw"]
    rows = [line.split(",") for line in lines[1:]]
    degrees = [",".join([*r[:4], repr(math.degrees(float(r[4])))]) for r in rows]
    (tmp_path / "deg.csv").write_text("\n".join([lines[0], *degrees]) + "\n")
    capsys.readouterr()
    learn = ["learn", "--scenario", "boyd2", "--start-time", "0", "--observations"]
    assert main([*learn, str(tmp_path / "p.csv")]) == 0
    capsys.readouterr()
    code = main([*learn, str(tmp_path / "deg.csv")])
    one_error_line(capsys, code, "deg.csv", "read as degrees: give yaw in radians")


def test_learn_on_the_observed_cells_reports_that_view_not_the_degree(tmp_path, capsys):
    poses = str(tmp_path / "p.csv")
    assert main(["simulate", "--scenario", "boyd2", "--steps", "200", "--seed", "1",
                 "--poses", poses]) == 0  # fmt: skip
    capsys.readouterr()
    learn = ["learn", "--scenario", "boyd2", "--observations", poses, "--start-time", "0"]
    assert main([*learn, "--visible", "observed", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["visible"] == "observed"
    assert out["observability"] == pytest.approx(4 / 31)  # the 4 cells seen, not the 0.14 given
    assert main([*learn, "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert plain["observability"] == 0.14 and "visible" not in plain
    assert main([*learn, "--visible", "observed"]) == 0
    assert "L's view: the cells the robots were observed on, 0.129 of the hallway" in (
        capsys.readouterr().out
    )
