"""The phase of a record's steps: where, within a step, robots that act in steps change cells.

A robot that acts in steps changes cells once a step, at the same phase of every step, halfway
between two of its decisions; steps put there read each state whole, and steps put anywhere
else read the end of one move and the start of the next
(:func:`mirl.observations.discretise.phased_start`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PHASE_CONCENTRATION", "PHASE_MIN_CHANGES", "cell_changes", "step_phase"]

PHASE_MIN_CHANGES = 5
"""Fewer changes of cell (at most a step apart) than this do not set the steps' phase: a few
stretches in view with a move or two each already tell it."""
PHASE_CONCENTRATION = 0.5
"""The robots' changes of cell set the steps' phase when their phases, as angles of the step,
average to a vector at least this long (1: all at one phase; 0: spread evenly, as on a smooth
track at a speed of its own)."""


def cell_changes(t, row, col, robots) -> tuple[np.ndarray, np.ndarray]:
    """Every change of cell of a robot's track.

    Parameters
    ----------
    t : ndarray of float, shape (n,)
        The poses' times (s).
    row, col : ndarray of int, shape (n,)
        The cells they lie in.
    robots : list of ndarray of int
        Per robot the indices of its poses, sorted by time.

    Returns
    -------
    midpoints : ndarray of float
        The midpoint of the two consecutive poses of a robot each change lies between.
    gaps : ndarray of float
        The time between those two poses.
    """
    mids, gaps = [np.zeros(0)], [np.zeros(0)]
    for idx in robots:
        ti = t[idx]
        moved = (row[idx][1:] != row[idx][:-1]) | (col[idx][1:] != col[idx][:-1])
        mids.append((0.5 * (ti[1:] + ti[:-1]))[moved])
        gaps.append(np.diff(ti)[moved])
    return np.concatenate(mids), np.concatenate(gaps)


def step_phase(
    changes: tuple[np.ndarray, np.ndarray], first: float, step: float, interval: float
) -> float:
    """The time of step 0 nearest ``first`` at which the changes of cell lie halfway between
    steps.

    The phase is the mean of the changes' phases as angles of the step, each change taken where
    its two poses are at most a step apart (a change across a gap has no known time), rounded
    to a whole number of pose intervals from ``first`` so that the steps stay on the poses'
    times. With fewer than :data:`PHASE_MIN_CHANGES` of them, or a mean vector shorter than
    :data:`PHASE_CONCENTRATION`, there is none to keep, and step 0 is at ``first``; so it is
    for a tracker that reports at most twice a step, whose poses are the steps' times.

    Parameters
    ----------
    changes : tuple of ndarray
        The changes' midpoints and gaps (:func:`cell_changes`).
    first : float
        The earliest pose's time (s).
    step : float
        The step (s).
    interval : float
        The time (s) between a robot's consecutive poses (0: unknown).

    Returns
    -------
    float
        The time (s) of step 0, within half a step of ``first``, so that the earliest pose falls
        on step 0 (or, at a tie, step 1).
    """
    mids, gaps = changes
    near = mids[gaps <= step * (1 + 1e-9)] - first
    if len(near) < PHASE_MIN_CHANGES or not step > 0 or interval >= step / 2:
        return first
    mean = np.exp(2j * np.pi * (near / step)).mean()
    if abs(mean) < PHASE_CONCENTRATION:
        return first
    # the changes lie halfway between steps: step 0 half a step from the mean change's phase
    offset = float((np.angle(mean) / (2 * np.pi) * step + step / 2) % step)
    if interval > 0:
        offset = round(offset / interval) * interval
    offset = round(offset, 6)
    if offset >= step / 2:  # the earliest pose falls on step 0 (or, at a tie, step 1)
        offset -= step
    return first + offset
