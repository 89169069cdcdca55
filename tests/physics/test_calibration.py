"""What the physics makes of the grid's actions (mirl.physics.calibration): the measured
strength-to-success table, which wheels count as damaged, the bookkeeping of a calibration run
(checked against a recount from its own transitions) and its rates as statistics over seeds
with margins — never one chaotic run's exact outcome."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from mirl.physics.calibration import (  # noqa: E402
    FORWARD_SUCCESS_RATIO,
    HEAD_ON_STARTS,
    Calibration,
    Meeting,
    calibrate,
    damaged_wheels,
    head_on_meeting,
    open_loop,
    weakened_wheels,
    wheel_success,
)
from mirl.physics.config import scenario_physics, with_motor_strength  # noqa: E402
from mirl.physics.robot import KOBUKI  # noqa: E402
from mirl.world.actions import ACTIONS  # noqa: E402
from mirl.world.faults import WHEELS  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402

FORWARD, STOP = ACTIONS.index("forward"), ACTIONS.index("stop")
MOVING = [ACTIONS.index(a) for a in ("forward", "turn_left", "turn_right")]


@pytest.fixture(scope="module")
def healthy():
    return load_scenario("boyd2-healthy")


# ---- the measured table ---------------------------------------------------------------------
def test_the_table_is_a_share_that_grows_with_the_motors_strength():
    strengths = sorted(FORWARD_SUCCESS_RATIO)
    ratios = [FORWARD_SUCCESS_RATIO[s] for s in strengths]
    assert all(0.0 < s < 1.0 for s in strengths)
    assert all(0.0 < r <= 1.0 for r in ratios)
    assert np.all(np.diff(ratios) >= 0)


@pytest.mark.parametrize("healthy_level", [0.95, 0.8])
def test_wheel_success_interpolates_the_table_linearly(healthy_level):
    """At the measured strengths it is the healthy level times the ratio; half-way between two
    of them, the mean of theirs; a dead motor never succeeds and a full one is healthy."""
    for strength, ratio in FORWARD_SUCCESS_RATIO.items():
        assert wheel_success(strength, healthy_level) == pytest.approx(healthy_level * ratio)
    mid = healthy_level * (FORWARD_SUCCESS_RATIO[0.5] + FORWARD_SUCCESS_RATIO[0.6]) / 2
    assert wheel_success(0.55, healthy_level) == pytest.approx(mid)
    # below the first measured strength: a straight line from (0, 0)
    assert wheel_success(0.25, healthy_level) == pytest.approx(
        healthy_level * FORWARD_SUCCESS_RATIO[0.5] / 2
    )
    assert wheel_success(0.0, healthy_level) == 0.0
    assert wheel_success(1.0, healthy_level) == pytest.approx(healthy_level)
    assert wheel_success(1.5, healthy_level) == pytest.approx(healthy_level)  # clamped
    grid = np.linspace(0, 1, 101)
    assert np.all(np.diff([wheel_success(s, healthy_level) for s in grid]) >= 0)


# ---- damaged and weakened wheels --------------------------------------------------------------
def test_a_healthy_scenario_has_no_damaged_or_weakened_wheel(healthy):
    assert damaged_wheels(healthy) == {r: () for r in healthy.robot_names}
    assert weakened_wheels(healthy) == {r: () for r in healthy.robot_names}


@pytest.mark.parametrize("strength", [0.3, 0.6, 0.7, 0.75, 0.8, 0.9, 0.99])
@pytest.mark.parametrize("wheel", WHEELS)
def test_every_weak_wheel_is_either_damaged_or_weakened(healthy, wheel, strength):
    """Damaged exactly when its success probability lies below the threshold (recomputed here
    from the definition); otherwise weakened; the other robot is untouched."""
    sc = with_motor_strength(healthy, "J", wheel, strength)
    level = sc.faults.healthy.get(wheel, 0.95)
    damaged = wheel_success(strength, level) < sc.faults.threshold(wheel)
    assert damaged_wheels(sc) == {"I": (), "J": (wheel,) if damaged else ()}
    assert weakened_wheels(sc) == {"I": (), "J": () if damaged else (wheel,)}


def test_both_wheels_of_a_robot_in_their_order(healthy):
    sc = with_motor_strength(healthy, "I", "right_wheel", 0.5)
    sc = with_motor_strength(sc, "I", "left_wheel", 0.6)
    assert damaged_wheels(sc)["I"] == WHEELS
    sc = with_motor_strength(sc, "I", "left_wheel", 0.9)
    assert damaged_wheels(sc)["I"] == ("right_wheel",)
    assert weakened_wheels(sc)["I"] == ("left_wheel",)


# ---- the record's arithmetic, on hand-made counts ---------------------------------------------
def _hand_made() -> Calibration:
    cal = Calibration(("I", "J"))
    cal.counts = np.zeros((2, len(ACTIONS), 2), dtype=int)
    cal.counts_alone = np.zeros_like(cal.counts)
    cal.failure_ends = np.zeros((2, len(ACTIONS), 3), dtype=int)
    cal.counts[0, FORWARD] = [10, 7]
    cal.counts_alone[0, FORWARD] = [4, 4]
    cal.failure_ends[0, FORWARD] = [2, 1, 0]
    cal.failure_ends[1, ACTIONS.index("turn_left")] = [1, 0, 1]
    cal.failure_ends[1, STOP] = [0, 0, 5]  # not a moving action: left out of the default
    return cal


def test_rate_is_successes_over_trials_and_nan_without_trials():
    cal = _hand_made()
    assert cal.rate(0, "forward") == (0.7, 10)
    assert cal.rate(0, "forward", alone=True) == (1.0, 4)
    rate, n = cal.rate(1, "forward")
    assert np.isnan(rate) and n == 0
    with pytest.raises(ValueError):
        cal.rate(0, "jump")


def test_stayed_shares_the_moving_actions_failures_or_one_actions():
    cal = _hand_made()
    assert cal.stayed() == (pytest.approx(3 / 5), 5)  # 2 + 1 stayed of 3 + 2 failed
    assert cal.stayed("forward") == (pytest.approx(2 / 3), 3)
    assert cal.stayed("stop") == (0.0, 5)
    share, n = cal.stayed("turn_right")
    assert np.isnan(share) and n == 0


@pytest.mark.parametrize(
    ("got_past", "contacts", "passed"), [(True, 0, True), (True, 1, False), (False, 0, False)]
)
def test_a_meeting_passes_only_past_each_other_untouched(got_past, contacts, passed):
    assert Meeting(got_past, contacts, wall_contacts=3).passed is passed


def test_a_meeting_that_has_not_started_has_not_passed(healthy):
    """No step driven: the robots are still at their starts, facing each other."""
    assert HEAD_ON_STARTS[0][0] < HEAD_ON_STARTS[1][0]  # the first is north of the second
    meeting = head_on_meeting(healthy, seed=0, steps=0)
    assert meeting == Meeting(got_past=False, contacts=0, wall_contacts=0)
    assert not meeting.passed


# ---- one robot's abilities, open loop ----------------------------------------------------------
def test_open_loop_pivots_as_the_kinematics_say(healthy):
    """A pivot on one driving wheel turns at its rim speed over the wheel separation; a full
    motor nears the commanded rim speed; a motor at half strength drives slower, and only its
    own wheel. Margins of 5 % and 10 % (measured: within 3 % and 2 %)."""
    full = KOBUKI.max_wheel_speed * KOBUKI.wheel_radius
    weak = with_motor_strength(healthy, "J", "left_wheel", 0.5)
    for sc in (healthy, weak):
        out = open_loop(sc, "J")
        for wheel, turn in (("left", "turn_right"), ("right", "turn_left")):
            pivot = np.degrees(out[f"{wheel}_wheel_speed"] / KOBUKI.wheel_separation)
            assert out[f"{turn}_rate"] == pytest.approx(pivot, rel=0.05)
        assert out["right_wheel_speed"] == pytest.approx(full, rel=0.1)
    healthy_out, weak_out = open_loop(healthy, "J"), open_loop(weak, "J")
    assert healthy_out["left_wheel_speed"] == pytest.approx(full, rel=0.1)
    assert weak_out["left_wheel_speed"] < 0.6 * healthy_out["left_wheel_speed"]


# ---- a calibration run: its bookkeeping and its rates ------------------------------------------
SEEDS, STEPS = (0, 1, 2), 100


@pytest.fixture(scope="module")
def weak_left():
    """J's left motor at half strength (its table's ratio: 0.45), I healthy; three short
    patrols (about 6 s)."""
    sc = with_motor_strength(load_scenario("boyd2-healthy"), "J", "left_wheel", 0.5)
    return sc, calibrate(sc, steps=STEPS, seeds=SEEDS)


def test_a_run_counts_every_step_once(weak_left):
    sc, cal = weak_left
    n = len(sc.robots)
    assert cal.robot_names == sc.robot_names
    assert cal.steps == len(SEEDS) * (STEPS - 1)
    assert cal.sim_seconds == pytest.approx(cal.steps * scenario_physics(sc).step_seconds)
    assert len(cal.records) == len(SEEDS) and len(cal.transitions) == len(SEEDS) * n
    assert cal.counts.shape == cal.counts_alone.shape == (n, len(ACTIONS), 2)
    assert np.all(cal.counts[:, :, 0].sum(axis=1) == cal.steps)
    assert np.all(cal.counts[..., 1] <= cal.counts[..., 0])
    assert np.all(cal.counts_alone <= cal.counts)
    assert np.all(cal.failure_ends.sum(axis=2) == cal.counts[..., 0] - cal.counts[..., 1])


def test_a_runs_counts_are_its_transitions_recounted(weak_left):
    """Counts, successes and where failed steps end, recomputed from the (s, a, s') the run
    hands a learner and the domain's intended states."""
    sc, cal = weak_left
    dom, n = sc.domain, len(sc.robots)
    counts = np.zeros_like(cal.counts)
    ends = np.zeros_like(cal.failure_ends)
    for k, steps in enumerate(cal.transitions):
        i = k % n  # per seed, one array per robot in order
        assert steps.shape == (STEPS - 1, 3)
        for s, a, s_next in steps:
            ok = dom.intended[s, a] == s_next
            counts[i, a] += [1, ok]
            if not ok:
                end = 0 if s_next == s else 1 if s_next in dom.intended[s] else 2
                ends[i, a, end] += 1
    np.testing.assert_array_equal(counts, cal.counts)
    np.testing.assert_array_equal(ends, cal.failure_ends)


def test_a_weak_motor_fails_the_forward_steps_the_table_says(weak_left):
    """Statistics over three patrols: the healthy robot's forward steps alone nearly all
    succeed, the weak one's well under 0.7 of that (the table: 0.45; measured on seeds 0-8 in
    threes: 0.99 against 0.30-0.42), and at a median speed near one cell a step for the healthy
    robot. Each rate is of 70-190 steps."""
    sc, cal = weak_left
    i, j = sc.robot_index("I"), sc.robot_index("J")
    (healthy_rate, n_i), (weak_rate, n_j) = (cal.rate(r, "forward", alone=True) for r in (i, j))
    assert n_i >= 30 and n_j >= 30
    assert healthy_rate >= 0.85
    assert weak_rate <= 0.7 * healthy_rate
    cell_per_step = sc.map.frame.cell_size / scenario_physics(sc).step_seconds
    assert np.median(cal.forward_speed[i]) == pytest.approx(cell_per_step, rel=0.2)
    assert np.median(cal.forward_speed[j]) < 0.7 * np.median(cal.forward_speed[i])
    # a failed step mostly stays put (Eq. 5's uniform error model would move two thirds)
    share, failed = cal.stayed()
    assert failed >= 30 and share >= 0.8


def test_no_turn_outruns_a_pivot_in_place_at_full_speed(weak_left):
    """The peak yaw rate of a turn is bounded by both wheels driving opposite at the most the
    controller commands: 2 v / separation (a 10 % margin for the contact's slip)."""
    _, cal = weak_left
    bound = np.degrees(2 * KOBUKI.max_wheel_speed * KOBUKI.wheel_radius / KOBUKI.wheel_separation)
    rates = [r for robot in cal.turn_rate for turn in robot.values() for r in turn]
    assert len(rates) >= 20
    assert max(rates) <= 1.1 * bound
