"""The true patrol: each patroller's optimal policy, followed with intended outcomes from
any state, settles into one back-and-forth cycle over the whole "[" of hallways; and that policy
is optimal by an independent dense policy evaluation."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.world.scenario import load_scenario

DELTA = {0: (0, 1), 1: (-1, 0), 2: (0, -1), 3: (1, 0)}
ENDS = ((0, 8), (16, 8))
# the patrol route from end to end: upper hallway west, long hallway south, lower hallway east
ROUTE = [(0, c) for c in range(8, 0, -1)] + [(r, 1) for r in range(1, 17)]
ROUTE += [(16, c) for c in range(2, 9)]
SETTLE = 200
HEALTHY = {"left_wheel": 0.95, "right_wheel": 0.95, "navigation": 0.97, "floor": 0.99}
SCENARIOS = ["boyd2", "boyd2-healthy"]


def ref_step(free, state, action):
    """ψ by hand, actions by index (forward, turn_left, turn_right, stop)."""
    r, c, h = state
    if action == 0:
        nr, nc = r + DELTA[h][0], c + DELTA[h][1]
        if 0 <= nr < free.shape[0] and 0 <= nc < free.shape[1] and free[nr, nc]:
            return (nr, nc, h)
        return state
    if action == 1:
        return (r, c, (h + 1) % 4)
    if action == 2:
        return (r, c, (h - 1) % 4)
    return state


def dedupe_cyclic(cells):
    """Drop consecutive repeats, treating the list as a cycle (last is before first)."""
    return [c for i, c in enumerate(cells) if c != cells[i - 1]]


class Patrol:
    """The scenario's true policies as dicts over (row, col, heading) states."""

    def __init__(self, name):
        self.scenario = load_scenario(name)
        d = self.scenario.domain
        self.free = d.map.patroller
        self.states = [tuple(map(int, s)) for s in d.states]

    def policy(self, robot):
        pol = self.scenario.true_policy(robot)
        return {s: int(pol[i]) for i, s in enumerate(self.states)}


@pytest.fixture(scope="module", params=SCENARIOS)
def patrol(request):
    return Patrol(request.param)


@pytest.mark.parametrize("robot", [0, 1])
def test_true_policy_settles_into_one_back_and_forth_cycle(patrol, robot):
    pi = patrol.policy(robot)

    def step(s):
        return ref_step(patrol.free, s, pi[s])

    # the cycle reached from one start
    s = patrol.states[0]
    for _ in range(SETTLE):
        s = step(s)
    cycle = [s]
    s = step(s)
    while s != cycle[0]:
        cycle.append(s)
        s = step(s)
        assert len(cycle) <= len(patrol.states)
    on_cycle = set(cycle)

    # every start reaches that same cycle within SETTLE steps
    for start in patrol.states:
        s = start
        for _ in range(SETTLE):
            if s in on_cycle:
                break
            s = step(s)
        assert s in on_cycle, f"from {start} not on the patrol cycle after {SETTLE} steps"

    # healthy robots: 30 moves each way + 2 corner turns each way + 2 turns at each end
    if dict(patrol.scenario.robots[robot].feature_probabilities) == HEALTHY:
        assert len(cycle) == 68

    # its cells: every patroller cell, through both ends, end to end and back
    cells = dedupe_cyclic([(r, c) for r, c, _ in cycle])
    assert {(int(r), int(c)) for r, c in np.argwhere(patrol.free)} == set(cells)
    assert len(set(cells)) == 31
    assert all(e in cells for e in ENDS)
    k = cells.index(ENDS[0])
    cells = cells[k:] + cells[:k]
    assert len(cells) == 2 * len(ROUTE) - 2 == 60
    assert cells[: len(ROUTE)] == ROUTE
    assert cells[len(ROUTE) - 1 :] + [cells[0]] == ROUTE[::-1]
    # palindrome around the far end: the way back retraces the way out
    assert all(cells[i] == cells[-i] for i in range(1, len(cells)))
    # consecutive cells are neighbours
    for (r0, c0), (r1, c1) in zip(cells, cells[1:] + cells[:1], strict=True):
        assert abs(r0 - r1) + abs(c0 - c1) == 1

    # the only turns on the cycle are at the two corners and the two ends
    turn_cells = {
        cyc[:2] for cyc, nxt in zip(cycle, cycle[1:] + cycle[:1], strict=True) if cyc[:2] == nxt[:2]
    }
    assert turn_cells == {(0, 1), (16, 1), *ENDS}


def test_both_robots_share_the_cycle_and_scenario_starts_are_on_it():
    for name in SCENARIOS:
        p = Patrol(name)
        cycles = []
        for robot in (0, 1):
            pi = p.policy(robot)
            s = tuple(p.scenario.robots[robot].start)
            seen = []
            for _ in range(SETTLE):
                seen.append(s)
                s = ref_step(p.free, s, pi[s])
            cycles.append(set(seen[-68:]))
        assert cycles[0] == cycles[1]
        for robot in (0, 1):
            assert tuple(p.scenario.robots[robot].start) in cycles[0]


# --------------------------------------------------------------------------- optimality


def dense_model(scenario, robot):
    d = scenario.domain
    S, A = d.n_states, d.n_actions
    T = scenario.true_transitions(robot).toarray().reshape(S, A, S)
    R = d.rewards(scenario.robots[robot].weights)
    return T, R


@pytest.mark.parametrize("name", SCENARIOS)
@pytest.mark.parametrize("robot", [0, 1])
def test_true_policy_is_optimal_by_dense_policy_evaluation(name, robot):
    scenario = load_scenario(name)
    T, R = dense_model(scenario, robot)
    S = T.shape[0]
    gamma = scenario.discount
    pi = scenario.true_policy(robot)
    idx = np.arange(S)
    P_pi = T[idx, pi]  # (S, S)
    R_pi = R[idx, pi]
    V = np.linalg.solve(np.eye(S) - gamma * P_pi, R_pi)
    v_vi = scenario.true_q(robot).max(axis=1)
    np.testing.assert_allclose(V, v_vi, atol=1e-6)
    # no single-state deviation improves on π: one-step lookahead with the dense T
    Q = R + gamma * np.einsum("sat,t->sa", T, V)
    assert np.all(Q <= V[:, None] + 1e-9)
    np.testing.assert_allclose(Q[idx, pi], V, atol=1e-9)
