"""Discretisation of pose tracks onto the grid: space, heading, time, gaps, snapping, frames."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import mirl
from mirl.observations.discretise import (
    DiscretisationError,
    discretise,
    heading_of_yaw,
    poses_from_trajectories,
)
from mirl.observations.poses import PoseTracks
from mirl.simulation.grid import simulate
from mirl.world.maps import MapFrame
from mirl.world.scenario import load_scenario

FIELDS = ("t", "robot", "row", "col", "heading")


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("boyd2")


def same(a, b):
    return a.horizon == b.horizon and all(
        np.array_equal(getattr(a, f), getattr(b, f)) for f in FIELDS
    )


def poses(rows, names=("I", "J")):
    """rows of (t, robot index, x, y, yaw)."""
    a = np.asarray(rows, dtype=float).reshape(-1, 5)
    return PoseTracks(names, a[:, 0], a[:, 1].astype(int), a[:, 2], a[:, 3], a[:, 4], "test")


def test_heading_of_yaw():
    yaw = [0, 0.7, 0.8, math.pi / 2, math.pi, -math.pi, -math.pi / 2, 2 * math.pi, -0.7]
    assert heading_of_yaw(yaw).tolist() == [0, 0, 1, 1, 2, 2, 3, 0, 0]


@pytest.mark.parametrize("degree", [0.14, 0.5, 1.0])
@pytest.mark.parametrize("rate", [1.0, 7.5, 30.0])
def test_simulated_poses_come_back_as_the_observations(scenario, degree, rate):
    res = simulate(scenario, 300, seed=2, observability=degree)
    obs = res.observations
    for sigma, deg in ((0.0, 0.0), (0.05, 3.0)):
        p = poses_from_trajectories(
            obs, scenario, rate_hz=rate, sigma_xy=sigma, sigma_yaw_degrees=deg, seed=1
        )
        d = discretise(p, scenario, start_time=0.0, n_steps=obs.horizon)
        assert same(d.trajectories, obs)
        assert [c.observed_steps for c in d.report] == np.bincount(obs.robot, minlength=2).tolist()
        assert sum(c.read for c in d.report) == len(p)


def same_steps(read, obs, k: int) -> bool:
    """Whether ``read`` holds the observed steps of ``obs`` from step ``k`` on, renumbered from
    0 (the watch of a record read from its poses ends at the last pose)."""
    return np.array_equal(read.t, obs.t - k) and all(
        np.array_equal(getattr(read, f), getattr(obs, f)) for f in FIELDS[1:]
    )


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("step", ["auto", 2.0])
def test_simulated_poses_come_back_without_a_start_time(scenario, seed, step):
    """A pose file read without ``start_time`` gives the observations a start at 0 gives, from
    the first step seen: the default start is the earliest pose moved to the record's own
    phase. At the earliest pose itself — half a step before the first observed step's time,
    which is where ``mirl simulate --poses`` writes it — every stretch in view gained a step
    on the last cell seen, a stall no robot made (I's healthy wheels learned at 0.73 and 0.83
    on boyd2, seed 1, 450 steps)."""
    obs = simulate(scenario, 300, seed=seed).observations
    first = int(obs.t.min())
    p = poses_from_trajectories(obs, scenario, rate_hz=10.0, sigma_xy=0.05,
                                sigma_yaw_degrees=3.0, seed=seed)  # fmt: skip
    d = discretise(p, scenario, step_seconds=step)
    assert d.start_time == pytest.approx(2.0 * first)
    assert d.phased and "halfway between the robots' changes of cell" in d.summary()
    assert same_steps(d.trajectories, obs, first)
    assert [c.observed_steps for c in d.report] == np.bincount(obs.robot, minlength=2).tolist()


def test_a_record_in_other_time_units_is_read_alike(scenario):
    """Stamps in milliseconds change the step read (2000 "s", its robots' jumps), not the
    steps: the phase scales with them."""
    scale = 1e3
    obs = simulate(scenario, 450, seed=1).observations
    p = poses_from_trajectories(obs, scenario, rate_hz=10.0)
    d = discretise(p, scenario, step_seconds="auto")
    scaled = discretise(dataclasses.replace(p, t=p.t * scale), scenario, step_seconds="auto")
    assert scaled.step_seconds == pytest.approx(d.step_seconds * scale)
    assert same(scaled.trajectories, d.trajectories)


def test_a_sparse_trackers_poses_keep_their_times(scenario):
    """One pose a step (a camera at the robots' decisions) already lies at the steps' times:
    the start stays on the earliest pose."""
    obs = simulate(scenario, 300, seed=1).observations
    p = poses_from_trajectories(obs, scenario, rate_hz=0.5)
    d = discretise(p, scenario, step_seconds="auto")
    assert not d.phased and d.start_time == pytest.approx(p.t.min())
    assert same_steps(d.trajectories, obs, int(obs.t.min()))


def test_nearest_pose_tolerance_and_gaps(scenario):
    # I on (0, 1)..(0, 4) heading east; steps of 2 s from t = 10
    p = poses(
        [
            (10.0, 0, 1, 0, 0),
            (11.9, 0, 2, 0, 0),  # nearest to step 1 (12 s), 0.1 s off
            (12.6, 0, 3, 0, 0),  # also near step 1 but 0.6 s off: not chosen
            (19.5, 0, 4, 0, 0),  # step 5 (20 s), 0.5 s off
        ]
    )
    d = discretise(p, scenario, start_time=10.0)
    tr = d.trajectories
    assert tr.horizon == 6
    assert tr.t.tolist() == [0, 1, 5] and tr.col.tolist() == [1, 2, 4]
    assert (d.report[0].binned, d.report[0].observed_steps) == (4, 3)
    assert d.report[1].read == 0 and d.report[1].observed_steps == 0
    # a tighter tolerance: the 0.5 s-off pose no longer counts; steps 2-4 never interpolated
    d = discretise(p, scenario, start_time=10.0, tolerance=0.2)
    assert d.trajectories.t.tolist() == [0, 1] and d.trajectories.horizon == 6
    assert d.report[0].binned == 2
    # an earlier start (L watched before I was seen): steps shift, leading steps unobserved
    d = discretise(p, scenario, start_time=6.0)
    assert d.trajectories.t.tolist() == [2, 3, 7] and d.trajectories.horizon == 8
    # poses before the start or after n_steps are read but not binned
    d = discretise(p, scenario, start_time=12.0, n_steps=2)
    assert d.trajectories.t.tolist() == [0] and d.report[0].binned == 2
    assert d.last_pose == 19.5  # read, not taken: what a later start is measured against
    # a start after every pose: an empty record (the CLI names its --start-time by last_pose)
    d = discretise(p, scenario, start_time=21.5)
    assert len(d.trajectories) == 0 and d.last_pose == 19.5
    assert discretise(poses([]), scenario).last_pose is None


def test_a_tolerance_over_half_a_step_is_refused_not_ignored(scenario):
    """A pose is a candidate for its nearest step only, so a tolerance past half a step would
    change nothing while the summary stated it: refused, naming the step (and, at
    ``"auto"``, that the step was chosen); half a step exactly is the default's value."""
    p = poses([(10.0, 0, 1, 0, 0), (11.9, 0, 2, 0, 0), (19.5, 0, 4, 0, 0)])
    refused = "`tolerance` 1.5 s is more than half the step of 2 s: "
    with pytest.raises(DiscretisationError, match=refused):
        discretise(p, scenario, start_time=10.0, tolerance=1.5)
    with pytest.raises(DiscretisationError, match="chosen from the robots' pace"):
        discretise(p, scenario, step_seconds="auto", tolerance=1.5)
    d = discretise(p, scenario, start_time=10.0, tolerance=1.0)
    assert d.tolerance == 1.0 and d.trajectories.t.tolist() == [0, 1, 5]


def test_snapping_dropping_and_errors(scenario):
    # (0, 3) is hallway, (1, 3) wall; x = col, y = -row
    p = poses([(0.0, 0, 3.0, -0.95, 0.0), (2.0, 0, 3.4, -1.2, 0.0), (4.0, 0, 12.0, 0.0, 0.0)])
    with pytest.raises(DiscretisationError) as e:
        discretise(p, scenario)
    msg = str(e.value)
    assert msg.startswith("test: robot I:") and "(3.400, -1.200)" in msg and "\n" not in msg
    d = discretise(p, scenario, drop_off_map=True)
    tr = d.trajectories
    assert tr.t.tolist() == [0] and (tr.row[0], tr.col[0]) == (0, 3)
    c = d.report[0]
    assert (c.read, c.binned, c.snapped, c.dropped, c.observed_steps) == (3, 3, 1, 2, 1)
    # off the map, within half a cell of the hallway end (0, 8): snaps
    d = discretise(poses([(0.0, 1, 8.9, 0.2, 0.0)]), scenario)
    assert (d.trajectories.row[0], d.trajectories.col[0]) == (0, 8)
    assert d.report[1].snapped == 1


def test_unknown_robot_nan_and_bad_arguments(scenario):
    with pytest.raises(DiscretisationError, match="robot 'K' is not in the scenario"):
        discretise(poses([(0, 0, 1, 0, 0)], names=("K",)), scenario)
    with pytest.raises(DiscretisationError, match="robot I: NaN"):
        discretise(poses([(0, 0, float("nan"), 0, 0)]), scenario)
    with pytest.raises(DiscretisationError, match="step_seconds"):
        discretise(poses([(0, 0, 1, 0, 0)]), scenario, step_seconds=0)


def test_map_frame_origin_and_cell_size(scenario, tmp_path):
    frame = MapFrame(cell_size=0.5, origin_x=-3.0, origin_y=2.0)
    moved = dataclasses.replace(scenario, map=dataclasses.replace(scenario.map, frame=frame))
    # centre of (16, 4): x = -3 + 4 * 0.5 = -1, y = 2 - 16 * 0.5 = -6
    x, y = frame.cell_centre(16, 4)
    assert (float(x), float(y)) == (-1.0, -6.0)
    d = discretise(poses([(0, 1, -1.1, -5.9, math.pi / 2)]), moved)
    tr = d.trajectories
    assert (tr.row[0], tr.col[0], tr.heading[0]) == (16, 4, 1)
    # the same frame from a scenario file's [frame] table
    text = (Path(mirl.__file__).parent / "data" / "scenarios" / "boyd2.toml").read_text()
    path = tmp_path / "framed.toml"
    path.write_text(
        text.replace(
            'map = "boyd2"', 'map = "boyd2"\nframe = { cell_size = 0.5, origin = [-3.0, 2.0] }'
        )
    )
    framed = load_scenario(path)
    assert framed.map.frame == frame
    assert same(discretise(poses([(0, 1, -1.1, -5.9, math.pi / 2)]), framed).trajectories, tr)
    # ... and the default frame puts that pose far off the hallway
    with pytest.raises(DiscretisationError, match="more than 0.5 cell"):
        discretise(poses([(0, 1, -1.1, -5.9, math.pi / 2)]), scenario)


def test_visible_cells(scenario):
    p = poses([(0.0, 0, 1, 0, 0), (0.0, 1, 1, -16, 0)])
    d = discretise(p, scenario)
    np.testing.assert_array_equal(d.visible, scenario.map.visible_mask(scenario.observability))
    assert [c.outside_visible for c in d.report] == [0, 1]  # (16, 1) is not visible at 0.14
    states = d.visible_states(scenario)
    np.testing.assert_array_equal(states, scenario.domain.visible_states(scenario.observability))
    d = discretise(p, scenario, visible="observed")
    assert d.visible.sum() == 2 and [c.outside_visible for c in d.report] == [0, 0]


def test_ros_map_frame_from_yaml(tmp_path):
    """A map_server map: origin = lower-left corner of the image; row 0 is the image top."""
    import yaml
    from PIL import Image

    from mirl.world.ros_maps import load_ros_map

    base = load_scenario("boyd2").map
    # boyd2 at 0.1 m per pixel, 1 m cells: 170 x 90 pixels
    px = np.kron(base.free.astype(np.uint8), np.ones((10, 10), dtype=np.uint8)).astype(bool)
    Image.fromarray(np.where(px, 254, 0).astype(np.uint8), mode="L").save(tmp_path / "m.pgm")
    yml = tmp_path / "m.yaml"
    yml.write_text(
        yaml.safe_dump(
            {
                "image": "m.pgm",
                "resolution": 0.1,
                "origin": [-2.0, -3.0, 0.0],
                "negate": 0,
                "occupied_thresh": 0.65,
                "free_thresh": 0.196,
                "mirl_observer_start": [0, 0],
                "mirl_goals": [[9, 1]],
            }
        )
    )
    gridmap = load_ros_map(yml, cell_size=1.0)
    # top of the image: y = -3 + 17 m; centre of cell (0, 0): 0.5 m in from the corner
    assert gridmap.frame == MapFrame(cell_size=1.0, origin_x=-1.5, origin_y=13.5)
    scenario = dataclasses.replace(load_scenario("boyd2"), map=gridmap)
    # the lower hallway's east end, cell (16, 8), spans x in [6, 7], y in [-3, -2]
    d = discretise(poses([(0.0, 1, 6.9, -2.1, 0.0)]), scenario)
    tr = d.trajectories
    assert (tr.row[0], tr.col[0]) == (16, 8)


def test_lateral_offset_is_left_of_the_heading_and_snapped_poses_have_none(scenario):
    # (0, 3) is a hallway cell centred at x = 3, y = 0; (1, 3) is wall below it
    p = poses(
        [
            (0.0, 0, 3.0, 0.2, 0.0),  # facing east, 0.2 north: 0.2 to its left
            (2.0, 0, 3.1, 0.0, math.pi / 2),  # facing north, 0.1 east: 0.1 to its right
            (4.0, 0, 2.9, -0.05, math.pi),  # facing west, 0.05 south: 0.05 to its left
            (6.0, 0, 3.0, -0.95, -math.pi / 2),  # on the wall below, snapped onto (0, 3)
        ]
    )
    tr = discretise(p, scenario).trajectories
    np.testing.assert_allclose(tr.lateral[:3], [0.2, -0.1, 0.05], atol=1e-12)
    assert np.isnan(tr.lateral[3])
    series = tr.lateral_series(0)
    assert series.shape == (tr.horizon,)
    np.testing.assert_allclose(series[:3], [0.2, -0.1, 0.05], atol=1e-12)
    # selecting rows keeps the offsets with them; grid records have none
    assert tr.select(tr.t >= 1).lateral.tolist()[:2] == tr.lateral[1:3].tolist()
    assert simulate(scenario, 20, seed=0).observations.lateral_series(0) is None


def _in_degrees(p: PoseTracks) -> PoseTracks:
    return dataclasses.replace(p, yaw=np.rad2deg(p.yaw))


@pytest.mark.parametrize("seed", range(4))
def test_yaws_in_degrees_are_refused_and_radians_are_not(scenario, seed):
    """Yaws written in degrees would be read as radians, headings pointing nowhere in
    particular; the refusal names the share of moves each reading points along."""
    obs = simulate(scenario, 300, seed=seed, observability=1.0).observations
    p = poses_from_trajectories(obs, scenario, rate_hz=10.0, sigma_xy=0.05,
                                sigma_yaw_degrees=5.0, seed=seed)  # fmt: skip
    assert same(discretise(p, scenario, start_time=0.0, n_steps=obs.horizon).trajectories, obs)
    with pytest.raises(DiscretisationError, match=r"read as degrees: give yaw in radians"):
        discretise(_in_degrees(p), scenario, start_time=0.0, n_steps=obs.horizon)


def test_yaws_that_fit_neither_reading_are_left_to_the_model_check(scenario):
    """A tracker that writes no heading (every yaw 0) and too few moves are not refused."""
    obs = simulate(scenario, 300, seed=0, observability=1.0).observations
    p = poses_from_trajectories(obs, scenario, rate_hz=10.0, seed=0)
    flat = dataclasses.replace(p, yaw=np.zeros_like(p.yaw))
    d = discretise(flat, scenario, start_time=0.0, n_steps=obs.horizon)
    assert (d.trajectories.heading == 0).all()
    short = discretise(_in_degrees(p), scenario, start_time=0.0, n_steps=8)  # < 20 moves
    assert short.trajectories.horizon == 8
