"""L's planner: detection matrix, belief filter and prediction, time-indexed MDP, hand-checked
cases on small maps."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.results import LearnResult, RobotModel
from mirl.planning.belief import BeliefFilter
from mirl.planning.go import solve_observer_mdp
from mirl.planning.observer import (
    detection_matrix,
    observer_domain,
    observer_model,
    shortest_path_policy,
)
from mirl.world.domain import STOP, detection_cells
from mirl.world.game import Equilibrium
from mirl.world.maps import parse_map
from mirl.world.motion import transition_matrix_from_success
from mirl.world.scenario import HEALTHY_PROBABILITIES, RobotSpec, Scenario, load_scenario

CORRIDOR = "L.G...\n"  # L's room (0,0), hallway (0,1)…(0,5), goal (0,2)
TWO_ROUTES = "L...\n.#.#\n..G.\n"


def _scenario(text: str, starts, detect_distance: int = 6) -> Scenario:
    gm = parse_map(text, name="tiny")
    robots = tuple(
        RobotSpec(f"P{i}", tuple(s), dict(HEALTHY_PROBABILITIES), np.zeros(4))
        for i, s in enumerate(starts)
    )
    return Scenario(name="tiny", map=gm, robots=robots, detect_distance=detect_distance)


def _static(scenario: Scenario) -> LearnResult:
    """Every patroller stands still for ever (deterministic stop)."""
    dom = scenario.domain
    T = transition_matrix_from_success(dom, 1.0)
    robots = tuple(
        RobotModel(r.name, np.zeros(4), {}, T, np.full(dom.n_states, STOP)) for r in scenario.robots
    )
    go = Equilibrium((1.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    return LearnResult("hand", robots, go)


def _plan_static(scenario: Scenario, steps: int = 12):
    dom = scenario.domain
    model = observer_model(scenario)
    belief = BeliefFilter(dom, _static(scenario), visible=np.ones(dom.n_states, bool))
    belief.update([dom.state_index(*r.start) for r in scenario.robots])
    return solve_observer_mdp(model, belief.predict(steps, model), window=5)


# ---- detection matrix --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["boyd2", "boydright"])
def test_detection_matrix_matches_detection_cells(name):
    sc = load_scenario(name)
    dom, ldom = sc.domain, observer_domain(sc.map)
    D = detection_matrix(dom, ldom, sc.detect_distance).toarray()
    expected = np.zeros_like(D)
    for s, (r, c, h) in enumerate(dom.states):
        for rr, cc in detection_cells(sc.map, r, c, h, sc.detect_distance):
            expected[s, ldom.cell_lut[rr, cc]] = 1
    np.testing.assert_array_equal(D, expected)
    room = ldom.cell_lut[sc.map.observer_start]
    assert D[:, room].sum() == 0  # L's room is never visible


# ---- hand-checked cases --------------------------------------------------------------------------
def test_static_patroller_facing_the_only_path_blocks():
    # a patroller at (0,4) facing west sees (0,1)…(0,4): L's only way and its goal
    plan = _plan_static(_scenario(CORRIDOR, [(0, 4, 2)]))
    assert plan.go_time is None
    assert np.all(plan.go_values < 0)


def test_static_patroller_facing_away_lets_l_pass():
    plan = _plan_static(_scenario(CORRIDOR, [(0, 4, 0)]))
    assert plan.go_time == 0
    # L needs 2 steps; the horizon is long enough to retry its 2.5 % failures
    assert plan.value > 0.99


def test_one_of_two_patrollers_blocking_blocks_with_the_joint_filter():
    sc = _scenario(CORRIDOR, [(0, 5, 0), (0, 4, 2)])
    assert _plan_static(sc).go_time is None
    sc = _scenario(CORRIDOR, [(0, 5, 0), (0, 4, 0)])
    assert _plan_static(sc).go_time == 0


def test_detection_range_limits_blocking():
    # facing west from (0,5) with range 2 sees (0,3)…(0,5) only: L's path (0,1),(0,2) is safe
    assert _plan_static(_scenario(CORRIDOR, [(0, 5, 2)], detect_distance=2)).go_time == 0
    assert _plan_static(_scenario(CORRIDOR, [(0, 5, 2)], detect_distance=3)).go_time is None


def test_start_heading_faces_the_door_and_shortest_path_reaches_goal():
    sc = load_scenario("boyd2")
    model = observer_model(sc)
    assert tuple(model.domain.states[model.start_state]) == (0, 0, 0)  # facing (0,1)
    pol = shortest_path_policy(model)
    s, steps = model.start_state, 0
    while not model.goal[s]:
        s = model.domain.intended[s, pol[s]]
        steps += 1
    assert steps == 11  # into the hallway, turn south, 9 cells down
