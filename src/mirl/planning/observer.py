"""L's own MDP: states (row, col, heading) over every free cell of the map (hallways and rooms), the
patrollers' four actions, L's failure (2.5 %: the robot stays put), its goal and the sparse
**detection matrix** D (patroller states × L cells, docs/design.md, "Detection": straight ahead
along the heading, up to ``detect_distance`` cells, stopped by walls; room cells are never visible).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from mirl.world.domain import N_HEADINGS, PatrolDomain
from mirl.world.maps import HEADING_DELTAS, GridMap
from mirl.world.motion import transition_matrix_from_success
from mirl.world.scenario import Scenario, as_scenario

__all__ = [
    "OBSERVER_FAILURE",
    "ObserverModel",
    "observer_model",
    "observer_domain",
    "detection_matrix",
    "shortest_path_policy",
]

OBSERVER_FAILURE = 0.025  # L's own action failure (the paper's 2.5 %): the robot stays put


def observer_domain(gridmap: GridMap) -> PatrolDomain:
    """A :class:`PatrolDomain` whose cells are all of the map's free cells (L may enter rooms).

    Parameters
    ----------
    gridmap : GridMap
        The map.

    Returns
    -------
    PatrolDomain
        L's domain.
    """
    free = gridmap.free
    lmap = GridMap(
        name=f"{gridmap.name}-observer",
        patroller=free,
        observer_only=np.zeros_like(free),
        observer_start=gridmap.observer_start,
        goals=gridmap.goals,
        visibility_order=np.zeros((0, 2), dtype=int),
        source=gridmap.source,
    )
    return PatrolDomain(lmap)


def detection_matrix(patrol: PatrolDomain, observer: PatrolDomain, distance: int) -> sp.csr_array:
    """Which L cells a patroller in each state sees.

    The rule of :func:`mirl.world.domain.detection_cells`, vectorised over states.

    Parameters
    ----------
    patrol : PatrolDomain
        The patrollers' domain.
    observer : PatrolDomain
        L's domain (:func:`observer_domain`).
    distance : int
        Cells a patroller sees straight ahead, at least 0.

    Returns
    -------
    scipy.sparse.csr_array of shape (S_patroller, C)
        D[s, c] = 1 iff a patroller in state s sees L on cell c; 0 elsewhere.

    Raises
    ------
    ValueError
        A negative distance.
    """
    if distance < 0:
        raise ValueError(f"detect_distance must be non-negative, got {distance}")
    r, c, h = patrol.states.T
    dr, dc = HEADING_DELTAS[h].T
    rows_n, cols_n = patrol.map.shape
    alive = np.ones(patrol.n_states, dtype=bool)
    rows, cols = [], []
    for k in range(distance + 1):  # loop over distances, vectorised over states
        rr, cc = r + k * dr, c + k * dc
        inside = (rr >= 0) & (rr < rows_n) & (cc >= 0) & (cc < cols_n)
        rr_c, cc_c = np.clip(rr, 0, rows_n - 1), np.clip(cc, 0, cols_n - 1)
        alive &= inside & patrol.map.patroller[rr_c, cc_c]  # sight stops at walls and rooms
        s = np.flatnonzero(alive)
        rows.append(s)
        cols.append(observer.cell_lut[rr_c[s], cc_c[s]])
    rows_a, cols_a = np.concatenate(rows), np.concatenate(cols)
    data = np.ones(len(rows_a))
    return sp.csr_array((data, (rows_a, cols_a)), shape=(patrol.n_states, observer.n_cells))


@dataclass(frozen=True, eq=False)
class ObserverModel:
    """L's MDP without its rewards (those come from the prediction).

    Parameters
    ----------
    domain : PatrolDomain
        L's domain, over the map's free cells.
    transitions : scipy.sparse.csr_array of shape (S_L*A, S_L)
        L's motion; a failed step stays put.
    goal : ndarray of bool, shape (S_L,)
        The states on L's goal cell.
    start_state : int
        L's start cell, heading towards its door.
    detection : scipy.sparse.csr_array of shape (S_patroller, C)
        :func:`detection_matrix`.
    failure : float, default OBSERVER_FAILURE
        The probability that one of L's moves fails.
    """

    domain: PatrolDomain  # over the map's free cells
    transitions: sp.csr_array  # (S_L·A, S_L); failure = stay put
    goal: np.ndarray  # (S_L,) bool: states on L's goal cell
    start_state: int  # L's start cell, heading towards its door
    detection: sp.csr_array  # (S_patroller, n_L_cells), see detection_matrix
    failure: float = OBSERVER_FAILURE

    @property
    def n_states(self) -> int:
        """S_L, L's states."""
        return self.domain.n_states

    def cell_of(self, states) -> np.ndarray:
        """The cell index (into L's domain's cells) of each L state.

        Parameters
        ----------
        states : int or array_like of int
            L's states.

        Returns
        -------
        ndarray of int
            Their cells.
        """
        return self.domain.state_cell(states)

    def seen_by(self, patroller_states: np.ndarray, observer_state: int) -> np.ndarray:
        """Which patrollers see L in ``observer_state``: the true rule.

        Parameters
        ----------
        patroller_states : ndarray of int, shape (N,)
            The patrollers' true states.
        observer_state : int
            L's state.

        Returns
        -------
        ndarray of bool, shape (N,)
            True for the patrollers that see it.
        """
        cell = int(self.cell_of(observer_state))
        column = self.detection[:, [cell]].toarray().ravel()
        return column[np.asarray(patroller_states)] > 0

    def not_seeing(self, observer_state: int) -> np.ndarray:
        """Which patroller states do not see L's cell in ``observer_state``.

        Kept per cell, since the stated probability of success asks for the same few cells many
        times in a run.

        Parameters
        ----------
        observer_state : int
            L's state.

        Returns
        -------
        ndarray of shape (S_patroller,)
            1.0 where a patroller state does not see L's cell, 0.0 where it does.
        """
        c = int(self.cell_of(observer_state))
        g = self._not_seeing_cells.get(c)
        if g is None:
            g = self._not_seeing_cells[c] = 1.0 - self._detection_columns[:, [c]].toarray().ravel()
        return g

    @cached_property
    def _not_seeing_cells(self) -> dict[int, np.ndarray]:
        return {}

    @cached_property
    def _detection_columns(self) -> sp.csc_array:
        return sp.csc_array(self.detection)

    @cached_property
    def distance_to_goal(self) -> np.ndarray:
        """(S_L,) steps to the goal under intended outcomes (inf where unreachable)."""
        return _distance_to_goal(self.domain, self.goal)

    @cached_property
    def cell_pairs(self) -> np.ndarray:
        """(n_pairs, 2) distinct (cell before, cell after) of L's possible one-step moves."""
        T = self.transitions.tocoo()
        A = self.domain.n_actions
        pairs = np.column_stack([self.cell_of(T.row // A), self.cell_of(T.col)])
        return np.unique(pairs, axis=0)

    @cached_property
    def _transition_entries(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Non-zeros of T as (row s·A+a, next state, probability, index into cell_pairs)."""
        T = self.transitions.tocoo()
        A = self.domain.n_actions
        n_cells = self.domain.n_cells
        key = self.cell_of(T.row // A) * n_cells + self.cell_of(T.col)
        pair_keys = self.cell_pairs[:, 0] * n_cells + self.cell_pairs[:, 1]
        return T.row, T.col, T.data, np.searchsorted(pair_keys, key)


def observer_model(
    scenario: Scenario | str, *, failure: float = OBSERVER_FAILURE
) -> ObserverModel:
    """Build L's MDP for ``scenario``.

    L starts in its start cell facing its first step towards the goal (the door), and its goal is
    ``scenario.goal``.

    Parameters
    ----------
    scenario : Scenario or str
        The scenario: map, L's start and goal, the patrollers' detection distance; or a
        shipped scenario's name or a scenario file, as :func:`~mirl.world.scenario.as_scenario`
        takes it (as ``run_episode`` and the environments do).
    failure : float, default OBSERVER_FAILURE
        The probability that one of L's moves fails (it stays put).

    Returns
    -------
    ObserverModel
        L's MDP.

    Raises
    ------
    ValueError
        L's goal is unreachable from its start.
    """
    scenario = as_scenario(scenario)
    dom = observer_domain(scenario.map)
    T = transition_matrix_from_success(dom, 1.0 - failure, "stop")
    goal = np.zeros(dom.n_states, dtype=bool)
    gcell = dom.cell_lut[scenario.goal]
    goal[gcell * N_HEADINGS : (gcell + 1) * N_HEADINGS] = True
    D = detection_matrix(scenario.domain, dom, scenario.detect_distance)
    start_cell = dom.cell_lut[scenario.observer_start]
    dist = _distance_to_goal(dom, goal)
    heads = start_cell * N_HEADINGS + np.arange(N_HEADINGS)
    # facing the door = the heading from which the goal is nearest (ties: lowest heading)
    start = int(heads[np.argmin(dist[heads])])
    if not np.isfinite(dist[start]):
        raise ValueError(
            f"{scenario.source}: observer.goal {scenario.goal} is unreachable from L's start "
            f"{scenario.observer_start}"
        )
    return ObserverModel(dom, T, goal, start, D, failure)


def _distance_to_goal(dom: PatrolDomain, goal: np.ndarray) -> np.ndarray:
    """Steps to the goal under intended outcomes (inf where unreachable), by vectorised
    relaxation: dist(s) = 1 + min_a dist(ψ(s, a)) until nothing changes."""
    dist = np.where(goal, 0.0, np.inf)
    psi = dom.intended
    for _ in range(dom.n_states):
        new = np.where(goal, 0.0, 1.0 + dist[psi].min(axis=1))
        if np.array_equal(new, dist):
            break
        dist = new
    return dist


def shortest_path_policy(model: ObserverModel) -> np.ndarray:
    """A stationary action per L state taking L along a shortest path to its goal.

    It ignores the patrollers. A failed step leaves L where it was, so following it again
    retries.

    Parameters
    ----------
    model : ObserverModel
        L's MDP.

    Returns
    -------
    ndarray of int, shape (S_L,)
        An action per state.
    """
    return np.argmin(model.distance_to_goal[model.domain.intended], axis=1)
