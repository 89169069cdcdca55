"""L's MDP (the observer model): its domain over every free cell, its motion that fails in
place, what the patrollers see of it, and the shortest path it follows after its plan."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.planning.observer import (
    OBSERVER_FAILURE,
    detection_matrix,
    observer_domain,
    observer_model,
    shortest_path_policy,
)
from mirl.world.domain import detection_cells
from mirl.world.maps import parse_map
from mirl.world.scenario import load_scenario

BOYDRIGHT = load_scenario("boydright")


def test_l_may_stand_on_every_free_cell_rooms_included():
    gm = BOYDRIGHT.map
    dom = observer_domain(gm)
    assert dom.n_cells == int(gm.free.sum()) > gm.n_patroller_cells
    assert dom.state_index(*gm.observer_start, 0) >= 0  # L's room is a state of L's


def test_a_move_succeeds_to_its_intended_state_or_fails_in_place():
    model = observer_model(BOYDRIGHT, failure=0.1)
    T = model.transitions.toarray().reshape(model.n_states, 4, model.n_states)
    intended = model.domain.intended
    s, a = np.meshgrid(np.arange(model.n_states), np.arange(4), indexing="ij")
    moves = intended != s
    np.testing.assert_allclose(T[s[moves], a[moves], intended[moves]], 0.9)
    np.testing.assert_allclose(T[s[moves], a[moves], s[moves]], 0.1)
    np.testing.assert_allclose(T.sum(axis=2), 1.0)
    assert observer_model(BOYDRIGHT).failure == OBSERVER_FAILURE


@pytest.mark.parametrize("distance", [0, 1, 6])
def test_the_detection_matrix_is_the_detection_rule_state_by_state(distance):
    patrol, ldom = BOYDRIGHT.domain, observer_domain(BOYDRIGHT.map)
    D = detection_matrix(patrol, ldom, distance).toarray()
    assert set(np.unique(D)) <= {0.0, 1.0}
    for s, (r, c, h) in enumerate(patrol.states):
        seen = {tuple(map(int, ldom.cells[k])) for k in np.flatnonzero(D[s])}
        assert seen == set(detection_cells(BOYDRIGHT.map, r, c, h, distance))
    with pytest.raises(ValueError, match="non-negative"):
        detection_matrix(patrol, ldom, -1)


def test_who_sees_l_is_the_detection_column_of_its_cell():
    model = observer_model(BOYDRIGHT)
    rng = np.random.default_rng(0)
    patrollers = rng.integers(0, BOYDRIGHT.domain.n_states, 20)
    for state in rng.integers(0, model.n_states, 30):
        column = model.detection[:, [int(model.cell_of(state))]].toarray().ravel()
        assert model.seen_by(patrollers, int(state)).tolist() == (column[patrollers] > 0).tolist()
        assert np.array_equal(model.not_seeing(int(state)), 1.0 - column)


def test_the_shortest_path_policy_takes_l_to_its_goal_from_every_state():
    model = observer_model(BOYDRIGHT)
    pol = shortest_path_policy(model)
    dist = model.distance_to_goal
    for s in range(model.n_states):
        steps, state = 0, s
        while not model.goal[state] and steps <= model.n_states:
            state = int(model.domain.intended[state, pol[state]])
            steps += 1
        assert model.goal[state] and steps == dist[s], s  # a shortest path, step by step


def test_a_goal_l_cannot_reach_is_refused():
    gm = parse_map("L.#G.\n")  # the wall cuts L off from its goal
    sc = load_scenario("boydright").with_options(name="cut")
    with pytest.raises(ValueError, match="unreachable"):
        observer_model(sc.with_options(map=gm, observer_start=None, goal=None, robots=()))
