"""The table of input formats: every file kind is recognised by one row, and a file none
recognises is refused in one line that lists them."""

from __future__ import annotations

import json

import pytest

from mirl.observations.sources import FORMATS, ROBOT_DATA_KINDS, input_format
from mirl.observations.trajectories import TrajectoryError


def test_each_format_recognises_its_files(tmp_path):
    grid = tmp_path / "g.csv"
    grid.write_text("t,robot,row,col,heading\n0,I,0,1,0\n")
    pose = tmp_path / "p.csv"
    pose.write_text("t,robot,x,y,yaw\n0,I,0.0,1.0,0.0\n")
    assert input_format(grid).name == "grid-csv" and not input_format(grid).robot_data
    assert input_format(pose).name == "pose-csv" and input_format(pose).robot_data
    assert set(ROBOT_DATA_KINDS) == {f.name for f in FORMATS.values() if f.robot_data}


def test_a_csv_is_recognised_by_its_header_whatever_bytes_its_rows_hold(tmp_path):
    """A byte that is not UTF-8 on a later line (a name in Latin-1) is that line's problem:
    the file is still told by its header, and the reader names the line (not "not a file of
    observations", nor "line 1"); one in the header makes the file no CSV."""
    from mirl.observations.poses import PoseError, read_pose_csv

    pose = tmp_path / "p.csv"
    pose.write_bytes(b"t,robot,x,y,yaw\n0,I,0.0,1.0,0.0\n1,J\xfc,0.0,1.0,0.0\n")
    grid = tmp_path / "g.csv"
    grid.write_bytes(b"t,robot,row,col,heading\n0,I,0,1,0\n1,J\xfc,0,1,0\n")
    assert input_format(pose).name == "pose-csv" and input_format(grid).name == "grid-csv"
    with pytest.raises(PoseError, match=r"p.csv: line 3: not UTF-8 text \(byte 0xfc at offset"):
        read_pose_csv(pose)
    header = tmp_path / "h.csv"
    header.write_bytes(b"t,robot,x,y,yaw\xff\n0,I,0.0,1.0,0.0\n")
    with pytest.raises(TrajectoryError, match="not a file of observations mirl reads"):
        input_format(header)


def test_a_file_no_format_recognises_is_refused_naming_them_all(tmp_path):
    other = tmp_path / "o.csv"
    other.write_text("time,who,where\n0,I,1\n")
    with pytest.raises(TrajectoryError) as err:
        input_format(other)
    message = str(err.value)
    assert str(other) in message and all(f.description in message for f in FORMATS.values())


def test_the_formats_are_a_table_tried_in_order():
    from mirl._registry import Registry

    assert isinstance(FORMATS, Registry)
    assert FORMATS.names == ("bag", "grid-csv", "pose-csv")  # a bag first: it has no header
    assert FORMATS["pose-csv"].robot_data and not FORMATS["grid-csv"].robot_data


@pytest.fixture(scope="module")
def team_poses(tmp_path_factory):
    """A pose CSV of boyd2's I and J (grid world, full view), and the same poses under a
    tracker's names with a third robot the scenario does not have."""
    from mirl.cli import main

    d = tmp_path_factory.mktemp("poses")
    plain = d / "p.csv"
    assert main(["simulate", "--scenario", "boyd2", "--steps", "120", "--seed", "4",
                 "--observability", "1", "--observations", str(d / "o.csv"),
                 "--poses", str(plain)]) == 0  # fmt: skip
    lines = plain.read_text().splitlines()
    renamed = [lines[0]]
    for line in lines[1:]:
        t, robot, rest = line.split(",", 2)
        renamed.append(f"{t},tb_{robot.lower()},{rest}")
        if robot == "J":
            renamed.append(f"{t},person,{rest}")
    tracker = d / "tracker.csv"
    tracker.write_text("\n".join(renamed) + "\n")
    n_j = sum(1 for line in lines[1:] if line.split(",")[1] == "J")
    return plain, tracker, n_j


def test_topics_on_a_pose_csv_read_the_robots_they_name_as_on_a_bag(team_poses):
    """``topics`` on a pose CSV reads the named robots under their scenario names, exactly as
    the file with those names would be read, and counts the poses of the robots left out."""
    from mirl.observations.sources import load_observations
    from mirl.world.scenario import load_scenario

    plain, tracker, n_j = team_poses
    sc = load_scenario("boyd2")
    want = load_observations(plain, sc)
    got = load_observations(tracker, sc, topics={"tb_i": "I", "tb_j": "J"})
    assert got.trajectories.robot_names == want.trajectories.robot_names == sc.robot_names
    for i in range(len(sc.robot_names)):
        assert (got.trajectories.state_series(sc.domain, i)
                == want.trajectories.state_series(sc.domain, i)).all()  # fmt: skip
    assert dict(got.left_out) == {"person": n_j} and not want.left_out
    only_i = load_observations(tracker, sc, topics={"tb_i": "I"})
    assert dict(only_i.left_out) == {"tb_j": n_j, "person": n_j}
    traj = only_i.trajectories
    assert (traj.state_series(sc.domain, traj.robot_names.index("J")) == -1).all()


def test_a_pose_csv_robot_outside_the_scenario_or_topics_is_refused_in_one_line(team_poses):
    from mirl.observations.poses import PoseError
    from mirl.observations.sources import load_observations
    from mirl.world.scenario import load_scenario

    _, tracker, _ = team_poses
    sc = load_scenario("boyd2")
    with pytest.raises(PoseError, match="robot 'tb_i' is not in the scenario"):
        load_observations(tracker, sc)
    with pytest.raises(PoseError, match="no robot 'tb_k' in the file"):
        load_observations(tracker, sc, topics={"tb_i": "I", "tb_k": "J"})
    # a robot the scenario lacks is named as the mapping's, as a bag's topic's (it asked for
    # `tb_k=ROBOT`, pointing at the file's robots)
    with pytest.raises(PoseError, match=r"`topics` tb_i=K: robot 'K' is not in the scenario \("):
        load_observations(tracker, sc, topics={"tb_i": "K"})


def test_mirl_learn_says_which_robots_of_a_pose_csv_its_topics_left_out(team_poses, capsys):
    from mirl.cli import main

    plain, tracker, n_j = team_poses
    assert main(["learn", "--scenario", "boyd2", "--observations", str(plain), "--json"]) == 0
    want = capsys.readouterr()
    code = main(["learn", "--scenario", "boyd2", "--observations", str(tracker), "--json",
                 "--topic", "tb_i=I", "--topic", "tb_j=J"])  # fmt: skip
    got = capsys.readouterr()
    assert code == 0 and not want.err
    assert got.err.count("mirl: warning:") == 1
    assert f"not read, as no --topic names them: person ({n_j} poses)" in got.err
    assert _but_path_and_times(got.out) == _but_path_and_times(want.out)


def test_an_observability_the_visible_cells_override_is_refused(team_poses, capsys):
    # with visible given, the degree would change nothing but the report's label
    from mirl.cli import main
    from mirl.observations.sources import load_observations
    from mirl.world.scenario import load_scenario

    plain, _, _ = team_poses
    sc = load_scenario("boyd2")
    with pytest.raises(ValueError, match="^`observability` sets the cells L could see, and "):
        load_observations(plain, sc, visible="observed", observability=0.5)
    assert load_observations(plain, sc, visible="observed").discretised is not None
    code = main(["learn", "--scenario", "boyd2", "--observations", str(plain),
                 "--visible", "observed", "--observability", "0.5"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "--observability sets the cells L could see, and --visible gives them" in err


def _but_path_and_times(out: str) -> dict:
    return {k: v for k, v in json.loads(out).items() if k not in ("observations", "timings")}


def test_a_bag_s_pose_topics_no_topic_names_are_said_not_dropped(tmp_path, capsys):
    """An MCAP of two robots read with one --topic: the other robot's pose topic was left
    unread without a word (a pose CSV's robots were said); now `learn` and `convert` name it
    with its messages, and naming both topics says nothing."""
    from mirl.cli import main
    from mirl.observations.bags import bag_topics
    from mirl.observations.sources import load_observations
    from mirl.world.scenario import load_scenario

    mcap = tmp_path / "p.mcap"
    assert main(["simulate", "--scenario", "boyd2", "--steps", "300", "--seed", "1",
                 "--poses", str(mcap)]) == 0  # fmt: skip
    n_j = bag_topics(mcap)["/J/pose"][1]
    assert n_j > 0
    got = load_observations(mcap, load_scenario("boyd2"), topics={"/I/pose": "I"})
    assert dict(got.left_out) == {"/J/pose": n_j}
    capsys.readouterr()
    both = ["--topic", "/I/pose=I", "--topic", "/J/pose=J"]
    learn = ["learn", "--scenario", "boyd2", "--observations", str(mcap)]
    convert = ["convert", str(mcap), str(tmp_path / "o.csv"), "--scenario", "boyd2"]
    for argv in (learn, convert):
        assert main([*argv, "--topic", "/I/pose=I"]) == 0
        err = capsys.readouterr().err
        assert f"not read, as no --topic names them: /J/pose ({n_j} poses)" in err
        assert main([*argv, *both]) == 0
        assert "not read" not in capsys.readouterr().err
