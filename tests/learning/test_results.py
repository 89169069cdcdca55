"""What learning hands on: behaviour accuracy against the truth's optimal actions (ties kept),
the agreement of a policy with the moves L saw, and the truth as a learning result."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.results import (
    LearnResult,
    ObservedAgreement,
    behavior_accuracy,
    observed_agreement,
    oracle_models,
)
from mirl.mdp import TabularMDP, value_iteration
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def test_the_true_policy_is_fully_accurate_and_a_changed_one_by_its_changed_states(boyd2):
    policy = boyd2.true_policy(0)
    assert behavior_accuracy(boyd2, 0, policy) == 1.0
    # an independent count: states where the action is within 1e-6 of the best Q (value
    # iteration run here, not the scenario's cached Q)
    T = boyd2.true_transitions(0)
    R = boyd2.domain.rewards(np.asarray(boyd2.robots[0].weights, float))
    Q = value_iteration(TabularMDP(T, R, boyd2.discount)).q_values
    rng = np.random.default_rng(0)
    changed = policy.copy()
    picked = rng.choice(len(policy), size=40, replace=False)
    changed[picked] = rng.integers(0, Q.shape[1], size=40)
    best = Q.max(axis=1)
    expected = np.mean(Q[np.arange(len(changed)), changed] >= best - 1e-6 * np.abs(best) - 1e-6)
    assert behavior_accuracy(boyd2, 0, changed) == pytest.approx(expected)
    assert behavior_accuracy(boyd2, 0, changed) < 1.0


def test_agreement_counts_the_moves_l_saw():
    d = load_scenario("boyd2").domain
    s = 0
    a_policy, a_other = 0, 1
    target = int(d.intended[s, a_policy])
    other = int(d.intended[s, a_other])
    assert target != other
    nowhere = next(
        x for x in range(d.n_states) if x not in d.intended[s] and x != s
    )  # no action of s leads there
    policy = np.full(d.n_states, a_policy)
    #        followed     other action  unseen gap   unexplained
    series = [s, target, -1, s, other, -1, -1, s, nowhere]
    got = observed_agreement(d, np.array(series), policy)
    assert got == ObservedAgreement(moves=3, followed=1, unexplained=1)
    assert got.share == pytest.approx(1 / 3)
    assert observed_agreement(d, np.array([s, -1, s]), policy).share is None


def test_the_truth_as_a_result(boyd2):
    truth = oracle_models(boyd2)
    assert truth.method == "oracle" and [r.name for r in truth.robots] == ["I", "J"]
    j = truth.robot("J")
    assert np.array_equal(j.policy, boyd2.true_policy(1)) and j.behavior_accuracy == 1.0
    assert dict(j.feature_probabilities) == dict(boyd2.robots[1].feature_probabilities)
    assert all(
        lo == hi == j.feature_probabilities[f] for f, (lo, hi) in j.feature_intervals.items()
    )
    assert j.verdict is not None and j.verdict.named == ("left_wheel",)  # boyd2's damaged wheel
    assert truth.pair_equilibrium(0, 1) == boyd2.pair_equilibrium(0, 1)
    assert oracle_models(boyd2, method="known-r-t").method == "known-r-t"
    with pytest.raises(KeyError, match="no robot 'L': the robots are I, J"):
        truth.robot("L")


def test_a_pair_without_its_own_equilibrium_plays_the_teams(boyd2):
    truth = oracle_models(boyd2)
    alone = LearnResult("oracle", truth.robots, truth.equilibrium)
    assert alone.pair_equilibrium(0, 1) is truth.equilibrium

