"""``mirl learn`` on a bag mirl did not write: two TurtleBot3s in Gazebo, driven by the ROS
navigation stack, their odometry republished in whole-second stamps (tests/data/real/
tb3-gazebo-nav; its README says where the data come from and what was changed).

Neither robot is damaged, so whatever a correct mirl infers, it must not say with confidence
(>= 0.9) that a part of either is: a verdict naming a part, or a set of parts, is false here."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest
from rosbags.rosbag1 import Reader, Writer

from mirl.cli import main
from tests.cli.test_robot_data import one_error_line

DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "tb3-gazebo-nav"
BAG = DATA / "location.bag"
TOPICS = ["--topic", "/tb_a/location=I", "--topic", "/tb_b/location=J"]
CONFIDENT = 0.9


def learn_json(*args: str) -> dict:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["learn", "--scenario", str(DATA / "world.toml"), *args, "--json"])
    assert code == 0
    return json.loads(out.getvalue())


def says_damaged_confidently(verdict: dict) -> bool:
    named = verdict["part"] is not None or bool(verdict["candidates"])
    return named and verdict["confidence"] >= CONFIDENT


@pytest.fixture(scope="module")
def learned() -> dict:
    return learn_json("--observations", str(BAG), *TOPICS)


def test_the_bag_is_read_at_its_stamps_resolution(learned):
    """The stamps are whole seconds: no step shorter than a second has a pose at both ends, and
    at two seconds a robot crosses two cells of 0.25 m too often; the report says why 1 s."""
    assert learned["step_seconds"] == 1.0
    assert "the tracker's interval, one pose a step" in learned["step_chosen"]
    assert learned["steps"] == 112


@pytest.mark.parametrize("robot", ["I", "J"])
def test_no_confident_claim_that_a_part_of_a_healthy_robot_is_damaged(learned, robot):
    verdict = learned["robots"][robot]["verdict"]
    assert not says_damaged_confidently(verdict), verdict


def test_robots_slower_than_their_tracker_fail_the_pace_check(learned):
    """J waits 11 s before it moves and crosses a 0.25 m cell in 1-3 s; I is slower still. At
    the only step the whole-second stamps allow, both stay in their cell on most of their free
    steps: nothing in the record moves at a healthy pace, so the poses cannot tell these slow
    healthy robots from robots whose motors are weak (the physical world's crawl reads the
    same), and neither verdict may claim a part at high confidence."""
    for robot in ("I", "J"):
        fit = learned["robots"][robot]["verdict"]["fit"]
        assert not fit["ok"] and "tracker's interval (1 s)" in fit["reason"], fit
        assert not fit["checks"]["pace"]["ok"]


def test_converting_the_bag_warns_that_the_grid_csv_loses_its_pace(tmp_path, capsys):
    out = tmp_path / "grid.csv"
    code = main(["convert", str(BAG), str(out), "--scenario", str(DATA / "world.toml"), *TOPICS])
    err = capsys.readouterr().err
    assert code == 0 and out.exists() and err.count("mirl: warning:") == 1
    assert "tracker's interval (1 s)" in err and "location.bag itself" in err


def test_the_topic_as_published_two_robots_on_one_is_a_misfit(tmp_path):
    """The bag's own ``/location``, both robots' odometry on one topic, read as one robot: the
    record jumps between them, which the model check must see, and no part is claimed."""
    bag = tmp_path / "published.bag"
    with Reader(BAG) as reader, Writer(bag) as writer:
        first = reader.connections[0]
        conn = writer.add_connection(
            "/location", first.msgtype, msgdef=first.msgdef.data, md5sum=first.digest
        )
        for _, t, raw in reader.messages():
            writer.write(conn, t, raw)
    out = learn_json("--observations", str(bag), "--topic", "/location=I")
    verdict = out["robots"]["I"]["verdict"]
    assert out["step_seconds"] == 1.0
    assert not verdict["fit"]["ok"] and "explained by no action" in verdict["fit"]["reason"]
    assert not says_damaged_confidently(verdict), verdict
    assert out["robots"]["J"]["observed_moves"]["moves"] == 0  # J has no topic here


def test_the_bags_own_map_is_refused_for_its_frame(capsys):
    """The bag's SLAM map starts where the robot did, about (2.0, 0.5) m from the Gazebo frame
    of the poses: J's first pose is off that map's hallway, refused in one line."""
    code = main(["learn", "--scenario", str(DATA / "slam-map.toml"),
                 "--observations", str(BAG), *TOPICS])  # fmt: skip
    one_error_line(capsys, code, "location.bag", "robot J", "(-2.000, -0.500) m", "map frame")
