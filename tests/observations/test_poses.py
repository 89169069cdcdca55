"""Pose CSV files: exact round trip, quaternion columns, and one-line errors naming the line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mirl.observations.poses import (
    PoseError,
    PoseTracks,
    read_pose_csv,
    write_pose_csv,
    yaw_from_quaternion,
)


def tracks(n=200, seed=0):
    rng = np.random.default_rng(seed)
    return PoseTracks(
        ("I", "J", "tb3_1"),
        rng.uniform(0, 1e4, n),
        rng.integers(0, 3, n),
        rng.normal(size=n) * 10,
        rng.normal(size=n) * 10,
        rng.uniform(-math.pi, math.pi, n),
    ).sorted()


def test_csv_round_trip_is_exact(tmp_path):
    tr = tracks()
    path = tmp_path / "p.csv"
    write_pose_csv(tr, path)
    assert path.read_text().splitlines()[0] == "t,robot,x,y,yaw"
    back = read_pose_csv(path)
    # names in order of first appearance in the file, same rows
    names = np.asarray(back.robot_names)[back.robot]
    np.testing.assert_array_equal(names, np.asarray(tr.robot_names)[tr.robot])
    for f in ("t", "x", "y", "yaw"):
        np.testing.assert_array_equal(getattr(back, f), getattr(tr, f))
    assert back.source == str(path)


def test_quaternion_columns_spaces_and_blank_lines(tmp_path):
    path = tmp_path / "q.csv"
    q = math.sin(math.pi / 4)
    path.write_text(
        f"robot, t, x, y, qz, qw, extra\nJ, 2.5, 1, 2, {q}, {q}, a\n\nI, 1, 3, 4, 0, 1, b\n"
        "I, 0.5, 5, 6, 1, 0, c\n"
    )
    tr = read_pose_csv(path)
    assert tr.robot_names == ("J", "I")
    assert tr.robot.tolist() == [0, 1, 1]  # sorted by (robot, t)
    assert tr.t.tolist() == [2.5, 0.5, 1.0]
    np.testing.assert_allclose(tr.yaw, [math.pi / 2, math.pi, 0.0], atol=1e-12)
    np.testing.assert_allclose(yaw_from_quaternion(0, 0, -q, q), -math.pi / 2)
    # any scale of the quaternion gives the same yaw
    np.testing.assert_allclose(yaw_from_quaternion(0, 0, -3 * q, 3 * q), -math.pi / 2)


def test_a_full_quaternion_is_read_as_a_bag_reads_it(tmp_path):
    """qx, qy beside qz, qw are read, not ignored: a body tilted or upside down (a motion-capture
    frame with z down, whose qz and qw are 0) gets the yaw a bag's reader gives it."""
    path = tmp_path / "q.csv"
    rows = [(0, 0.5, 0.3, 0.8), (1, 0, 0, 0), (math.sqrt(0.5), 0.5, 0.5, 0)]
    path.write_text(
        "t,robot,x,y,qx,qy,qz,qw\n"
        + "".join(f"{k},I,1,2,{','.join(map(str, q))}\n" for k, q in enumerate(rows))
    )
    tr = read_pose_csv(path)
    expected = [yaw_from_quaternion(*q) for q in rows]
    np.testing.assert_allclose(tr.yaw, expected, atol=1e-12)
    assert abs(tr.yaw[1]) < 1e-12 and abs(tr.yaw[2] - math.pi / 2) < 1e-12  # rolled, not refused


@pytest.mark.parametrize(
    "text, where",
    [
        ("t,robot,x\n1,I,2\n", "line 1: missing column 'y'"),
        ("t,robot,x,y\n1,I,2,3\n", "line 1: need a 'yaw' column"),
        ("t,robot,x,y,yaw\n1,I,2,3,0\n\n2,I,abc,3,0\n", "line 4: column x: 'abc' is not a number"),
        ("t,robot,x,y,yaw\n1,I,2,3,0\n2,I,nan,3,0\n", "line 3: column x: missing, NaN"),
        ("t,robot,x,y,yaw\n1,I,2,3,0\n2,I,,3,0\n", "line 3: column x: missing, NaN"),
        ("t,robot,x,y,yaw\n1,I,2,3,0\n2,I,1,3\n", "line 3: expected 5 cells"),
        ("t,robot,x,y,yaw\n1, ,2,3,0\n", "line 2: empty robot name"),
        ("\ufefft,robot,x,y,yaw\n1,I,2,3,0\nabc,I,2,3,0\n", "line 3: column t: 'abc' is not"),
        ("t,robot,x,y,yaw\n1,I,2,3,0\n2,I,1_000,3,0\n", "line 3: column x: '1_000' is not a"),
        ("t,robot,x,y,yaw\n1,I,2,3,0\n2,I,2,\uff13,0\n", "line 3: column y: '\uff13' is not a"),
        ("", "file is empty"),
        ("t,robot,x,y,qz,qw\n1,I,2,3,0,1\n2,I,2,3,0,0\n", "line 3: qz = qw = 0"),
        ("t,robot,x,y,qz,qw\n1,I,2,3,0,1\n2,I,2,3,0,1e300\n", "line 3: qz or qw beyond"),
        ("t,robot,x,y,qx,qz,qw\n1,I,2,3,0,0,1\n", "line 1: a quaternion with 'qx' needs 'qy'"),
        ("t,robot,x,y,qx,qy,qz,qw\n1,I,2,3,0,0,0,0\n", "line 2: qx = qy = qz = qw = 0"),
        ("t,robot,x,y,qx,qy,qz,qw\n1,I,2,3,2e6,0,0,1\n", "line 2: qx, qy, qz or qw beyond"),
    ],
)
def test_errors_name_file_and_line(tmp_path, text, where):
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(PoseError) as e:
        read_pose_csv(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}: ") and where in msg and "\n" not in msg


def test_missing_file_and_unknown_robot(tmp_path):
    with pytest.raises(PoseError, match="no such file"):
        read_pose_csv(tmp_path / "none.csv")
    tr = tracks(10)
    with pytest.raises(PoseError, match="robot 'tb3_1' is not in the scenario \\(I, J\\)"):
        tr.with_robot_names(("I", "J"))
    back = tr.with_robot_names(("tb3_1", "J", "I", "K"))
    assert back.robot_names == ("tb3_1", "J", "I", "K")
    assert back.robot.tolist() == sorted(back.robot.tolist())  # re-sorted by (robot, t)
    a, b = np.argsort(back.t), np.argsort(tr.t)  # same poses, same names
    np.testing.assert_array_equal(
        np.asarray(back.robot_names)[back.robot[a]], np.asarray(tr.robot_names)[tr.robot[b]]
    )
    np.testing.assert_array_equal(back.x[a], tr.x[b])
