"""L's planner: detection matrix, belief filter and prediction, time-indexed MDP, hand-checked
cases on small maps."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mirl.learning.results import LearnResult, RobotModel, oracle_models
from mirl.mdp import policy_matrix
from mirl.planning.belief import NOT_WATCHING, UNSEEN, BeliefFilter, Prediction, _joint_step_matrix
from mirl.planning.go import solve_observer_mdp
from mirl.planning.observer import (
    detection_matrix,
    observer_domain,
    observer_model,
    shortest_path_policy,
)
from mirl.planning.team_filter import game_step_matrix
from mirl.world.domain import FORWARD, STOP, detection_cells
from mirl.world.game import Equilibrium, game_action_to_action, meeting
from mirl.world.maps import parse_map
from mirl.world.motion import transition_matrix, transition_matrix_from_success
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


# ---- prediction --------------------------------------------------------------------------------
def _moving_models(scenario: Scenario, seed: int, eq: Equilibrium) -> LearnResult:
    rng = np.random.default_rng(seed)
    dom = scenario.domain
    robots = []
    for i in range(len(scenario.robots)):
        probs = {f: float(rng.uniform(0.6, 0.95)) for f in HEALTHY_PROBABILITIES}
        T = transition_matrix(dom, probs)
        pol = rng.integers(0, dom.n_actions, dom.n_states)
        pol[rng.random(dom.n_states) < 0.5] = FORWARD  # plenty of meetings
        robots.append(RobotModel(f"R{i}", np.zeros(4), probs, T, pol))
    return LearnResult("hand", tuple(robots), eq)


def test_joint_step_matrix_matches_brute_force():
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom = sc.domain
    eq = Equilibrium((0.5, 0.3, 0.2), (0.1, 0.6, 0.3))
    lr = _moving_models(sc, 0, eq)
    S = dom.n_states
    M = _joint_step_matrix(dom, lr, [policy_matrix(r.transitions, r.policy) for r in lr.robots])
    T = [r.transitions.toarray().reshape(S, dom.n_actions, S) for r in lr.robots]
    pol = [r.policy for r in lr.robots]
    dense = np.zeros((S * S, S * S))
    for si, sj in itertools.product(range(S), range(S)):
        ai, aj = pol[0][si], pol[1][sj]
        if meeting(dom, si, sj, ai, aj):
            nxt = np.zeros((S, S))
            for gi, gj in itertools.product(range(3), range(3)):
                bi = int(game_action_to_action(gi, ai))
                bj = int(game_action_to_action(gj, aj))
                nxt += eq.row[gi] * eq.col[gj] * np.outer(T[0][si, bi], T[1][sj, bj])
        else:
            nxt = np.outer(T[0][si, ai], T[1][sj, aj])
        dense[si * S + sj] = nxt.ravel()
    np.testing.assert_allclose(M.toarray(), dense, atol=1e-12)
    assert dense.sum(axis=1) == pytest.approx(1.0)


@pytest.mark.parametrize("joint", [True, False])
def test_prediction_matches_dense_propagation(joint):
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom = sc.domain
    lr = _moving_models(sc, 1, Equilibrium((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)))
    model = observer_model(sc)
    visible = np.zeros(dom.n_states, bool)
    visible[:8] = True  # cells (0,1), (0,2)
    f = BeliefFilter(dom, lr, visible=visible, joint=joint)
    f.update([dom.state_index(0, 1, 0), UNSEEN])
    f.update([UNSEEN, UNSEEN])
    pred = f.predict(6, model)
    S = dom.n_states
    assert pred.occupancy.sum(axis=2) == pytest.approx(1.0)
    D = model.detection.toarray()
    if joint:
        M = _joint_step_matrix(dom, lr, [policy_matrix(r.transitions, r.policy) for r in lr.robots])
        b = f.belief.copy()
        for k in range(7):
            p = b.reshape(S, S)
            np.testing.assert_allclose(pred.occupancy[k, 0], p.sum(1), atol=1e-12)
            np.testing.assert_allclose(pred.occupancy[k, 1], p.sum(0), atol=1e-12)
            # detection: P(some robot sees c) from the joint, by enumeration
            either = 1 - (1 - D)[:, None, :] * (1 - D)[None, :, :]  # (sI, sJ, c)
            np.testing.assert_allclose(
                pred.detection[k], np.einsum("ij,ijc->c", p, either), atol=1e-12
            )
            b = M.T @ b
    else:
        # factored: each marginal moves by its policy, or by its side of the game with the
        # probability q(s) = Σ_s' meet(s, s') b_other(s') that it meets the other robot
        Ps = [policy_matrix(r.transitions, r.policy).toarray() for r in lr.robots]
        eq, pol = lr.equilibrium, [r.policy for r in lr.robots]
        Gs = [
            game_step_matrix(dom, r.transitions, r.policy, side).toarray()
            for r, side in zip(lr.robots, (eq.row, eq.col), strict=True)
        ]
        si, sj = np.divmod(np.arange(S * S), S)
        meet = meeting(dom, si, sj, pol[0][si], pol[1][sj]).reshape(S, S).astype(float)
        b = f.belief.copy()
        for k in range(7):
            np.testing.assert_allclose(pred.occupancy[k], b, atol=1e-12)
            q = [meet @ b[1], meet.T @ b[0]]
            b = np.stack([(b[i] * (1 - q[i])) @ Ps[i] + (b[i] * q[i]) @ Gs[i] for i in range(2)])
    # first-order hazard, per robot by enumeration of (s at k-1, s' at k)
    Ps = [policy_matrix(r.transitions, r.policy).toarray() for r in lr.robots]
    for k in range(1, 7):
        for j, (cp, c) in enumerate(pred.pairs):
            surv = 1.0
            for i in range(2):
                b0 = pred.occupancy[k - 1, i]
                joint_ok = b0 @ (((1 - D[:, cp])[:, None] * Ps[i]) @ (1 - D[:, c]))
                surv *= joint_ok / (b0 @ (1 - D[:, cp]))
            assert pred.hazard[k, j] == pytest.approx(1 - surv, abs=1e-12)


def test_filter_uses_negative_evidence_and_survives_impossible_observations():
    sc = load_scenario("boyd2")
    dom = sc.domain
    visible = dom.visible_states(0.14)
    f = BeliefFilter(dom, oracle_models(sc), visible=visible)
    for _ in range(5):
        f.update([UNSEEN, UNSEEN])
    m = f.marginals()
    assert m[:, visible].sum() == pytest.approx(0.0)
    assert m.sum(axis=1) == pytest.approx(1.0)
    f.update([NOT_WATCHING, NOT_WATCHING])  # no evidence at all: mass flows back into view
    assert f.marginals()[:, visible].sum() > 0
    s_far = dom.state_index(16, 8, 0)
    f.update([dom.state_index(0, 1, 0), UNSEEN])
    f.update([s_far, UNSEEN])  # a jump the model cannot explain
    assert f.fallbacks >= 1
    m = f.marginals()
    assert m[0, s_far] == pytest.approx(1.0)
    assert m.sum(axis=1) == pytest.approx(1.0)


# ---- backward induction ------------------------------------------------------------------------
def _allowed(model, s: int, a: int) -> bool:
    """The start-cell rule: there L may only leave (or, facing a wall, turn)."""
    dom = model.domain
    cell = dom.state_cell(np.arange(dom.n_states))
    start = cell[model.start_state]
    if cell[s] != start:
        return True
    leaves = cell[dom.intended[s]] != start
    return bool(leaves[a]) if leaves.any() else a != STOP


def _random_prediction(model, steps: int, seed: int) -> Prediction:
    rng = np.random.default_rng(seed)
    pairs = model.cell_pairs
    C = model.domain.n_cells
    haz = rng.uniform(0, 0.4, (steps + 1, len(pairs))) * (rng.random((steps + 1, len(pairs))) < 0.5)
    return Prediction(
        0, np.zeros((steps + 1, 0, 0)), rng.uniform(0, 0.4, (steps + 1, C)), haz, pairs
    )


def test_backward_induction_matches_enumeration_of_action_sequences():
    sc = _scenario(TWO_ROUTES, [(1, 2, 1)])
    model = observer_model(sc, failure=0.0)  # deterministic L: open loop = closed loop
    K = 6
    pred = _random_prediction(model, K, 3)
    plan = solve_observer_mdp(model, pred, goal_reward=1.0, detection_penalty=0.7)
    dom = model.domain
    cell = dom.state_cell(np.arange(dom.n_states))
    pair_index = {tuple(p): j for j, p in enumerate(pred.pairs.tolist())}
    best = -np.inf
    for seq in itertools.product(range(4), repeat=K):
        s, surv, val, ok = model.start_state, 1.0, 0.0, True
        for k, a in enumerate(seq):
            nxt = dom.intended[s, a]
            if not _allowed(model, s, a):
                ok = False
                break
            h = pred.hazard[k + 1, pair_index[(cell[s], cell[nxt])]]
            val -= 0.7 * surv * h
            surv *= 1 - h
            s = nxt
            if model.goal[s]:
                val += surv
                break
        if ok:
            best = max(best, val)
    assert plan.go_values[0] == pytest.approx(best, abs=1e-12)


def test_backward_induction_matches_recursive_dp_with_failures():
    sc = _scenario(TWO_ROUTES, [(1, 2, 1)])
    model = observer_model(sc)  # 2.5 % failure
    K = 7
    pred = _random_prediction(model, K, 4)
    plan = solve_observer_mdp(model, pred, goal_reward=1.0, detection_penalty=0.5, keep_values=True)
    dom = model.domain
    cell = dom.state_cell(np.arange(dom.n_states))
    pair_index = {tuple(p): j for j, p in enumerate(pred.pairs.tolist())}
    T = model.transitions.toarray().reshape(dom.n_states, dom.n_actions, dom.n_states)
    memo: dict = {}

    def value(k: int, s: int) -> float:
        if model.goal[s]:
            return 1.0
        if k == K:
            return 0.0
        if (k, s) not in memo:
            qs = []
            for a in range(dom.n_actions):
                if not _allowed(model, s, a):
                    continue
                q = 0.0
                for s2 in np.flatnonzero(T[s, a]):
                    h = pred.hazard[k + 1, pair_index[(cell[s], cell[s2])]]
                    q += T[s, a, s2] * ((1 - h) * value(k + 1, s2) - 0.5 * h)
                qs.append(q)
            memo[(k, s)] = max(qs)
        return memo[(k, s)]

    for k in range(K):
        assert plan.values[k, model.start_state] == pytest.approx(value(k, model.start_state))
        for s in range(dom.n_states):
            assert plan.values[k, s] == pytest.approx(value(k, s), abs=1e-12)


def test_go_time_is_best_positive_in_window():
    sc = _scenario(CORRIDOR, [(0, 4, 0)])
    model = observer_model(sc)
    K = 10
    C = model.domain.n_cells
    det = np.zeros((K + 1, C))
    det[:6] = 1.0  # every hallway cell is watched until t = 5
    det[:, model.domain.cell_lut[0, 0]] = 0.0
    pred = Prediction(
        0, np.zeros((K + 1, 0, 0)), det, det[:, model.cell_pairs[:, 1]], model.cell_pairs
    )
    plan = solve_observer_mdp(model, pred, window=8)
    assert plan.go_time == 5  # the first step into the hallway lands at t = 6
    assert np.all(plan.go_values[:5] < 0)
    assert solve_observer_mdp(model, pred, window=4).go_time is None


def test_streamed_prediction_and_timed_policy_are_the_full_arrays_bit_for_bit():
    # the factored filter's checkpointed prediction and the policy kept as its changes give
    # exactly the arrays of computing every step at once
    from mirl.planning.team_filter import factored_detection

    sc = load_scenario("office")
    lr = oracle_models(sc)
    model = observer_model(sc)
    f = BeliefFilter(sc.domain, lr, visible=sc.domain.visible_states(0.14), joint=False)
    for _ in range(5):
        f.update(np.full(len(lr.robots), UNSEEN))
    pred = f.predict(40, model)
    occ = np.empty((41, *f.belief.shape))
    occ[0] = f.belief
    for k in range(40):
        occ[k + 1] = f._propagate(occ[k])
    det, haz = factored_detection(occ, model.detection, f._step_T, model.cell_pairs)
    assert np.array_equal(pred.occupancy, occ)
    assert np.array_equal(pred.detection, np.clip(det, 0, 1))
    assert np.array_equal(pred.hazard, np.clip(haz, 0, 1))
    assert np.array_equal(pred.hazard_rows(7, 19), np.clip(haz, 0, 1)[7:19])
    full = Prediction(pred.t0, occ, np.clip(det, 0, 1), np.clip(haz, 0, 1), model.cell_pairs)
    a = solve_observer_mdp(model, pred, keep_values=True)
    b = solve_observer_mdp(model, full, keep_values=True)
    assert np.array_equal(a.values, b.values) and np.array_equal(a.go_values, b.go_values)
    assert a.policy.n_changes < 40 * model.n_states / 4  # kept as changes, not the table


def test_timed_policy_answers_as_the_table():
    from mirl.planning.go import TimedPolicy

    rng = np.random.default_rng(0)
    table = rng.integers(0, 4, (6, 9)).astype(np.int8)
    table[:3] = table[3]  # steps whose actions do not change
    pol = TimedPolicy(6, 9)
    for k in range(5, -1, -1):
        pol._record(k, table[k])
    pol._finish()
    assert np.array_equal(pol.to_array(), table)
    assert pol.n_changes == 9 + int((table[:-1] != table[1:]).sum())
    with pytest.raises(IndexError):
        pol[6, 0]
