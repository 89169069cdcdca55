"""What a physical run records: grid states per decision step as trajectories, the tick poses
only when kept, and L's camera measurements as pose tracks."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.physics.records import OBSERVER, Records
from mirl.world.scenario import load_scenario

SC = load_scenario("boyd2")
DOM = SC.domain


def _records(has_observer=True, record_ticks=True):
    rec = Records(DOM, SC.robot_names, has_observer, record_ticks)
    s = DOM.state_index(0, 1, 0), DOM.state_index(16, 1, 1)
    rec.true += [np.array(s), np.array([s[0] + 4, s[1]])]
    rec.seen += [np.array([s[0], -1]), np.array([-1, -1])]
    rec.seen_lateral += [np.array([0.1, np.nan]), np.array([np.nan, np.nan])]
    return rec, s


def test_grid_states_become_trajectories_with_their_lateral_offsets():
    rec, (s0, s1) = _records()
    np.testing.assert_array_equal(rec.true_states(), [[s0, s1], [s0 + 4, s1]])
    truth = rec.truth()
    assert truth.horizon == 2
    assert truth.state_series(DOM, 0).tolist() == [s0, s0 + 4]
    seen = rec.observations()
    assert seen.state_series(DOM, 0).tolist() == [s0, -1]
    assert seen.state_series(DOM, 1).tolist() == [-1, -1]
    assert seen.lateral.tolist() == [pytest.approx(0.1)]
    assert rec.observations(until=0).horizon == 1


def test_tick_poses_are_kept_only_when_asked_for():
    rec, _ = _records(record_ticks=True)
    poses = np.zeros((rec.m, 3))
    rec.tick(0.1, poses)
    rec.tick(0.2, poses + 1)
    times, kept = rec.tick_poses()
    assert times.tolist() == [0.1, 0.2] and kept.shape == (2, 3, 3) and rec.m == 3
    tracks = rec.true_tracks()
    assert tracks.robot_names[-1] == OBSERVER and len(tracks.t) == 6
    off, _ = _records(record_ticks=False)
    off.tick(0.1, poses)
    times, kept = off.tick_poses()
    assert times.shape == (0,) and kept.shape == (0, 3, 3)


def test_camera_measurements_are_pose_tracks_of_the_patrollers():
    rec, _ = _records(has_observer=False)
    assert rec.m == 2
    assert rec.observed_rows().shape == (0, 5)
    rec.measured([(2.0, 1, 3.0, -4.0, 0.5)])
    rec.measured([(4.0, 0, 1.0, 0.0, -0.5), (4.0, 1, 3.5, -4.0, 0.4)])
    np.testing.assert_allclose(rec.observed_rows()[:, 0], [2.0, 4.0, 4.0])
    tracks = rec.observed_tracks()
    assert tracks.robot_names == SC.robot_names
    assert tracks.robot.tolist() == [1, 0, 1] and tracks.source == "L's camera"
