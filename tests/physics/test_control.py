"""The move_base analogue: who slows down and who keeps right, and the wheel speeds of each
mode (drive, pivot on the inner wheel, hold) within the wheels' limits."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.physics.control import DRIVE, HOLD, PIVOT, Controller, crowded, in_company, wrap
from mirl.physics.robot import KOBUKI


def test_wrap_puts_angles_in_minus_pi_to_pi():
    a = np.array([0.0, np.pi, -np.pi, 3 * np.pi / 2, -7.0, 12.0])
    w = wrap(a)
    assert ((w >= -np.pi) & (w < np.pi)).all()
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)


def poses(*rows):
    return np.array(rows, dtype=float)


def test_a_robot_coming_the_other_way_close_ahead_slows_both():
    p = poses([0, 0, 0], [1.0, 0, np.pi])  # 1 cell apart, face to face
    assert crowded(p, 1.0, 1.2).tolist() == [True, True]
    assert not crowded(p, 1.0, 0.9).any()  # farther than pass_distance


def test_a_robot_close_ahead_going_the_same_way_slows_the_one_behind():
    p = poses([0, 0, 0], [0.7, 0, 0])
    assert crowded(p, 1.0, 1.2).tolist() == [True, False]
    assert not crowded(poses([0, 0, 0], [0.9, 0, 0]), 1.0, 1.2).any()
    assert not crowded(poses([0, 0, 0]), 1.0, 1.2).any()  # alone


def test_only_robots_meeting_head_on_keep_right_and_until_they_have_passed():
    ahead = poses([0, 0, 0], [3.0, 0.1, np.pi])
    assert in_company(ahead, 1.0, 6.0).tolist() == [True, True]
    alongside = poses([0, 0, 0], [0.0, 0.4, np.pi])  # side by side: still keeping right
    assert in_company(alongside, 1.0, 6.0).tolist() == [True, True]
    behind = poses([0, 0, 0], [-3.0, 0.0, np.pi])  # gone past: back to the middle
    assert not in_company(behind, 1.0, 6.0).any()
    following = poses([0, 0, 0], [2.0, 0.0, 0.0])
    assert not in_company(following, 1.0, 6.0).any()
    assert not in_company(poses([0, 0, 0], [7.0, 0, np.pi]), 1.0, 6.0).any()


def controller(n=1, **kw):
    args = dict(max_speed=0.7, max_accel=1.0, turn_speed=1.2, dt=0.1)
    return Controller(n, KOBUKI, **{**args, **kw})


def test_holding_commands_both_wheels_to_zero():
    c = controller()
    c.set_targets(0, HOLD, 1.0, 0.0, 0.0)
    assert c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1)).tolist() == [[0.0, 0.0]]


@pytest.mark.parametrize("turn, still, driving", [(np.pi / 2, 0, 1), (-np.pi / 2, 1, 0)])
def test_a_pivot_turns_on_the_inner_wheel(turn, still, driving):
    c = controller()
    c.set_targets(0, PIVOT, 0.0, 0.0, turn)
    w = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0]
    assert w[still] == 0.0 and w[driving] > 0  # left turn: the right wheel drives


def test_driving_straight_accelerates_gently_and_within_the_wheels_limit():
    c = controller(max_accel=1.0, dt=0.1)
    c.set_targets(0, DRIVE, 5.0, 0.0, 0.0)
    first = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0]
    assert first[0] == first[1] == pytest.approx(0.1 / KOBUKI.wheel_radius)  # a·dt, in rad/s
    for _ in range(30):
        w = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0]
    assert w[0] == pytest.approx(0.7 / KOBUKI.wheel_radius)  # cruise speed reached
    assert np.abs(w).max() <= KOBUKI.max_wheel_speed + 1e-9
    slow = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1), slow=np.array([True]))[0]
    assert slow[0] == pytest.approx(0.2 / KOBUKI.wheel_radius)  # pass_speed


def test_the_wheel_speeds_follow_the_robots_build():
    """The same forward speed is fewer rad/s on a bigger wheel, and a slower wheel limit scales
    a command down, both wheels alike."""
    from dataclasses import replace

    big = replace(KOBUKI, wheel_radius=2 * KOBUKI.wheel_radius)
    speeds = []
    for robot in (KOBUKI, big):
        c = Controller(1, robot, max_speed=0.7, max_accel=1.0, turn_speed=1.2, dt=0.1)
        c.set_targets(0, DRIVE, 5.0, 0.0, 0.0)
        speeds.append(c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0])
    np.testing.assert_allclose(speeds[1], speeds[0] / 2)
    capped = replace(KOBUKI, max_wheel_speed=5.0)  # 0.175 m/s at the rim
    c = Controller(1, capped, max_speed=0.7, max_accel=10.0, turn_speed=1.2, dt=0.1)
    c.set_targets(0, DRIVE, 5.0, 0.0, 0.0)
    w = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0]
    assert w.tolist() == pytest.approx([5.0, 5.0])


def test_a_large_bearing_error_turns_in_place_before_driving():
    c = controller()
    c.set_targets(0, DRIVE, 0.0, 5.0, np.pi / 2)  # the target is to the left
    w = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0]
    assert w[0] == pytest.approx(-w[1]) and w[1] > 0  # no forward speed, turning left


def test_in_company_the_target_moves_into_the_right_lane():
    c = controller()
    c.set_targets(0, DRIVE, 2.0, 0.0, 0.0, lane=0.3)
    alone = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1))[0]
    c = controller()
    c.set_targets(0, DRIVE, 2.0, 0.0, 0.0, lane=0.3)
    company = c.wheel_speeds(np.zeros(1), np.zeros(1), np.zeros(1), company=np.array([True]))[0]
    assert alone[0] == pytest.approx(alone[1])
    assert company[0] > company[1]  # steering right, towards the lane
