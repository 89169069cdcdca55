"""L's go decision (:mod:`mirl.planning.go`): the table of hazard models, the
backward induction against enumeration and a recursive DP, the go time, the timed policy."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mirl._registry import UnknownNameError
from mirl.planning.belief import BeliefFilter, Prediction
from mirl.planning.go import HAZARDS, HazardModel, solve_observer_mdp
from mirl.planning.observer import observer_model
from mirl.world.domain import STOP
from tests.planning.test_planner import CORRIDOR, TWO_ROUTES, _scenario, _static


# ---- the tables ----------------------------------------------------------------------------------
def test_hazard_models_are_a_table():
    assert HAZARDS.names == ("markov", "independent")
    assert all(isinstance(h, HazardModel) and h.description for h in HAZARDS.values())


def test_each_hazard_model_reads_its_rows_of_the_prediction():
    """markov: the first-order hazard of each of L's moves; independent: the detection
    probability of the cell the move arrives on."""
    sc = _scenario(TWO_ROUTES, [(1, 2, 1)])
    model = observer_model(sc)
    pred = _random_prediction(model, 5, 0)
    np.testing.assert_array_equal(HAZARDS["markov"].rows(pred, 1, 4), pred.hazard[1:4])
    arrival = pred.detection[1:4][:, pred.pairs[:, 1]]
    np.testing.assert_array_equal(HAZARDS["independent"].rows(pred, 1, 4), arrival)


def test_the_plan_multiplies_by_the_hazard_model_it_names():
    """A plan with the independent model is the markov plan of a prediction whose hazards are
    the arrival cells' detection probabilities."""
    sc = _scenario(TWO_ROUTES, [(1, 2, 1)])
    model = observer_model(sc)
    pred = _random_prediction(model, 6, 1)
    as_hazard = Prediction(
        0, pred.occupancy, pred.detection, pred.detection[:, pred.pairs[:, 1]], pred.pairs
    )
    a = solve_observer_mdp(model, pred, hazard="independent", keep_values=True)
    b = solve_observer_mdp(model, as_hazard, hazard="markov", keep_values=True)
    assert np.array_equal(a.values, b.values) and a.go_time == b.go_time
    c = solve_observer_mdp(model, pred, keep_values=True)  # markov by default
    assert not np.array_equal(a.values, c.values)


def test_an_unknown_hazard_model_is_the_table_s_error():
    sc = _scenario(CORRIDOR, [(0, 4, 0)])
    model = observer_model(sc)
    belief = BeliefFilter(sc.domain, _static(sc))
    belief.update([sc.domain.state_index(0, 4, 0)])
    with pytest.raises(UnknownNameError, match=r"did you mean 'markov'"):
        solve_observer_mdp(model, belief.predict(4, model), hazard="markow")


@pytest.mark.parametrize(
    "argument, value",
    [("window", -1), ("window", 2.5), ("goal_reward", float("nan")),
     ("detection_penalty", float("inf")), ("min_value", "0"), ("keep_values", "no")],
)  # fmt: skip
def test_arguments_the_plan_cannot_use_are_refused_naming_them(argument, value):
    sc = _scenario(CORRIDOR, [(0, 4, 0)])
    model = observer_model(sc)
    pred = _random_prediction(model, 6, 0)
    with pytest.raises(ValueError, match=f"^`{argument}`"):
        solve_observer_mdp(model, pred, **{argument: value})
    assert solve_observer_mdp(model, pred, window=np.int64(2)).go_values.shape == (3,)


def test_observer_model_takes_a_scenario_by_name_as_the_other_entry_points_do():
    from mirl.world.scenario import load_scenario

    by_name = observer_model("boyd2")
    assert by_name.start_state == observer_model(load_scenario("boyd2")).start_state


# ---- backward induction --------------------------------------------------------------------------
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
