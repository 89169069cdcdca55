"""``step_seconds="auto"``: the robots' own pace (mirl.observations.discretise.auto_step_seconds)
on tracks that move in jumps, tracks that move smoothly, and tracks too noisy to tell."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.cli import main
from mirl.observations.discretise import (
    AUTO_LONG_MOVES,
    RHYTHM_FACTOR,
    auto_step_seconds,
    discretise,
    poses_from_trajectories,
    rhythm_strength,
)
from mirl.observations.poses import PoseTracks, write_pose_csv
from mirl.observations.sources import load_observations
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("boyd2")


@pytest.mark.parametrize("step", [2.0, 1.5, 3.0])
@pytest.mark.parametrize("degree", [0.14, 1.0])
def test_a_track_in_jumps_is_read_at_its_period(scenario, step, degree):
    """Poses written from grid states (10 Hz, 5 cm / 3° noise) at ``step`` seconds a step: the
    auto step is that step, and the record read at it is the grid record."""
    obs = simulate(scenario, 300, seed=1, observability=degree, random_starts=True).observations
    tracks = poses_from_trajectories(
        obs, scenario, step_seconds=step, sigma_xy=0.05, sigma_yaw_degrees=3.0, seed=1
    )
    auto = auto_step_seconds(tracks, scenario, start_time=0.0)
    assert auto.found and auto.seconds == pytest.approx(step)
    d = discretise(tracks, scenario, step_seconds="auto", start_time=0.0, n_steps=obs.horizon)
    assert d.step_seconds == pytest.approx(step) and d.auto_step == auto
    back = d.trajectories
    assert np.array_equal(back.t, obs.t) and np.array_equal(back.row, obs.row)
    assert "the robots' pace" in d.summary()


def _smooth_track(scenario, speed: float, seconds: float = 600.0) -> PoseTracks:
    """One robot driving the top hallway of boyd2 back and forth at ``speed`` cells a second,
    turning round in place at its ends, tracked at 20 Hz (:func:`_driven`)."""
    return _driven(scenario, lambda t: t * speed, seconds)


@pytest.mark.parametrize(("speed", "pace"), [(0.5, 2.0), (0.25, 4.0), (1.0, 1.0)])
def test_a_smooth_track_is_read_where_a_move_is_one_cell(scenario, speed, pace):
    """A robot at ``speed`` cells a second: the longest step at which its moves stay within one
    cell is one cell's time, 1 / speed (within the steps tried)."""
    auto = auto_step_seconds(_smooth_track(scenario, speed), scenario)
    assert auto.found and auto.long_moves <= AUTO_LONG_MOVES
    assert auto.seconds == pytest.approx(pace, abs=0.051)


def test_a_track_too_noisy_for_any_step_gets_the_papers(scenario):
    obs = simulate(scenario, 300, seed=0, observability=1.0, random_starts=True).observations
    tracks = poses_from_trajectories(obs, scenario, sigma_xy=0.6, sigma_yaw_degrees=30, seed=0)
    auto = auto_step_seconds(tracks, scenario)
    assert not auto.found and auto.seconds == 2.0
    assert "the paper's 2 s" in auto.sentence()


def test_robot_data_are_read_at_their_pace_by_default(scenario, tmp_path):
    obs = simulate(scenario, 200, seed=2, observability=1.0, random_starts=True).observations
    path = tmp_path / "poses.csv"
    write_pose_csv(poses_from_trajectories(obs, scenario, step_seconds=1.5, seed=2), path)
    loaded = load_observations(path, scenario, start_time=0.0)
    assert loaded.discretised.step_seconds == pytest.approx(1.5)
    fixed = load_observations(path, scenario, step_seconds=2.0, start_time=0.0)
    assert fixed.discretised.step_seconds == 2.0 and fixed.discretised.auto_step is None


def test_the_command_line_takes_auto_and_says_what_it_chose(scenario, tmp_path, capsys):
    obs = simulate(scenario, 200, seed=2, observability=1.0, random_starts=True).observations
    path = tmp_path / "poses.csv"
    write_pose_csv(poses_from_trajectories(obs, scenario, step_seconds=1.5, seed=2), path)
    for flags in ([], ["--step-seconds", "auto"]):
        code = main(["convert", str(path), str(tmp_path / "grid.csv"), "--scenario", "boyd2",
                     "--start-time", "0", *flags])  # fmt: skip
        out = capsys.readouterr().out
        assert code == 0 and "steps of 1.5 s" in out and "the robots' pace" in out
    with pytest.raises(SystemExit) as refused:
        main(["convert", str(path), str(tmp_path / "grid.csv"), "--scenario", "boyd2",
              "--step-seconds", "fast"])  # fmt: skip
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "--step-seconds" in err and "or auto" in err


def _whole_seconds(tracks: PoseTracks) -> PoseTracks:
    """The track as a publisher stamping in whole seconds records it: many poses to a stamp."""
    return PoseTracks(
        tracks.robot_names, np.floor(tracks.t), tracks.robot, tracks.x, tracks.y, tracks.yaw
    )


@pytest.mark.parametrize(("speed", "pace"), [(0.5, 2.0), (0.25, 4.0), (1.0, 1.0)])
def test_whole_second_stamps_are_read_at_a_multiple_of_a_second(scenario, speed, pace):
    """20 Hz poses stamped in whole seconds: the stamps say a second, no finer, so the step is a
    whole number of seconds, the longest at which a move stays within one cell."""
    auto = auto_step_seconds(_whole_seconds(_smooth_track(scenario, speed)), scenario)
    assert auto.found and auto.seconds == pytest.approx(pace)
    assert auto.long_moves <= AUTO_LONG_MOVES


def test_two_robots_on_one_topic_stamped_in_whole_seconds_do_not_break_the_auto_step(scenario):
    """Two robots' 20 Hz tracks interleaved under one name and stamped in whole seconds (a real
    bag's republished odometry): which robot's pose comes first in a second varies, so the
    record jumps between them, and the zero time between poses of one stamp is no pose
    interval. The step is a whole number of seconds; the jumps show, for the model check."""
    one = _smooth_track(scenario, 0.5, seconds=120.0)
    other = _smooth_track(scenario, 0.5, seconds=133.0)
    keep = other.t >= 13.0  # the other robot is 13 s along the same hallway
    # each a publisher of its own: which one's pose comes first in a second is chance
    t = np.concatenate([one.t, other.t[keep] - 13.0])
    t = t + np.random.default_rng(0).uniform(0.0, 0.05, len(t))
    order = np.argsort(t, kind="stable")
    both = PoseTracks(
        ("I",),
        t[order],
        np.zeros(len(t), dtype=int),
        np.concatenate([one.x, other.x[keep]])[order],
        np.concatenate([one.y, other.y[keep]])[order],
        np.concatenate([one.yaw, other.yaw[keep]])[order],
    )
    auto = auto_step_seconds(_whole_seconds(both), scenario)
    assert auto.seconds == pytest.approx(1.0) and auto.why == "poses"
    assert auto.long_moves > AUTO_LONG_MOVES  # the jumps between the two are not read away


# ---- a record at no healthy pace ---------------------------------------------------------------
def test_a_record_at_its_pace_says_nothing_of_it(scenario):
    """At the step the auto step chooses — a track in jumps, a smooth one, whole-second stamps
    of a steady robot read at the stamps' interval — nothing says the pace is no healthy
    robot's; grid states tell nothing of it."""
    obs = simulate(scenario, 300, seed=1, observability=1.0, random_starts=True).observations
    assert obs.off_pace is None
    jumps = poses_from_trajectories(obs, scenario, step_seconds=1.5, seed=1)
    for tracks in (jumps, _smooth_track(scenario, 0.5), _whole_seconds(_smooth_track(scenario, 1))):
        d = discretise(tracks, scenario, step_seconds="auto")
        assert d.trajectories.off_pace == "", d.auto_step
    assert discretise(jumps, scenario, step_seconds="auto").auto_step.why == "pace"


def _sparse(tracks: PoseTracks, every: float = 2.0) -> PoseTracks:
    """The poses a camera takes once every ``every`` seconds (at the robots' decisions)."""
    keep = np.isclose(np.mod(tracks.t + 1e-9, every), 0.0, atol=1e-6)
    return PoseTracks(
        tracks.robot_names, tracks.t[keep], tracks.robot[keep], tracks.x[keep], tracks.y[keep],
        tracks.yaw[keep],
    )  # fmt: skip


def _pair(scenario, speeds: tuple[float, float]) -> PoseTracks:
    """I and J on the top hallway at ``speeds`` cells a second, J 13 s behind."""
    one, other = (_smooth_track(scenario, v, seconds=600.0) for v in speeds)
    return PoseTracks(
        ("I", "J"),
        np.concatenate([one.t, other.t]),
        np.concatenate([np.zeros(len(one.t), int), np.ones(len(other.t), int)]),
        np.concatenate([one.x, other.x]),
        np.concatenate([one.y, other.y]),
        np.concatenate([one.yaw, other.yaw]),
    )


@pytest.mark.parametrize("fast", [(0.5, 0.25), (0.25, 0.5)])
def test_robots_slowed_down_alike_under_a_sparse_tracker_fit_two_paces(scenario, fast):
    """A camera once every 2 s: two robots crawling a quarter of a cell a second move within
    one cell only at 4 s, the auto step reads them there, and the record says that the poses
    fit two paces; with either robot at half a cell a second, it is the pace at 2 s, no flag."""
    slow = discretise(_sparse(_pair(scenario, (0.25, 0.25))), scenario, step_seconds="auto")
    assert slow.step_seconds == 4.0 and slow.auto_step.why == "multiple"
    assert slow.auto_step.tracker_interval == 2.0 and "a multiple" in slow.auto_step.sentence()
    assert "a multiple of the tracker's interval (2 s)" in slow.trajectories.off_pace
    paced = discretise(_sparse(_pair(scenario, fast)), scenario, step_seconds="auto")
    assert paced.step_seconds == 2.0 and paced.auto_step.why == "poses"
    assert paced.trajectories.off_pace == ""
    given = discretise(_sparse(_pair(scenario, (0.25, 0.25))), scenario, step_seconds=2.0)
    assert given.trajectories.off_pace == ""  # the user says the robots decide every 2 s
    # read one pose a step, the record says at which interval, for the model check to ask
    # whether any robot moves at a healthy pace there; not at a multiple or a step given
    assert paced.trajectories.tracker_interval == 2.0
    assert slow.trajectories.tracker_interval is None
    assert given.trajectories.tracker_interval is None
    assert paced.trajectories.select(paced.trajectories.t < 10).tracker_interval == 2.0


def test_converting_a_record_that_fits_two_paces_warns_that_the_csv_loses_it(
    scenario, tmp_path, capsys
):
    path = tmp_path / "poses.csv"
    write_pose_csv(_sparse(_pair(scenario, (0.25, 0.25))), path)
    code = main(["convert", str(path), str(tmp_path / "grid.csv"), "--scenario", "boyd2"])
    err = capsys.readouterr().err
    assert code == 0 and err.count("mirl: warning:") == 1
    assert "a multiple of the tracker's interval" in err and "poses.csv itself" in err


# ---- a smooth track's decision rhythm ---------------------------------------------------------
def _driven(scenario, position, seconds: float = 600.0, rate: float = 20.0) -> PoseTracks:
    """One robot driving the top hallway of boyd2 back and forth, ``position(t)`` cells along it
    (turning round in place at its ends), tracked at ``rate`` Hz."""
    frame = scenario.map.frame
    cells = [c for c in range(scenario.map.shape[1]) if scenario.map.patroller[0, c]]
    lo, length = min(cells), max(cells) - min(cells)
    t = np.arange(0.0, seconds, 1 / rate)
    phase = np.mod(position(t), 2 * length)
    col = lo + np.where(phase < length, phase, 2 * length - phase)
    yaw = np.where(phase < length, 0.0, np.pi)
    x, y = frame.cell_centre(np.zeros_like(col), col)
    return PoseTracks(("I",), t, np.zeros(len(t), dtype=int), x, y, yaw)


def _stop_and_go(decision: float = 2.0, drive: float = 1.5, offset: float = 0.3):
    """A robot that decides every ``decision`` s, drives one cell in ``drive`` s (a smooth
    start and stop) and waits for its next decision."""

    def position(t):
        k, tau = np.divmod(t - offset, decision)
        return k + (1 - np.cos(np.pi * np.minimum(tau, drive) / drive)) / 2

    return position


def _drive_on(speed: float = 0.3):
    """A robot that never finishes a move within a decision: it drives on at about ``speed``
    cells a second, the speed wandering (incommensurate periods, no rhythm)."""

    def position(t):
        wander = 0.3 * np.sin(t / 7.3) + 0.2 * np.sin(t / 2.9 + 1.0) + 0.1 * np.sin(t / 1.13)
        return speed * (t + wander)

    return position


def _team(*tracks: PoseTracks) -> PoseTracks:
    names = ("I", "J", "K")[: len(tracks)]
    return PoseTracks(
        names,
        np.concatenate([tr.t for tr in tracks]),
        np.concatenate([np.full(len(tr.t), i) for i, tr in enumerate(tracks)]),
        np.concatenate([tr.x for tr in tracks]),
        np.concatenate([tr.y for tr in tracks]),
        np.concatenate([tr.yaw for tr in tracks]),
    )


def _rhythm(scenario, tracks: PoseTracks, step: float) -> float:
    rf, cf = scenario.map.frame.cell_coordinates(tracks.x, tracks.y)
    return rhythm_strength(tracks.t, rf, cf, tracks.yaw, step)


def _noisy(tracks: PoseTracks, sigma_m: float, sigma_deg: float, seed: int = 0) -> PoseTracks:
    rng = np.random.default_rng(seed)
    n = len(tracks.t)
    return PoseTracks(
        tracks.robot_names, tracks.t, tracks.robot, tracks.x + rng.normal(0, sigma_m, n),
        tracks.y + rng.normal(0, sigma_m, n), tracks.yaw + np.deg2rad(rng.normal(0, sigma_deg, n)),
    )  # fmt: skip


@pytest.mark.parametrize("decision", [1.5, 2.0, 3.0])
@pytest.mark.parametrize("noise", [(0.0, 0.0), (0.05, 3.0)])
def test_a_robot_that_stops_onto_its_cells_keeps_the_rhythm_of_its_decisions(
    scenario, decision, noise
):
    """Motion that starts and stops at every decision concentrates in phase at the decision
    interval, and at no step a tenth or more away from it; a robot that drives on keeps no
    rhythm at all. A tracker's noise of 5 cm and 3° (20 Hz) changes neither."""
    go = _noisy(_driven(scenario, _stop_and_go(decision, drive=0.75 * decision)), *noise)
    assert _rhythm(scenario, go, decision) > 2 * RHYTHM_FACTOR
    assert _rhythm(scenario, go, 1.1 * decision) < RHYTHM_FACTOR
    assert _rhythm(scenario, go, 1.55 * decision) < RHYTHM_FACTOR
    on = _noisy(_driven(scenario, _drive_on(1 / decision)), *noise)
    assert _rhythm(scenario, on, decision) < RHYTHM_FACTOR


def test_robots_that_drive_on_through_their_decisions_fit_two_paces(scenario):
    """Two robots that never finish a move in time, tracked smoothly: the auto step reads them
    at the faster one's pace, no robot keeps a rhythm there, and the record says the poses fit
    two paces; beside one robot that stops onto its cells, the pace is its rhythm and nothing
    is said; a step the user gives is not second-guessed."""
    slow = _team(_driven(scenario, _drive_on(0.3)), _driven(scenario, _drive_on(0.25)))
    d = discretise(slow, scenario, step_seconds="auto")
    assert d.auto_step.found and d.auto_step.why == "pace" and d.auto_step.rhythm is False
    assert "no robot's moves keep a rhythm" in d.trajectories.off_pace
    assert f"{d.step_seconds:g} s" in d.trajectories.off_pace
    paced = _team(_driven(scenario, _stop_and_go(2.0)), _driven(scenario, _drive_on(0.3)))
    d = discretise(paced, scenario, step_seconds="auto")
    assert d.step_seconds == pytest.approx(2.0, abs=0.051) and d.auto_step.rhythm is True
    assert d.trajectories.off_pace == ""
    given = discretise(slow, scenario, step_seconds=2.0)
    assert given.auto_step is None and given.trajectories.off_pace == ""


def _physical_team(damage: dict[str, float], seed: int, steps: int = 200):
    """A boyd2-healthy team in the physical world at full view: its true poses (L's left out)
    and the scenario."""
    from mirl.physics.config import with_motor_strength
    from mirl.physics.patrol import PhysicalWorld

    sc = load_scenario("boyd2-healthy")
    for robot, strength in damage.items():
        wheel = "right_wheel" if robot == "I" else "left_wheel"
        sc = with_motor_strength(sc, robot, wheel, strength)
    world = PhysicalWorld(sc, observability=1.0, seed=seed)
    for _ in range(steps - 1):
        world.step()
    tracks = world.true_tracks()
    keep = tracks.robot < len(sc.robot_names)
    return sc, PoseTracks(sc.robot_names, tracks.t[keep], tracks.robot[keep], tracks.x[keep],
                          tracks.y[keep], tracks.yaw[keep])  # fmt: skip


@pytest.mark.parametrize("seed", [11, 12])
def test_physical_robots_keep_their_rhythm_unless_every_motor_is_weak(seed):
    """The physical world's true poses at the control rate: a healthy robot stops onto its cells
    at its decisions, and its rhythm is strong at the step chosen (3.58–4.63 times the
    yardstick on boyd2-healthy in `benchmarks/bench_rhythm.py`, seeds 1–3); a team whose motors
    are all at 0.6 drives on (0.53–1.09 there) and its record says it fits two paces. A margin
    of almost two either side of the threshold, so that a CPU whose simulation differs in its
    last bits gives the same answer."""
    sc, healthy = _physical_team({}, seed)
    d = discretise(healthy, sc, step_seconds="auto")
    assert d.step_seconds == pytest.approx(2.0, abs=0.051) and d.trajectories.off_pace == ""
    sc, slow = _physical_team({"I": 0.6, "J": 0.6}, seed)
    d = discretise(slow, sc, step_seconds="auto")
    assert d.step_seconds > 2.5 and d.auto_step.rhythm is False
    assert "no robot's moves keep a rhythm" in d.trajectories.off_pace


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.0, 1e4), min_size=0, max_size=60),
    st.floats(0.1, 10.0),
    st.integers(0, 2**32 - 1),
)
def test_the_rhythm_of_any_track_is_a_finite_ratio(times, step, seed):
    """Any sorted times (repeated stamps, gaps, a handful of poses) and any positions: the
    strength is finite and non-negative, and a track that never moves has none."""
    rng = np.random.default_rng(seed)
    t = np.sort(np.asarray(times, dtype=float))
    row, col, yaw = (rng.normal(0, 3, len(t)) for _ in range(3))
    strength = rhythm_strength(t, row, col, yaw, step)
    assert np.isfinite(strength) and strength >= 0
    still = np.zeros(len(t))
    assert rhythm_strength(t, still, still, still, step) == 0.0


def test_stamps_a_few_ulps_apart_are_no_motion_and_raise_no_float_warning():
    """Two poses 5e-324 s apart would move at ~1e308 cells a second; that span is left out
    (no overflow warning) and the spans a tracker measures still give a strength."""
    rng = np.random.default_rng(0)
    t = np.concatenate([[0.0, 5e-324], 1.0 + np.arange(200.0)])  # a span per pose: lag 1
    row, col, yaw = (rng.normal(0, 3, len(t)) for _ in range(3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        strength = rhythm_strength(t, row, col, yaw, 2.0)
    assert np.isfinite(strength) and strength > 0


def test_converting_a_smooth_track_with_no_rhythm_warns_that_the_csv_loses_it(
    scenario, tmp_path, capsys
):
    """`mirl convert` says that the grid CSV it writes cannot carry the doubt about the pace,
    once; beside a robot that stops onto its cells it says nothing."""
    slow, paced = tmp_path / "slow.csv", tmp_path / "paced.csv"
    write_pose_csv(_team(_driven(scenario, _drive_on(0.3)), _driven(scenario, _drive_on(0.25))),
                   slow)  # fmt: skip
    write_pose_csv(_team(_driven(scenario, _stop_and_go(2.0)), _driven(scenario, _drive_on(0.3))),
                   paced)  # fmt: skip
    code = main(["convert", str(slow), str(tmp_path / "grid.csv"), "--scenario", "boyd2"])
    err = capsys.readouterr().err
    assert code == 0 and err.count("mirl: warning:") == 1
    assert "no robot's moves keep a rhythm" in err and "slow.csv itself" in err
    code = main(["convert", str(paced), str(tmp_path / "grid2.csv"), "--scenario", "boyd2"])
    assert code == 0 and "mirl: warning:" not in capsys.readouterr().err
