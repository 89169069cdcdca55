"""The go rules as strategies: every row of the table loads one, and each decides as its rule
says, checked against the planner called directly."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from mirl.experiments.go_rules import (
    AdaptiveRule,
    Planning,
    PosteriorAdaptiveRule,
    ValueRule,
    Waiting,
)
from mirl.experiments.options import GO_RULES
from mirl.learning.results import LearnResult, oracle_models
from mirl.planning.belief import BeliefFilter
from mirl.planning.go import solve_observer_mdp
from mirl.planning.observer import observer_model
from mirl.planning.posterior_chance import StatedChance
from mirl.world.scenario import Scenario, load_scenario
from mirl.worlds import make_world


def test_every_row_loads_a_strategy():
    for row in GO_RULES.values():
        rule = row.load()()
        assert callable(rule.decide) and callable(rule.replan_penalty)
    assert GO_RULES["value"].load() is ValueRule and GO_RULES["adaptive"].load() is AdaptiveRule
    assert GO_RULES["adaptive-posterior"].load() is PosteriorAdaptiveRule
    assert GO_RULES.names == ("adaptive", "adaptive-posterior", "value") and all(
        r.description for r in GO_RULES.values()
    )


@dataclass
class _Watcher:
    belief: BeliefFilter
    learned: LearnResult
    scenario: Scenario
    visible: np.ndarray | None = None
    moments: tuple = ()

    def chances(self, chance_at):
        return [chance_at(t, b) for t, b in self.moments]


@pytest.fixture(scope="module")
def waiting():
    sc = load_scenario("boyd2")
    model = observer_model(sc)
    world = make_world(
        "grid", sc, model, observability=1.0, seed=4, noise=np.random.SeedSequence(1)
    )
    truth = oracle_models(sc)
    belief = BeliefFilter(sc.domain, truth, visible=world.visible)
    for _ in range(79):
        world.step()
    for now in world.seen:
        belief.update(now)
    planning = Planning(
        window=20, deadline=world.t + 60, travel=40, replan_every=10, commit=False,
        hazard="markov", goal_reward=1.0, detection_penalty=0.5, opportunity_steps=10,
        moment_travel=30,
    )  # fmt: skip
    return Waiting(world, _Watcher(belief, truth, sc, world.visible), model, planning)


def test_the_value_rule_goes_at_the_best_positive_value(waiting):
    p = waiting.planning
    decision = ValueRule().decide(waiting)
    plan = solve_observer_mdp(
        waiting.model, waiting.watcher.belief.predict(p.window + p.travel, waiting.model),
        window=p.window, detection_penalty=p.detection_penalty, hazard=p.hazard,
    )  # fmt: skip
    np.testing.assert_allclose(decision.plan.go_values, plan.go_values)
    expected = None if plan.go_time is None else waiting.world.t + plan.go_time
    assert decision.go_time == expected
    assert decision.attempt.best_value == pytest.approx(float(plan.go_values.max()))
    assert decision.attempt.predicted_success is None  # the value rule states no chance
    assert ValueRule().replan_penalty(p) == 0.5 and AdaptiveRule().replan_penalty(p) == 0.0


def test_the_adaptive_rule_goes_at_the_deadline_and_states_its_chance(waiting):
    at_deadline = Waiting(
        waiting.world, waiting.watcher, waiting.model,
        Planning(**{**waiting.planning.__dict__, "deadline": waiting.world.t}),
    )  # fmt: skip
    decision = AdaptiveRule().decide(at_deadline)
    assert decision.go_time == waiting.world.t  # the window is empty: go now
    assert 0.0 <= decision.attempt.predicted_success <= 1.0


def test_the_adaptive_rule_weighs_going_now_against_the_chances_to_come(waiting):
    """Here the window's best go time is now, with a chance below 1: with no chance stated yet
    waiting is worth nothing and L goes; with sure chances to come it waits."""
    decision = AdaptiveRule().decide(waiting)
    assert decision.plan.go_time == 0 and decision.plan.go_values[0] < 1.0
    assert decision.go_time == waiting.world.t
    assert decision.attempt.predicted_success is not None
    sure = _Watcher(waiting.watcher.belief, waiting.watcher.learned, waiting.watcher.scenario)
    sure.chances = lambda chance_at: [1.0]  # type: ignore[method-assign]
    patient = Waiting(waiting.world, sure, waiting.model, waiting.planning)
    decision = AdaptiveRule().decide(patient)
    assert decision.go_time is None and decision.attempt.predicted_success is None
    assert decision.next_round == waiting.world.t + waiting.planning.replan_every


def test_the_oracles_stated_chance_is_its_exact_chance_with_no_spread(waiting):
    # true models have no posterior to draw from: the stated chance is the exact one
    decision = AdaptiveRule().decide(waiting)
    a = decision.attempt
    assert a.predicted_success == a.predicted_success_point
    assert a.predicted_success_interval == (a.predicted_success, a.predicted_success)


def test_the_posterior_rule_acts_as_the_adaptive_rule_where_draws_agree(waiting):
    # with the true models the posterior chance is the point chance: the two rules decide alike
    for rule in (AdaptiveRule(), PosteriorAdaptiveRule()):
        decision = rule.decide(waiting)
        assert decision.go_time == waiting.world.t
    sure = _Watcher(waiting.watcher.belief, waiting.watcher.learned, waiting.watcher.scenario)
    sure.chances = lambda chance_at: [1.0]  # type: ignore[method-assign]
    patient = Waiting(waiting.world, sure, waiting.model, waiting.planning)
    assert PosteriorAdaptiveRule().decide(patient).go_time is None


def test_the_posterior_rule_waits_when_the_posterior_chance_falls_short(waiting):
    """Where the adaptive rule goes (its go-now chance beats waiting), the posterior rule scales
    that chance by the posterior's over the point models' and waits if it then falls short."""
    c = float(AdaptiveRule().decide(waiting).plan.go_values[0])
    watcher = _Watcher(waiting.watcher.belief, waiting.watcher.learned, waiting.watcher.scenario)
    watcher.chances = lambda chance_at: [0.8 * c]  # type: ignore[method-assign]
    tempted = Waiting(waiting.world, watcher, waiting.model, waiting.planning)
    assert AdaptiveRule().decide(tempted).go_time == waiting.world.t
    for posterior, goes in ((0.5 * 0.6, False), (0.95 * 0.6, True)):
        rule = PosteriorAdaptiveRule()
        rule._posterior.stated = lambda w, plan, m=posterior: StatedChance(  # type: ignore
            m, (m, m), 0.6
        )
        decision = rule.decide(tempted)
        assert (decision.go_time is not None) == goes
        if goes:  # it states the chance it acted on
            assert decision.attempt.predicted_success == pytest.approx(posterior)
