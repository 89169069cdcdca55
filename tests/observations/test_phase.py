"""The phase of a record's steps (:mod:`mirl.observations.phase`)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.observations.phase import PHASE_MIN_CHANGES, cell_changes, step_phase


def test_cell_changes_are_the_midpoints_of_the_poses_around_them():
    t = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 0.0, 1.0])
    row = np.array([0, 0, 1, 1, 2, 5, 5])
    col = np.array([0, 0, 0, 0, 0, 5, 6])
    mids, gaps = cell_changes(t, row, col, [np.arange(5), np.array([5, 6])])
    np.testing.assert_allclose(mids, [0.75, 1.75, 0.5])
    np.testing.assert_allclose(gaps, [0.5, 0.5, 1.0])


@settings(max_examples=60, deadline=None)
@given(
    step=st.sampled_from([1.0, 2.0, 3.0]),
    phase=st.floats(0.0, 0.999),
    first=st.floats(-1e3, 1e3),
    n=st.integers(PHASE_MIN_CHANGES, 40),
)
def test_steps_fall_halfway_between_changes_that_keep_a_rhythm(step, phase, first, n):
    """Changes of cell at one phase of every step put step 0 half a step from that phase,
    within half a step of the earliest pose."""
    rng = np.random.default_rng(n)
    k = np.sort(rng.choice(200, size=n, replace=False))
    mids = first + (k + phase) * step
    start = step_phase((mids, np.full(n, 0.1)), first, step, 0.0)
    assert first - step / 2 - 1e-6 <= start < first + step / 2 + 1e-6
    # every change lies halfway between two steps
    off = ((mids - start) / step) % 1.0
    np.testing.assert_allclose(off, 0.5, atol=1e-5)


def test_no_rhythm_few_changes_or_a_sparse_tracker_keep_the_earliest_pose():
    rng = np.random.default_rng(0)
    spread = (rng.uniform(0, 100, 200), np.full(200, 0.1))  # a smooth track: any phase
    assert step_phase(spread, 3.0, 2.0, 0.1) == 3.0
    few = (np.array([1.2, 3.2, 5.2]), np.full(3, 0.1))
    assert step_phase(few, 0.0, 2.0, 0.1) == 0.0
    rhythm = (np.arange(10) * 2.0 + 1.3, np.full(10, 0.1))
    assert step_phase(rhythm, 0.0, 2.0, 1.0) == 0.0  # poses at most twice a step: theirs
    assert step_phase(rhythm, 0.0, 2.0, 0.1) == pytest.approx(0.3)
    # a change across a gap longer than a step has no known time and sets nothing
    gapped = (np.arange(10) * 2.0 + 1.3, np.full(10, 5.0))
    assert step_phase(gapped, 0.0, 2.0, 0.1) == 0.0
