"""What ``learn`` and ``run`` will cost, known before any work (docs/design.md, "Cost before
work"): peak memory and time estimated from the number of states, robots, observed steps and
L's planning horizon, and a budget a command is refused over, in one line that names the state
count, the estimate and a cell size that fits.

The estimates are linear in the states because the learner's and the planner's memory is
(docs/design.md, "Memory linear in the states"); their constants are fitted to measured runs
(``python benchmarks/bench_cost.py`` prints estimate against measurement) and rounded up, so
that an estimate is an upper bound on the machines measured rather than a best guess.
"""

from __future__ import annotations

import math
import os
from collections import deque
from dataclasses import dataclass

import numpy as np

from mirl.experiments.options import RunProtocol
from mirl.world.domain import N_HEADINGS
from mirl.world.maps import HEADING_DELTAS
from mirl.world.scenario import Scenario

__all__ = [
    "CostEstimate",
    "CostError",
    "estimate_cost",
    "check_budget",
    "default_max_memory",
    "planning_horizon",
]

# bytes: the interpreter with numpy, scipy and mirl's stages imported
BASE_MEMORY = 120 * 2**20
# bytes per patroller state and robot: learning (transitions, features, per-robot solvers)
LEARN_BYTES_PER_STATE = 2_500
# bytes per state of L and the patrollers while planning: the factored filter's checkpoints and
# block of hazards, L's transition entries and one step of its values
PLAN_BYTES_PER_STATE = 6_000
# seconds per patroller state and robot whatever the record's length (learning's solves: the
# IRL's soft value iterations, the policies), per state, robot and observed step (the filters
# over the record), and per state and planned step (planning). The fixed part dominates on large
# maps: a two-step record on Willow Garage at 0.1 m (873 656 state-robots) still learns for
# minutes.
LEARN_SECONDS_PER_STATE = 3.0e-4
LEARN_SECONDS_PER_STATE_STEP = 1.0e-7
# seconds per robot and step of the record whatever the map: on a small map the per-step work of
# the IRL's passes over the record outweighs the states' (boyd2, 124 states, 2 robots: 0.9 ms a
# step measured from records of 2 000 to 10 000 steps, one stray row setting their length)
LEARN_SECONDS_PER_ROBOT_STEP = 1.0e-3
# an estimate longer than this is said before the work (`mirl learn`), not only in a refusal
LONG_SECONDS = 60.0
PLAN_SECONDS_PER_STATE_STEP = 1.5e-7


class CostError(ValueError):
    """A command whose estimated cost exceeds its budget (one line, names `max_memory`)."""


@dataclass(frozen=True)
class CostEstimate:
    """The estimated peak memory (bytes) and time (seconds) of one command.

    Parameters
    ----------
    command : {"learn", "run"}
        The command estimated.
    cells : int
        The patrollers' cells.
    states : int
        The patrollers' states (cells × headings).
    robots : int
        The patrollers.
    steps : int
        Observed steps.
    horizon : int
        L's planning horizon (0 for ``learn``).
    memory : int
        The peak memory, bytes.
    seconds : float
        The wall time, seconds.
    """

    command: str  # "learn" or "run"
    cells: int  # the patrollers' cells
    states: int  # the patrollers' states (cells × headings)
    robots: int
    steps: int  # observed steps
    horizon: int  # L's planning horizon (0 for learn)
    memory: int
    seconds: float

    def describe(self) -> str:
        """The estimate in words, for a refusal or ``--dry-run``.

        Returns
        -------
        str
            ``"124 states (31 cells x 4 headings), 2 robots: about 123 MB and 1 s"``.
        """
        return (
            f"{self.states:,} states ({self.cells:,} cells x {N_HEADINGS} headings), "
            f"{self.robots} robots: about {_size(self.memory)} and {_duration(self.seconds)}"
        )


def default_max_memory() -> int:
    """Half of the machine's physical memory: the other half is left to the system and to
    whatever else runs (a sweep's workers, a second run), and a run that needs more than half
    a machine is better refused at once than swapped or killed late.

    Returns
    -------
    int
        Bytes (half of 8 GB where the machine does not say).
    """
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # not POSIX: assume a small machine
        total = 8 * 2**30
    return int(total // 2)


def planning_horizon(scenario: Scenario, protocol: RunProtocol | None = None) -> int:
    """About L's planning horizon of a run: the go window plus the travel after it (by default
    3 × L's shortest path, at least 20: :meth:`~mirl.experiments.options.RunProtocol.travel`),
    the path in cells by a breadth-first search over the free cells (no states built; the
    run's path also counts L's turns, a few per cent more).

    Parameters
    ----------
    scenario : Scenario
        The scenario (its map, L's start and goal).
    protocol : RunProtocol, optional
        The run's protocol (its window and travel); the default protocol if None.

    Returns
    -------
    int
        Steps.
    """
    protocol = RunProtocol() if protocol is None else protocol
    gm = scenario.map
    free = gm.patroller | gm.observer_only
    assert scenario.observer_start is not None and scenario.goal is not None  # set by Scenario
    dist = _cell_distances(free, scenario.observer_start)
    path = dist[scenario.goal]
    return protocol.window + protocol.travel(int(path if path >= 0 else free.sum()))


def estimate_cost(
    scenario: Scenario, command: str, *, steps: int, robots: int | None = None
) -> CostEstimate:
    """The cost of ``learn`` (``command="learn"``) or ``run`` on ``scenario`` with ``steps``
    observed steps, from counts of the map's cells only (nothing is built).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    command : {"learn", "run"}
        The command; ``"run"`` adds planning to learning.
    steps : int
        Observed steps.
    robots : int, optional
        The patrollers (the scenario's if None).

    Returns
    -------
    CostEstimate
        The estimate.
    """
    gm = scenario.map
    cells = int(gm.patroller.sum())
    n = len(scenario.robots) if robots is None else int(robots)
    S = cells * N_HEADINGS
    S_L = int((gm.patroller | gm.observer_only).sum()) * N_HEADINGS
    memory = BASE_MEMORY + LEARN_BYTES_PER_STATE * S * n
    seconds = (LEARN_SECONDS_PER_STATE + LEARN_SECONDS_PER_STATE_STEP * steps) * S * n
    seconds += LEARN_SECONDS_PER_ROBOT_STEP * steps * n
    horizon = 0
    if command == "run":
        horizon = planning_horizon(scenario)
        memory += PLAN_BYTES_PER_STATE * (S_L + S * n)
        seconds += PLAN_SECONDS_PER_STATE_STEP * (S_L + S * n) * horizon
    return CostEstimate(command, cells, S, n, int(steps), horizon, int(memory), float(seconds))


def check_budget(scenario: Scenario, estimate: CostEstimate, max_memory: int) -> None:
    """Refuse (:class:`CostError`, one line) when ``estimate`` exceeds ``max_memory`` bytes,
    naming the states, the estimate and a cell size (or a map size) that fits.

    Parameters
    ----------
    scenario : Scenario
        The scenario estimated (its map, for the advice).
    estimate : CostEstimate
        The estimate.
    max_memory : int
        The budget, bytes.

    Raises
    ------
    CostError
        If the estimate's memory exceeds ``max_memory``.
    """
    if estimate.memory <= max_memory:
        return
    fits = _fitting_states(estimate, max_memory)
    cell = scenario.map.frame.cell_size
    if fits <= 0:
        advice = "nothing fits: raise `max_memory`"
    elif scenario.map.source.lower().endswith((".yaml", ".yml")):
        # states grow as 1 / cell size²: the size whose state count fits, rounded up to 5 cm
        larger = cell * math.sqrt(estimate.states / fits)
        advice = f"a cell size of {math.ceil(larger * 20 - 1e-9) / 20:g} m or more fits"
    else:
        advice = f"a map of at most {fits // N_HEADINGS:,} hallway cells fits"
    raise CostError(
        f"{scenario.source}: {estimate.command} on {estimate.describe()}, over the budget "
        f"`max_memory` of {_size(max_memory)}; {advice}"
    )


def _fitting_states(estimate: CostEstimate, budget: int) -> int:
    """The most patroller states whose estimate fits ``budget`` (L's states taken as the
    patrollers' in the same proportion as now)."""
    per_state = (estimate.memory - BASE_MEMORY) / max(estimate.states, 1)
    return int((budget - BASE_MEMORY) / per_state) if budget > BASE_MEMORY else 0


def _cell_distances(free: np.ndarray, source: tuple[int, int]) -> np.ndarray:
    dist = np.full(free.shape, -1, dtype=np.int64)
    dist[source] = 0
    queue = deque([source])
    rows, cols = free.shape
    while queue:
        r, c = queue.popleft()
        for dr, dc in HEADING_DELTAS:
            rr, cc = r + int(dr), c + int(dc)
            if 0 <= rr < rows and 0 <= cc < cols and free[rr, cc] and dist[rr, cc] < 0:
                dist[rr, cc] = dist[r, c] + 1
                queue.append((rr, cc))
    return dist


def _size(n: float) -> str:
    return f"{n / 2**30:.1f} GB" if n >= 2**30 else f"{n / 2**20:.0f} MB"


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{max(seconds, 1):.0f} s"
    return f"{seconds / 60:.0f} min" if seconds < 5400 else f"{seconds / 3600:.1f} h"
