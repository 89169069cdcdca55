"""Robots read from a bag's transforms only (/tf, /tf_static), composed up to the map frame;
frames named in errors and mixing frames refused unless told how they relate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mirl.observations.bags import BagError, read_bag
from tests.helpers.bags import default_message, pose_message, typestore, write_bag

TF = "tf2_msgs/msg/TFMessage"


def _transform(ts, t, parent, child, x, y, yaw):
    tr = default_message(ts, "geometry_msgs/msg/TransformStamped")
    sec = math.floor(t)
    tr.header.stamp.sec, tr.header.stamp.nanosec = int(sec), int(round((t - sec) * 1e9))
    tr.header.frame_id, tr.child_frame_id = parent, child
    tr.transform.translation.x, tr.transform.translation.y = x, y
    tr.transform.rotation.z, tr.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return tr


def _tf_message(ts, transforms):
    msg = default_message(ts, TF)
    msg.transforms = transforms
    return TF, msg


def _records(ros2: bool, with_localiser: bool = True):
    """A robot driving along x in odom at 10 Hz; odom sits at (2, 1) turned 90° in map (the
    localiser's map -> odom at 1 Hz, or nothing); base_link -> laser static."""
    ts = typestore(ros2)
    recs = [
        ("/tf_static", 0.0, _tf_message(ts, [_transform(ts, 0.0, "base_link", "laser", 0.1, 0, 0)]))
    ]
    for k in range(51):
        t = 100.0 + 0.1 * k
        if with_localiser and k % 10 == 0:
            loc = _transform(ts, t, "map", "odom", 2.0, 1.0, math.pi / 2)
            recs.append(("/tf", t, _tf_message(ts, [loc])))
        odo = _transform(ts, t, "odom", "base_link", 0.2 * k, 0.0, 0.0)
        recs.append(("/tf", t, _tf_message(ts, [odo])))
    return recs


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_a_tf_only_bag_gives_the_robot_frame_in_the_map_frame(tmp_path, fmt):
    name = "b.bag" if fmt == "ros1" else "b"
    bag = write_bag(tmp_path / name, _records(fmt != "ros1"), fmt=fmt)
    tracks = read_bag(bag, {"/tf:base_link": "I"})
    assert len(tracks) == 51
    d = 0.2 * np.arange(51)
    # odom turned 90° at (2, 1): x along odom is +y in map
    np.testing.assert_allclose(tracks.x, 2.0, atol=1e-9)
    np.testing.assert_allclose(tracks.y, 1.0 + d, atol=1e-9)
    np.testing.assert_allclose(tracks.yaw, math.pi / 2, atol=1e-9)
    assert tracks.frames["I"] == "map via /tf from base_link"
    # a frame mounted on the robot (/tf_static) moves with it, at its mount's stamps
    laser = read_bag(bag, {"/tf:laser": "I"})
    assert laser.unplaced == {"I": 0} and len(laser) == 51
    np.testing.assert_allclose(laser.y, 1.0 + d + 0.1, atol=1e-9)


def test_only_pose_topics_are_said_left_out_not_other_tf_frames(tmp_path):
    """A robot read from /tf leaves its other child frames (odom, laser: its own frames and
    the localiser's) unread, and they are not robots, so they are not in `left_out`; a pose
    topic beside it is, with its messages."""
    from mirl.observations.sources import load_observations
    from mirl.world.scenario import load_scenario

    ts = typestore(True)
    j = [("/J/pose", 100.0 + k, pose_message(ts, "stamped", 100.0 + k, 8.0, 0.0, 0.0))
         for k in range(3)]  # fmt: skip
    bag = write_bag(tmp_path / "b", sorted(_records(True) + j, key=lambda r: r[1]), fmt="mcap")
    scenario = load_scenario("boyd2")
    # the robot drives off boyd2's map: its poses are dropped, which does not matter here
    got = load_observations(bag, scenario, topics={"/tf:base_link": "I"}, drop_off_map=True)
    assert dict(got.left_out) == {"/J/pose": 3}
    got = load_observations(bag, scenario, topics={"/J/pose": "J"})
    assert dict(got.left_out) == {}


def test_a_link_without_a_recent_transform_drops_and_counts_the_pose(tmp_path):
    recs = [
        r
        for r in _records(True)
        if not (r[0] == "/tf" and r[2][1].transforms[0].child_frame_id == "odom" and r[1] > 100.5)
    ]
    bag = write_bag(tmp_path / "b", recs, fmt="mcap")
    tracks = read_bag(bag, {"/tf:base_link": "I"})
    # the localiser spoke at 100.0 only: poses up to 1 s after it are placed, later ones not
    assert len(tracks) == 11 and tracks.unplaced["I"] == 40


def test_tf_errors_name_the_frames(tmp_path):
    bag = write_bag(tmp_path / "b", _records(True, with_localiser=False), fmt="mcap")
    with pytest.raises(BagError, match=r"not below the map frame 'map'.*\(it reaches odom -> "
                       r"base_link\)"):  # fmt: skip
        read_bag(bag, {"/tf:base_link": "I"})
    with pytest.raises(BagError, match=r"\(it reaches odom -> base_link -> laser\)"):
        read_bag(bag, {"/tf:laser": "I"})
    # saying that odom is the map frame places the robot in odom's coordinates
    tracks = read_bag(bag, {"/tf:base_link": "I"}, same_frames={"odom": "map"})
    np.testing.assert_allclose(tracks.x, 0.2 * np.arange(51), atol=1e-9)
    with pytest.raises(BagError, match="no transform into frame 'base_footprint'"):
        read_bag(bag, {"/tf:base_footprint": "I"})


def test_topics_in_different_frames_are_refused_unless_related(tmp_path):
    ts = typestore(True)
    recs = [
        ("/a", 1.0, pose_message(ts, "stamped", 1.0, 1.0, 0, 0, frame="map")),
        ("/b", 1.0, pose_message(ts, "stamped", 1.0, 2.0, 0, 0, frame="odom")),
    ]
    bag = write_bag(tmp_path / "b", recs, fmt="mcap")
    with pytest.raises(BagError, match=r"different frames \(/a in 'map', /b in 'odom'\)"):
        read_bag(bag, {"/a": "I", "/b": "J"})
    tracks = read_bag(bag, {"/a": "I", "/b": "J"}, same_frames={"odom": "map"})
    assert tracks.frames == {"I": "map", "J": "odom"}


def test_a_same_frames_pair_no_frame_read_is_in_is_refused(tmp_path):
    """`same_frames` naming a frame that no topic read is in and no transform names would
    change nothing (a misspelt frame, or another bag's): refused, naming the frames read."""
    ts = typestore(True)
    recs = [("/a", 1.0, pose_message(ts, "stamped", 1.0, 1.0, 0, 0, frame="map"))]
    bag = write_bag(tmp_path / "b", recs, fmt="mcap")
    with pytest.raises(BagError, match=r"`same_frames` odm=map: no pose topic read is in frame "
                       r"'odm' .*\(frames read: 'map'\)"):  # fmt: skip
        read_bag(bag, {"/a": "I"}, same_frames={"odm": "map"})
    assert len(read_bag(bag, {"/a": "I"}, same_frames={"map": "odom"})) == 1
    tf_bag = write_bag(tmp_path / "tf", _records(True), fmt="mcap")
    with pytest.raises(BagError, match="frames read: 'base_link', 'laser', 'map', 'odom'"):
        read_bag(tf_bag, {"/tf:base_link": "I"}, same_frames={"odm": "map"})


def test_an_off_map_pose_names_its_frame(tmp_path):
    from mirl.observations.discretise import DiscretisationError, discretise
    from mirl.world.scenario import load_scenario

    ts = typestore(True)
    recs = [("/p", 1.0, pose_message(ts, "stamped", 1.0, 50.0, -50.0, 0, frame="odom"))]
    tracks = read_bag(write_bag(tmp_path / "b", recs, fmt="mcap"), {"/p": "I"})
    with pytest.raises(DiscretisationError, match=r"pose \(50.000, -50.000\) m in frame 'odom'"):
        discretise(tracks, load_scenario("boyd2"))
