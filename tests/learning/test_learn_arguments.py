"""learn() at its boundary: arguments it cannot work with are refused before any work, with a
message naming the argument; a scenario may be given by name."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.learn import learn
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def record():
    sc = load_scenario("boyd2")
    return sc, simulate(sc, 60, seed=1, observability=0.14).observations


def test_a_scenario_name_is_the_scenario(record):
    sc, obs = record
    by_name = learn(obs, "boyd2", "mirl", score=False)
    by_object = learn(obs, sc, "mirl", score=False)
    for a, b in zip(by_name.robots, by_object.robots, strict=True):
        np.testing.assert_array_equal(a.weights, b.weights)
        np.testing.assert_array_equal(a.policy, b.policy)


@pytest.mark.parametrize(
    ("change", "error", "needle"),
    [
        ({"observations": None}, TypeError, "observations must be"),
        ({"observations": [[0, 1]]}, TypeError, "observations must be"),
        ({"scenario": 3}, TypeError, "scenario must be"),
        ({"random_state": -1}, ValueError, "random_state"),
        ({"random_state": 1.5}, ValueError, "random_state"),
        ({"visible": np.ones(5, bool)}, ValueError, "visible must have shape"),
        ({"visible": np.full(124, 2)}, ValueError, "visible must be booleans"),
        ({"options": {"label_tol": 2.0}}, ValueError, "`label_tol` must be a number in"),
        ({"options": {"labeltol": 0.1}}, ValueError, "did you mean 'label_tol'"),
        ({"options": 3}, TypeError, "`options` must be a LearnOptions"),
        ({"method": "mirl-t", "options": {"p": 0.5}}, ValueError, "`p` applies to the methods"),
        ({"random_state": 2**63}, ValueError, r"`random_state` must be an integer in \[0, 2\^63"),
        ({"observability": "0.5"}, ValueError, "`observability`"),
        ({"observability": 1.5}, ValueError, "`observability`"),
        ({"score": "no"}, ValueError, "`score`"),
        ({"trace": {}}, TypeError, "trace must be an empty"),
    ],
)
def test_bad_arguments_are_named(record, change, error, needle):
    sc, obs = record
    kwargs = {"observations": obs, "scenario": sc, "method": "mirl", "score": False} | change
    with pytest.raises(error, match=needle):
        learn(**kwargs)


def test_numpy_integer_seed_and_01_visible_are_accepted(record):
    sc, obs = record
    visible = sc.domain.visible_states(0.14)
    a = learn(obs, sc, "mirl", random_state=np.int64(2), visible=visible.astype(int), score=False)
    b = learn(obs, sc, "mirl", random_state=2, visible=visible, score=False)
    np.testing.assert_array_equal(a.robots[0].weights, b.robots[0].weights)


def test_simulate_takes_a_scenario_by_name_too(record):
    sc, _ = record
    by_name = simulate("boyd2", 40, seed=4, observability=0.14)
    by_object = simulate(sc, 40, seed=4, observability=0.14)
    np.testing.assert_array_equal(by_name.true_states, by_object.true_states)
    with pytest.raises(TypeError, match="scenario must be"):
        simulate(None, 40, seed=4)


@pytest.mark.parametrize(
    ("option", "needle"),
    [
        ({"temperature": 0.0}, "temperature must be positive"),
        ({"l2": -1.0}, "l2 must be at least 0"),
        ({"max_evaluations": 0}, "max_evaluations must be at least 1"),
        ({"n_restarts": 0}, "n_restarts must be at least 1"),
    ],
)
def test_irl_options_that_would_fit_nothing_are_refused(option, needle):
    # each ran and returned θ = 0 (or a NaN policy) without a word
    from mirl.learning.irl import OccludedMaxEntIRL

    with pytest.raises(ValueError, match=needle):
        OccludedMaxEntIRL(**option)


def test_an_irl_problem_with_a_view_of_another_map_is_refused():
    import scipy.sparse as sp

    from mirl.learning.irl import IRLProblem

    stay = sp.csr_array((np.ones(6), (np.arange(6), np.repeat(np.arange(3), 2))), shape=(6, 3))
    with pytest.raises(ValueError, match=r"visible must be \(3,\)"):
        IRLProblem(np.zeros((3, 2, 1)), stay, 0.9, visible=np.ones(7, bool))


def test_backward_induction_refuses_a_negative_horizon():
    import scipy.sparse as sp

    from mirl.mdp import backward_induction

    stay = sp.csr_array((np.ones(6), (np.arange(6), np.repeat(np.arange(3), 2))), shape=(6, 3))
    with pytest.raises(ValueError, match="horizon must be at least 0"):
        backward_induction(stay, np.zeros((3, 2)), -1)
    assert backward_induction(stay, np.zeros((3, 2)), 0).values.shape == (1, 3)
