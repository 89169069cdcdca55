"""ROS bags built by hand (ROS 1, ROS 2 sqlite3, ROS 2 MCAP): known poses with a gap, a pose on
a wall, an out-of-order log time and a topic of another type, checked step by step; and every
kind of bad bag gives one line naming the file and topic."""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from mirl.observations.bags import BagError, bag_topics, read_bag, write_mcap
from mirl.observations.discretise import discretise
from mirl.observations.poses import PoseTracks
from mirl.world.scenario import load_scenario
from tests.helpers.bags import pose_message, string_message, typestore, write_bag

TOPICS = {"/tb_i/amcl_pose": "I", "/tb_j/odom": "J"}
PI = math.pi

# boyd2, default frame: the centre of cell (row, col) is x = col, y = -row
# robot I (AMCL): (stamp, x, y, yaw)
I_POSES = [
    (100.0, 8.0, 0.0, PI),  # step 0: (0, 8) west
    (102.3, 7.0, 0.0, PI + 0.3),  # step 1: (0, 7) west (yaw wraps)
    # steps 2 and 3: gap (tracker lost I)
    (108.1, 5.0, -0.8, PI),  # step 4: on the wall cell (1, 5), 0.3 cell from (0, 5): snaps
    (109.5, 4.0, 0.0, PI),  # step 5 candidate, 0.5 s off
    (110.2, 3.0, 0.0, PI),  # step 5: nearest (0.2 s off) -> (0, 3)
    (111.1, 2.0, 0.0, -PI / 2 + 0.1),  # step 6 (0.9 s off): (0, 2) south
]
# robot J (Odometry): (stamp, x, y, yaw, log time)
J_POSES = [
    (100.4, 1.0, -16.0, 0.0, 100.4),  # step 0: (16, 1) east
    (101.6, 2.0, -16.0, 0.0, 103.5),  # step 1: logged late, after I's 102.3 (out of order)
    (104.0, 3.0, -16.0, PI / 2, 104.0),  # step 2: (16, 3) north
    # steps 3, 4, 5: gap
    (112.0, 4.05, -15.9, -0.2, 112.0),  # step 6: (16, 4) east
]
EXPECTED = [  # t, robot, row, col, heading
    (0, 0, 0, 8, 2),
    (0, 1, 16, 1, 0),
    (1, 0, 0, 7, 2),
    (1, 1, 16, 2, 0),
    (2, 1, 16, 3, 1),
    (4, 0, 0, 5, 2),
    (5, 0, 0, 3, 2),
    (6, 0, 0, 2, 3),
    (6, 1, 16, 4, 0),
]


def records(ros2: bool, *, i_kind="amcl", j_kind="odom"):
    ts = typestore(ros2)
    recs = [("/tb_i/amcl_pose", t, pose_message(ts, i_kind, t, x, y, a)) for t, x, y, a in I_POSES]
    recs += [
        ("/tb_j/odom", log, pose_message(ts, j_kind, t, x, y, a)) for t, x, y, a, log in J_POSES
    ]
    recs += [("/tb_i/scan", 100.0 + k, string_message(ts, f"scan {k}")) for k in range(3)]
    return sorted(recs, key=lambda r: r[1])


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("boyd2")


FORMATS = ["ros1", "sqlite3", "mcap"]


def bag_path(tmp_path, fmt):
    return tmp_path / ("poses.bag" if fmt == "ros1" else f"poses_{fmt}")


@pytest.fixture(scope="module", params=FORMATS)
def bag(request, tmp_path_factory):
    fmt = request.param
    path = bag_path(tmp_path_factory.mktemp(fmt), fmt)
    return write_bag(path, records(fmt != "ros1"), fmt=fmt)


@pytest.mark.parametrize("decode", ["fast", "rosbags"])
def test_hand_built_bag_every_step(bag, scenario, decode):
    tracks = read_bag(bag, TOPICS, robot_names=scenario.robot_names, decode=decode)
    assert tracks.robot_names == ("I", "J")
    # header stamps, not log times: J's late message keeps its stamp and order
    np.testing.assert_allclose(tracks.t[tracks.robot == 1], [p[0] for p in J_POSES], atol=1e-9)
    np.testing.assert_allclose(tracks.x[tracks.robot == 0], [p[1] for p in I_POSES])
    np.testing.assert_allclose(tracks.y[tracks.robot == 1], [p[2] for p in J_POSES])
    yaw = tracks.yaw[tracks.robot == 0]
    np.testing.assert_allclose(np.cos(yaw), [math.cos(p[3]) for p in I_POSES], atol=1e-12)
    np.testing.assert_allclose(np.sin(yaw), [math.sin(p[3]) for p in I_POSES], atol=1e-12)

    d = discretise(tracks, scenario)
    tr = d.trajectories
    assert d.start_time == pytest.approx(100.0)
    assert tr.horizon == 7
    got = list(
        zip(*(a.tolist() for a in (tr.t, tr.robot, tr.row, tr.col, tr.heading)), strict=True)
    )
    assert got == EXPECTED
    # the gaps stay unobserved: no interpolation
    series_i = tr.state_series(scenario.domain, 0)
    series_j = tr.state_series(scenario.domain, 1)
    assert (series_i[[2, 3]] == -1).all() and (series_j[[3, 4, 5]] == -1).all()
    i, j = d.report
    assert (i.read, i.binned, i.snapped, i.dropped, i.observed_steps) == (6, 6, 1, 0, 5)
    assert (j.read, j.binned, j.snapped, j.dropped, j.observed_steps) == (4, 4, 0, 0, 4)


def test_a_pose_topic_no_topic_names_is_left_out_with_its_messages(bag, scenario):
    """In each bag format (ROS 1 names its types without /msg/), the pose topic no topic names
    is counted in `left_out`, an Odometry as a PoseWithCovarianceStamped; /tb_i/scan (strings)
    is not a robot and is not counted."""
    from mirl.observations.sources import load_observations

    got = load_observations(bag, scenario, topics={"/tb_i/amcl_pose": "I"})
    assert dict(got.left_out) == {"/tb_j/odom": len(J_POSES)}
    got = load_observations(bag, scenario, topics={"/tb_j/odom": "J"})
    assert dict(got.left_out) == {"/tb_i/amcl_pose": len(I_POSES)}
    assert dict(load_observations(bag, scenario, topics=TOPICS).left_out) == {}


def _odometry_bag(tmp_path, fmt: str, frame_of) -> Path:
    ts = typestore(fmt != "ros1")
    recs = []
    for k in range(40):
        _, msg = pose_message(ts, "odom", 50.0 + k * 0.1, 0.1 * k, -0.2 * k, 0.05 * k)
        msg.header.frame_id = frame_of(k)
        msg.child_frame_id = "b" * (k % 5)
        recs.append(("/o", 50.0 + k * 0.1, ("nav_msgs/msg/Odometry", msg)))
    folder = tmp_path / fmt
    folder.mkdir(parents=True)
    return write_bag(bag_path(folder, fmt), recs, fmt=fmt)


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_fast_decoding_matches_rosbags_with_varied_strings(tmp_path, fmt):
    # child frame ids of different lengths: messages of several lengths and pose offsets
    path = _odometry_bag(tmp_path, fmt, lambda k: "map")
    fast = read_bag(path, {"/o": "I"}, decode="fast")
    slow = read_bag(path, {"/o": "I"}, decode="rosbags")
    for f in ("t", "x", "y", "yaw"):
        np.testing.assert_array_equal(getattr(fast, f), getattr(slow, f))
    np.testing.assert_allclose(fast.x, 0.1 * np.arange(40))


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
@pytest.mark.parametrize("decode", ["fast", "rosbags"])
def test_a_topic_in_two_frames_is_refused(tmp_path, fmt, decode):
    # poses in 'map' and 'odom' cannot be placed on one map; both decoders see the frames
    # (frame ids of different lengths, and of the same length: 'map' / 'odo')
    for other in ("odom", "odo"):
        path = _odometry_bag(tmp_path / other, fmt, lambda k, o=other: o if k == 17 else "map")
        with pytest.raises(BagError, match=f"messages in 2 frames \\(map, {other}\\)"):
            read_bag(path, {"/o": "I"}, decode=decode)


def test_pose_stamped_topics_and_bag_topics(tmp_path):
    path = write_bag(tmp_path / "s", records(True, i_kind="stamped", j_kind="amcl"), fmt="mcap")
    topics = bag_topics(path)
    assert topics["/tb_i/amcl_pose"] == ("geometry_msgs/msg/PoseStamped", 6)
    assert topics["/tb_i/scan"][0] == "std_msgs/msg/String"
    tracks = read_bag(path, TOPICS)
    assert tracks.counts().tolist() == [6, 4]


def test_write_mcap_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    n = 500
    tracks = PoseTracks(
        ("I", "J"),
        np.sort(rng.uniform(0, 100, n)),
        rng.integers(0, 2, n),
        rng.normal(size=n),
        rng.normal(size=n),
        rng.uniform(-3, 3, n),
    ).sorted()
    for name in ("poses.mcap", "poses_dir"):
        path = tmp_path / name
        write_mcap(tracks, path)
        assert path.is_file() == name.endswith(".mcap")
        back = read_bag(path, {"/I/pose": "I", "/J/pose": "J"})
        np.testing.assert_allclose(back.t, tracks.t, atol=1e-9)  # nanosecond stamps
        np.testing.assert_array_equal(back.robot, tracks.robot)
        np.testing.assert_array_equal(back.x, tracks.x)
        np.testing.assert_allclose(back.yaw, tracks.yaw, atol=1e-12)
    with pytest.raises(BagError, match="exists already"):
        write_mcap(tracks, tmp_path / "poses.mcap")
    # a name read_bag would refuse is refused before anything is written
    with pytest.raises(BagError, match="lower-case suffix; name it more.mcap$"):
        write_mcap(tracks, tmp_path / "more.MCAP")
    assert not (tmp_path / "more.MCAP").exists()


# ---- bad data: one line naming the file and topic ------------------------------------------
def _one_line(exc_info, *parts):
    msg = str(exc_info.value)
    assert "\n" not in msg
    for p in parts:
        assert str(p) in msg, msg
    return msg


@pytest.mark.parametrize("fmt", FORMATS)
def test_missing_topic_and_unsupported_type(tmp_path, fmt):
    path = write_bag(bag_path(tmp_path, fmt), records(fmt != "ros1"), fmt=fmt)
    with pytest.raises(BagError) as e:
        read_bag(path, {"/tb_k/amcl_pose": "I"})
    _one_line(e, path, "/tb_k/amcl_pose", "not in the bag")
    with pytest.raises(BagError) as e:
        read_bag(path, {"/tb_i/scan": "I"})
    _one_line(e, path, "/tb_i/scan", "unsupported message type std_msgs/msg/String")
    with pytest.raises(BagError) as e:
        read_bag(path, {"/tb_i/amcl_pose": "K"}, robot_names=("I", "J"))
    _one_line(e, path, "/tb_i/amcl_pose", "robot 'K' is not in the scenario")


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_nan_pose_and_time_backwards(tmp_path, fmt):
    ts = typestore(fmt != "ros1")
    recs = [("/p", t, pose_message(ts, "amcl", t, 1.0, 0.0, 0.0)) for t in (1.0, 2.0, 3.0)]
    recs[1] = ("/p", 2.0, pose_message(ts, "amcl", 2.0, float("nan"), 0.0, 0.0))
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    path = write_bag(bag_path(tmp_path / "a", fmt), recs, fmt=fmt)
    with pytest.raises(BagError) as e:
        read_bag(path, {"/p": "I"})
    _one_line(e, path, "topic /p", "message 1", "NaN")
    # header stamps 1, 3, 2 logged in that order: time goes backwards within the topic
    recs = [
        ("/p", log, pose_message(ts, "amcl", t, 1.0, 0.0, 0.0))
        for t, log in ((1.0, 1.0), (3.0, 2.0), (2.0, 3.0))
    ]
    path = write_bag(bag_path(tmp_path / "b", fmt), recs, fmt=fmt)
    with pytest.raises(BagError) as e:
        read_bag(path, {"/p": "I"})
    _one_line(e, path, "topic /p", "goes backwards", "message 2")


@pytest.mark.parametrize("fmt", FORMATS)
def test_truncated_bag(tmp_path, fmt):
    path = write_bag(bag_path(tmp_path, fmt), records(fmt != "ros1"), fmt=fmt)
    data_file = path if path.is_file() else next(p for p in path.iterdir() if p.suffix != ".yaml")
    data = data_file.read_bytes()
    data_file.write_bytes(data[: len(data) // 2])
    with pytest.raises(BagError) as e:
        read_bag(path, TOPICS)
    _one_line(e, path)


def test_not_a_bag_and_missing_file(tmp_path):
    fake = tmp_path / "x.bag"
    fake.write_text("hello\n")
    with pytest.raises(BagError) as e:
        read_bag(fake, TOPICS)
    _one_line(e, fake, "cannot read bag")
    with pytest.raises(BagError) as e:
        read_bag(tmp_path / "none.mcap", TOPICS)
    _one_line(e, "none.mcap", "no such file")
    fake = tmp_path / "y.mcap"
    fake.write_bytes(b"\x89MCAP0\r\n" + b"\0" * 10)
    with pytest.raises(BagError) as e:
        read_bag(fake, TOPICS)
    _one_line(e, fake)


def test_bare_mcap_file_is_read(tmp_path):
    path = write_bag(tmp_path / "b", records(True), fmt="mcap")
    inner = next(path.glob("*.mcap"))
    bare = tmp_path / "copy.mcap"
    shutil.copy(inner, bare)
    assert read_bag(bare, TOPICS).counts().tolist() == [6, 4]


def test_a_bag_directory_is_read_whatever_its_name(tmp_path):
    """A ROS 2 bag directory is told by its metadata.yaml: a dot and capitals in its name are
    no suffix to rename (only a file's suffix tells rosbags its storage)."""
    path = write_bag(tmp_path / "b", records(True), fmt="mcap")
    named = path.rename(tmp_path / "patrol.RobotsIJ")
    assert read_bag(named, TOPICS).counts().tolist() == [6, 4]
    assert set(bag_topics(named)) == {"/tb_i/amcl_pose", "/tb_j/odom", "/tb_i/scan"}


def test_zero_quaternion_is_an_error(tmp_path):
    ts = typestore(True)
    recs = [("/p", t, pose_message(ts, "stamped", t, 1.0, 0.0, 0.0)) for t in (1.0, 2.0)]
    recs[1][2][1].pose.orientation.w = 0.0  # an orientation never filled in
    path = write_bag(tmp_path / "z", recs, fmt="mcap")
    with pytest.raises(BagError) as e:
        read_bag(path, {"/p": "I"})
    _one_line(e, path, "topic /p", "message 1", "zero quaternion")


def test_quaternion_far_past_unit_is_an_error(tmp_path):
    """A component of 1e300 is no orientation (its square overflowed into a warning before)."""
    ts = typestore(True)
    recs = [("/p", t, pose_message(ts, "stamped", t, 1.0, 0.0, 0.0)) for t in (1.0, 2.0)]
    recs[1][2][1].pose.orientation.w = 1e300
    path = write_bag(tmp_path / "q", recs, fmt="mcap")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(BagError) as e:
            read_bag(path, {"/p": "I"})
    _one_line(e, path, "topic /p", "message 1", "orientation component beyond")


@pytest.mark.parametrize("fmt", FORMATS)
def test_fast_path_is_taken(tmp_path, fmt, monkeypatch):
    """Only the first and last message of a topic go through rosbags' deserialiser."""
    import mirl.observations.bags as bags

    path = write_bag(bag_path(tmp_path, fmt), records(fmt != "ros1"), fmt=fmt)
    calls = []
    original = bags._decode_one

    def counting(reader, raw, msgtype):
        calls.append(msgtype)
        return original(reader, raw, msgtype)

    monkeypatch.setattr(bags, "_decode_one", counting)
    read_bag(path, TOPICS)
    assert len(calls) == 4  # 2 topics x (first, last)
    calls.clear()
    read_bag(path, TOPICS, decode="rosbags")
    assert len(calls) == 10


def test_unfilled_stamps_are_an_error(tmp_path):
    ts = typestore(False)
    recs = [("/p", 1.0 + k, pose_message(ts, "stamped", 0.0, 1.0, 0.0, 0.0)) for k in range(3)]
    path = write_bag(tmp_path / "z.bag", recs, fmt="ros1")
    with pytest.raises(BagError) as e:
        read_bag(path, {"/p": "I"})
    _one_line(e, path, "topic /p", "3 messages have header stamp 0")
