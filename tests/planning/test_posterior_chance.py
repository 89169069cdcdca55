"""The chance over drawn model sets (mirl.planning.posterior_chance): one filter per draw, the
factored draws as a control variate for the exact chance, the averaged prediction. The average
against quadrature of an exact posterior is in tests/learning/test_model_posterior.py."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.results import oracle_models
from mirl.planning.belief import BeliefFilter
from mirl.planning.go import solve_observer_mdp
from mirl.planning.observer import observer_model
from mirl.planning.posterior_chance import AveragedPrediction, PosteriorBeliefs
from mirl.planning.success import success_probability
from mirl.simulation.grid import PatrolSimulator
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def record():
    sc = load_scenario("boyd2")
    sim = PatrolSimulator(sc, observability=0.3)
    states = [sim.reset(seed=5, options={"random_starts": True})[1]["states"]]
    states += [sim.step()[4]["states"] for _ in range(119)]
    true = np.array(states)
    return sc, np.where(sim.visible[true], true, -1), sim.visible


def _filter(sc, models, seen, visible, joint):
    f = BeliefFilter(sc.domain, models, visible=visible, joint=joint)
    for now in seen:
        f.update(now)
    return f


def test_draws_of_the_point_models_state_the_point_chance(record):
    sc, seen, visible = record
    truth = oracle_models(sc)
    model = observer_model(sc)
    point = _filter(sc, truth, seen, visible, True)
    plan = solve_observer_mdp(model, point.predict(40, model), window=0, detection_penalty=0.0)
    beliefs = PosteriorBeliefs(sc.domain, [truth] * 3, visible=visible, joint=True)
    beliefs.run(seen)
    assert beliefs.t == point.t
    exact = success_probability(point, model, plan, extra=10).success
    assert beliefs.success(model, plan, extra=10) == pytest.approx([exact] * 3, abs=1e-12)


def test_factored_shifts_vanish_for_the_reference_itself(record):
    sc, seen, visible = record
    truth = oracle_models(sc)
    model = observer_model(sc)
    beliefs = PosteriorBeliefs(sc.domain, [truth] * 2, visible=visible, joint=False,
                               reference=truth)  # fmt: skip
    beliefs.run(seen)
    point = _filter(sc, truth, seen, visible, True)
    plan = solve_observer_mdp(model, point.predict(40, model), window=0, detection_penalty=0.0)
    assert beliefs.shifts(model, plan, extra=10) == pytest.approx([0.0, 0.0], abs=1e-12)


def test_the_averaged_prediction_is_the_rows_mean(record):
    sc, seen, visible = record
    truth = oracle_models(sc)
    model = observer_model(sc)
    a = _filter(sc, truth, seen, visible, True).predict(20, model)
    b = _filter(sc, truth, seen[:-30], visible, True).predict(20, model)
    mean = AveragedPrediction([a, b])
    assert mean.steps == 20 and mean.t0 == a.t0
    assert np.allclose(mean.hazard_rows(3, 9), (a.hazard[3:9] + b.hazard[3:9]) / 2)
    assert np.allclose(mean.detection_rows(0, 20), (a.detection[:20] + b.detection[:20]) / 2)


def _team_with_floor(sc, models, floor: float):
    """``models`` with every robot's T remade with its floor feature at ``floor``."""
    from dataclasses import replace

    from mirl.world.motion import transition_matrix

    robots = []
    for r in models.robots:
        probs = {**r.feature_probabilities, "floor": floor}
        robots.append(replace(r, transitions=transition_matrix(sc.domain, probs, sc.error_model),
                              feature_probabilities=probs))  # fmt: skip
    return replace(models, robots=tuple(robots))


def test_the_stated_chance_is_the_point_chance_plus_each_draws_shift(record):
    """Against the per-draw chances computed directly: each draw's factored chance less the
    point models' factored chance, added to the point models' exact chance; mean and 5–95 %
    quantiles of those."""
    sc, seen, visible = record
    truth = oracle_models(sc)
    model = observer_model(sc)
    draws = [_team_with_floor(sc, truth, f) for f in (0.6, 0.8, 0.95, 0.99)]
    point = _filter(sc, truth, seen, visible, True)
    plan = solve_observer_mdp(model, point.predict(40, model), window=0, detection_penalty=0.0)
    exact = success_probability(point, model, plan, extra=10).success
    beliefs = PosteriorBeliefs(sc.domain, draws, visible=visible, joint=False, reference=truth)
    beliefs.run(seen)
    stated = beliefs.stated(exact, model, plan, extra=10)
    base = success_probability(_filter(sc, truth, seen, visible, False), model, plan, extra=10)
    direct = np.clip(
        [
            exact + success_probability(_filter(sc, d, seen, visible, False), model, plan,
                                        extra=10).success - base.success
            for d in draws
        ],
        0.0, 1.0,
    )  # fmt: skip
    assert stated.draws == pytest.approx(direct, abs=1e-12)
    assert stated.mean == pytest.approx(direct.mean(), abs=1e-12)
    assert stated.interval == pytest.approx(np.quantile(direct, [0.05, 0.95]), abs=1e-12)
    assert stated.interval[0] <= stated.mean <= stated.interval[1] and stated.point == exact
    assert len(set(np.round(direct, 9))) > 1  # the floors move the chance: a real spread


def test_true_models_have_no_posterior_to_draw(record):
    from mirl.planning.posterior_chance import posterior_beliefs

    sc, seen, visible = record
    assert posterior_beliefs(oracle_models(sc), list(seen), sc, visible=visible) is None


def test_the_draws_filters_stepped_together_are_each_filter_bit_for_bit(record):
    """The stack (one product for all draws) against each filter updated alone, over a record
    with unseen, unwatched and impossible observations (a robot seen where its model cannot
    have taken it: the fallback)."""
    from mirl.planning.belief import NOT_WATCHING

    sc, seen, visible = record
    truth = oracle_models(sc)
    draws = [_team_with_floor(sc, truth, f) for f in (0.6, 0.9, 0.99)]
    odd = seen.copy()
    odd[40:45] = NOT_WATCHING
    odd[69, 0], odd[70, 0] = np.flatnonzero(visible)[[0, -1]]  # a jump across the map
    beliefs = PosteriorBeliefs(sc.domain, draws, visible=visible, joint=False, reference=truth)
    assert beliefs._stack is not None
    alone = [_filter(sc, m, odd, visible, False) for m in (*draws, truth)]
    beliefs.run(odd)
    assert beliefs.t == len(odd) - 1
    for f, g in zip((*beliefs.filters, beliefs.reference), alone, strict=True):
        assert f.t == g.t and f.fallbacks == g.fallbacks
        assert np.array_equal(f.belief, g.belief)
    assert sum(g.fallbacks for g in alone) > 0  # the impossible sighting was exercised
    # a filter stepped alone in between: the stack takes its belief, not its own copy
    beliefs.filters[0].update(odd[-1])
    alone[0].update(odd[-1])
    for f in (*beliefs.filters[1:], beliefs.reference):
        f.update(odd[-1])
    for g in alone[1:]:
        g.update(odd[-1])
    beliefs.update(odd[-2])
    for g in alone:
        g.update(odd[-2])
    for f, g in zip((*beliefs.filters, beliefs.reference), alone, strict=True):
        assert np.array_equal(f.belief, g.belief)


def test_a_stack_takes_factored_filters_of_one_view_only(record):
    from mirl.planning.belief import FactoredFilterStack

    sc, seen, visible = record
    truth = oracle_models(sc)
    joint = BeliefFilter(sc.domain, truth, visible=visible, joint=True)
    factored = BeliefFilter(sc.domain, truth, visible=visible, joint=False)
    with pytest.raises(ValueError, match="factored"):
        FactoredFilterStack([factored, joint])
    blind = BeliefFilter(sc.domain, truth, joint=False)
    with pytest.raises(ValueError, match="view"):
        FactoredFilterStack([factored, blind])
