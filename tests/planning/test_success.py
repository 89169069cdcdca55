"""The stated probability of success: the belief filter propagated along L's plan."""

from __future__ import annotations

from math import comb

import numpy as np
import pytest

from mirl.planning.belief import BeliefFilter
from mirl.planning.go import solve_observer_mdp, waiting_value
from mirl.planning.observer import OBSERVER_FAILURE, observer_model
from mirl.planning.success import success_probability
from tests.planning.test_planner import CORRIDOR, _scenario, _static


def _estimate(starts, extra=0, steps=12, failure=OBSERVER_FAILURE):
    sc = _scenario(CORRIDOR, starts)
    dom = sc.domain
    model = observer_model(sc, failure=failure)
    belief = BeliefFilter(dom, _static(sc), visible=np.ones(dom.n_states, bool))
    belief.update([dom.state_index(*s) for s in starts])
    prediction = belief.predict(steps, model)
    plan = solve_observer_mdp(model, prediction, window=0, detection_penalty=0.0)
    return success_probability(belief, model, plan, extra=extra, prune=0.0), plan


def test_unwatched_path_succeeds_unless_l_fails_too_often():
    # L needs 2 steps; within the plan's n steps it gets there unless fewer than 2 moves work
    est, plan = _estimate([(0, 4, 0)], extra=1, steps=3, failure=0.3)
    n, q = plan.horizon + 1, 0.7
    fewer_than_two = sum(comb(n, k) * q**k * (1 - q) ** (n - k) for k in range(2))
    assert est.success == pytest.approx(1 - fewer_than_two, abs=1e-9)
    assert est.detected == pytest.approx(0.0, abs=1e-12)
    assert est.success + est.detected + est.unfinished == pytest.approx(1.0)
    assert est.exact


def test_a_patroller_watching_the_only_path_stops_every_attempt():
    est, _ = _estimate([(0, 4, 2)])
    assert est.success == pytest.approx(0.0, abs=1e-12)
    assert est.detected == pytest.approx(1.0)


def test_the_joint_filter_sees_one_blocker_of_two():
    assert _estimate([(0, 5, 0), (0, 4, 2)])[0].success == pytest.approx(0.0, abs=1e-12)
    assert _estimate([(0, 5, 0), (0, 4, 0)])[0].success > 0.99


def test_conditioning_on_not_being_seen_is_exact_on_the_pair():
    sc = _scenario(CORRIDOR, [(0, 4, 0), (0, 5, 0)])
    dom = sc.domain
    belief = BeliefFilter(dom, _static(sc), visible=np.zeros(dom.n_states, bool))
    rng = np.random.default_rng(0)
    b = rng.random(dom.n_states**2)
    b /= b.sum()
    g = (rng.random(dom.n_states) < 0.6).astype(float)
    post, kept = belief.condition_unseen(b, g)
    B = b.reshape(dom.n_states, dom.n_states)
    expected = sum(
        B[i, j] for i in range(dom.n_states) for j in range(dom.n_states) if g[i] and g[j]
    )
    assert kept == pytest.approx(expected)
    assert post.sum() == pytest.approx(1.0)
    assert np.all(post.reshape(B.shape)[g == 0] == 0)


def test_waiting_value_is_the_finite_horizon_stopping_recursion():
    chances = [0.1, 0.2, 0.6]
    assert waiting_value(chances, 0) == 0.0  # no chance left: go now
    assert waiting_value([], 5) == 0.0
    assert waiting_value(chances, 1) == pytest.approx(0.3)  # the last chance, whatever it is
    assert waiting_value(chances, 2) == pytest.approx((0.3 + 0.3 + 0.6) / 3)
    values = [waiting_value(chances, n) for n in range(1, 40)]
    assert np.all(np.diff(values) >= 0) and values[-1] == pytest.approx(0.6, abs=1e-6)


def test_a_shared_belief_changes_nothing_when_l_never_fails():
    exact, _ = _estimate([(0, 5, 0), (0, 2, 2)], failure=0.0)
    sc = _scenario(CORRIDOR, [(0, 5, 0), (0, 2, 2)])
    dom = sc.domain
    model = observer_model(sc, failure=0.0)
    belief = BeliefFilter(dom, _static(sc), visible=np.ones(dom.n_states, bool))
    belief.update([dom.state_index(0, 5, 0), dom.state_index(0, 2, 2)])
    plan = solve_observer_mdp(model, belief.predict(12, model), window=0, detection_penalty=0.0)
    shared = success_probability(belief, model, plan, prune=0.0, shared=True)
    assert shared.success == pytest.approx(exact.success, abs=1e-12)
    assert not shared.exact and exact.exact


def test_a_shared_belief_is_close_to_per_state_beliefs_on_boyd2():
    # L's failed moves split it over several states; sharing one belief among them is the
    # factored filter's approximation (docs/design.md: mean difference −0.001, largest 0.023
    # over 96 moments of 16 runs)
    from mirl.learning.results import oracle_models
    from mirl.world.scenario import load_scenario
    from mirl.worlds import make_world

    sc = load_scenario("boyd2")
    model = observer_model(sc)
    world = make_world(
        "grid", sc, model, observability=1.0, seed=5, noise=np.random.SeedSequence(5)
    )
    belief = BeliefFilter(sc.domain, oracle_models(sc), visible=world.visible)
    differences = []
    for t in range(140):
        if t:
            world.step()
        belief.update(world.seen[-1])
        if t >= 60 and t % 20 == 0:
            plan = solve_observer_mdp(
                model, belief.predict(36, model), window=0, detection_penalty=0.0, min_value=-1.0
            )
            per_state = success_probability(belief, model, plan, extra=36).success
            shared = success_probability(belief, model, plan, extra=36, shared=True).success
            differences.append(shared - per_state)
    assert len(differences) == 4 and max(map(abs, differences)) < 0.03


def test_not_seeing_is_the_complement_of_the_detection_column_and_is_kept():
    sc = _scenario(CORRIDOR, [(0, 4, 0)])
    model = observer_model(sc)
    for s in range(model.n_states):
        column = model.detection[:, [int(model.cell_of(s))]].toarray().ravel()
        assert np.array_equal(model.not_seeing(s), 1.0 - column)
    assert model.not_seeing(0) is model.not_seeing(0)
