"""Occluded max-ent IRL and equilibrium weighting, on hand-checkable models."""

from __future__ import annotations

import itertools
from functools import partial

import numpy as np
import pytest
import scipy.sparse as sp

from mirl.learning.equilibria import joint_log_likelihood, potential_meetings, weigh_equilibria
from mirl.learning.irl import ANCHORS, OBJECTIVES, IRLProblem, OccludedMaxEntIRL
from mirl.learning.soft_policy import soft_policy_iteration
from mirl.mdp import TabularMDP, soft_value_iteration, value_iteration
from mirl.world.domain import FORWARD, STOP
from mirl.world.scenario import load_scenario

LEFT, RIGHT, STAY = range(3)


def corridor(n: int = 5, p: float = 0.9):
    """A 1-D corridor: left / right / stay, success p, failures to the other actions' cells.
    Features: 'stay at the east end' and 'moving'."""
    psi = np.array([[max(s - 1, 0), min(s + 1, n - 1), s] for s in range(n)])
    T = np.zeros((n, 3, n))
    for s, a in itertools.product(range(n), range(3)):
        T[s, a, psi[s, a]] += p
        for b in range(3):
            if b != a:
                T[s, a, psi[s, b]] += (1 - p) / 2
    phi = np.zeros((n, 3, 2))
    phi[n - 1, STAY, 0] = 1.0
    phi[:, [LEFT, RIGHT], 1] = 1.0
    return sp.csr_array(T.reshape(n * 3, n)), T, phi


def rollout(T3, policy, steps, rng, restart_every=30):
    n = T3.shape[0]
    x, a = np.zeros(steps, dtype=int), np.zeros(steps, dtype=int)
    s = 0
    for t in range(steps):
        if t % restart_every == 0:
            s = int(rng.integers(n))
        x[t], a[t] = s, policy[s]
        s = int(rng.choice(n, p=T3[s, a[t]]))
    return x, a


@pytest.fixture(scope="module")
def expert():
    T, T3, phi = corridor()
    theta = np.array([1.0, -0.1])
    policy = value_iteration(TabularMDP(T, phi @ theta, 0.9)).policy
    x, a = rollout(T3, policy, 300, np.random.default_rng(0))
    return T, T3, phi, policy, x, a


def test_true_corridor_policy_is_right_then_stay(expert):
    *_, policy, _, _ = expert
    assert policy.tolist() == [RIGHT, RIGHT, RIGHT, RIGHT, STAY]


def test_soft_policy_iteration_matches_soft_value_iteration(expert):
    T, _, phi, *_ = expert
    R = phi @ np.array([0.7, -0.3])
    V, Q, pi, it = soft_policy_iteration(T, R, 0.9, temperature=0.5)
    ref = soft_value_iteration(TabularMDP(T, R, 0.9), temperature=0.5)
    assert it < 20
    np.testing.assert_allclose(V, ref.values, atol=1e-6)
    np.testing.assert_allclose(pi, ref.policy, atol=1e-7)


@pytest.mark.parametrize("objective", OBJECTIVES)
@pytest.mark.parametrize("optimizer", ["lbfgs", "nelder-mead"])
def test_fully_observed_expert_policy_is_recovered(expert, objective, optimizer):
    T, _, phi, policy, x, a = expert
    irl = OccludedMaxEntIRL(objective=objective, optimizer=optimizer, random_state=0).fit(
        IRLProblem(phi, T, discount=0.9), x, a
    )
    assert irl.policy_.tolist() == policy.tolist()
    assert irl.result_.x.shape == (2,) and np.isfinite(irl.result_.fun)


def test_policy_is_recovered_with_the_east_end_occluded(expert):
    """Only the sequence likelihood sees, through the time the robot spends out of view, that it
    stays at the (hidden) east end; feature counts on the visible cells cannot."""
    T, _, phi, policy, x, a = expert
    objective = "sequence"
    visible = np.array([True, True, True, False, False])
    x_obs = np.where(visible[x], x, -1)
    problem = IRLProblem(phi, T, discount=0.9, visible=visible)
    irl = OccludedMaxEntIRL(objective=objective, random_state=0).fit(problem, x_obs, a)
    assert irl.policy_.tolist() == policy.tolist()


def test_occluded_steps_contribute_nothing_to_the_expert_counts(expert):
    T, _, phi, _, x, a = expert
    visible = np.array([True, True, False, False, True])
    x_obs = np.where(visible[x], x, -1)
    seen = x_obs >= 0
    labels = np.where(seen, a, -1)
    problem = IRLProblem(phi, T, discount=0.9, visible=visible)
    fit = partial(OccludedMaxEntIRL(objective="sequence").fit, problem)
    counts = fit(x_obs, labels).expert_counts_
    # by hand: φ(s_t, a_t) summed over the observed, labelled steps only
    np.testing.assert_allclose(counts, phi[x[seen], a[seen]].sum(axis=0))
    # whatever happened while occluded (other actions, other labels) changes nothing
    scrambled = labels.copy()
    scrambled[~seen] = np.random.default_rng(1).integers(0, 3, (~seen).sum())
    np.testing.assert_allclose(fit(x_obs, scrambled).expert_counts_, counts)
    # while the expected counts are over observable states only
    irl = fit(x_obs, labels)
    assert irl.expected_counts_[0] > 0  # the east end (feature 0) is observable here
    hidden_only = OccludedMaxEntIRL(objective="counts").fit(
        IRLProblem(phi, T, discount=0.9, visible=np.array([True, True, True, True, False])),
        np.where(x < 4, x, -1),
        np.where(x < 4, a, -1),
    )
    assert hidden_only.expert_counts_[0] == 0 and hidden_only.expected_counts_[0] == 0


@pytest.mark.parametrize("objective", OBJECTIVES)
@pytest.mark.parametrize("anchor", ANCHORS)
def test_gradients_match_finite_differences(expert, objective, anchor):
    T, _, phi, _, x, a = expert
    visible = np.array([True, True, False, False, True])
    irl = OccludedMaxEntIRL(objective=objective, anchor=anchor)
    irl._prepare(
        IRLProblem(phi, T, discount=0.9, visible=visible), np.where(visible[x], x, -1), a, None
    )
    irl._V_warm = None
    theta = np.array([0.8, -0.4])
    _, g = irl._loss(theta, grad=True)
    eps = 1e-6
    num = [(irl._loss(theta + eps * e) - irl._loss(theta - eps * e)) / (2 * eps) for e in np.eye(2)]
    np.testing.assert_allclose(g, num, rtol=1e-4, atol=1e-7)


def test_sequence_likelihood_equals_enumeration_over_occluded_paths(expert):
    T, T3, phi, *_ = expert
    visible = np.array([True, True, False, False, False])
    x = np.array([0, 1, -1, -1, 1, -1, -1, 1, -1, -1])
    irl = OccludedMaxEntIRL(objective="sequence")
    irl._prepare(IRLProblem(phi, T, discount=0.9, visible=visible), x, None, None)
    irl._V_warm = None
    _, _, pi = irl._soft(np.array([0.3, -0.7]))
    ll, _ = irl._sequence_loglik(pi, irl._dyn.transposed_policy(pi))
    P = np.einsum("sa,sat->st", pi, T3)
    hidden = np.flatnonzero(~visible)
    occluded = np.flatnonzero(x < 0)
    total = 0.0
    for fill in itertools.product(hidden, repeat=len(occluded)):
        path = x.copy()
        path[occluded] = fill
        total += np.prod(P[path[:-1], path[1:]])
    assert ll == pytest.approx(np.log(total), rel=1e-10)


def test_restarts_are_seeded(expert):
    T, _, phi, _, x, a = expert
    fits = [
        OccludedMaxEntIRL(optimizer="nelder-mead", n_restarts=3, random_state=7).fit(
            IRLProblem(phi, T, discount=0.9), x, a
        )
        for _ in range(2)
    ]
    np.testing.assert_array_equal(fits[0].weights_, fits[1].weights_)
    assert len(fits[0].result_.starts) == 3


def test_a_looser_tol_stops_sooner_near_the_same_weights(expert):
    """``tol`` (L-BFGS-B's ftol) trades digits of θ that no policy reads for evaluations; the
    default keeps scipy's, which every published result used."""
    T, _, phi, policy, x, a = expert
    visible = np.array([True, True, True, False, False])
    x_obs = np.where(visible[x], x, -1)
    fits = {
        tol: OccludedMaxEntIRL(tol=tol).fit(
            IRLProblem(phi, T, discount=0.9, visible=visible), x_obs, a
        )
        for tol in (None, 1e-5)
    }
    loose, default = fits[1e-5], fits[None]
    assert loose.result_.nfev < default.result_.nfev  # measured: 10 against 46
    assert loose.policy_.tolist() == default.policy_.tolist() == policy.tolist()
    assert loose.result_.fun <= default.result_.fun * (1 + 1e-5)
    np.testing.assert_allclose(loose.weights_, default.weights_, rtol=1e-3)
    with pytest.raises(ValueError, match="tol must be positive"):
        OccludedMaxEntIRL(tol=0.0)


def test_bad_inputs_are_rejected(expert):
    T, _, phi, *_ = expert
    with pytest.raises(ValueError, match="objective"):
        OccludedMaxEntIRL(objective="magic")
    for option, typo, meant in (
        ("objective", "sequense", "sequence"),
        ("optimizer", "l-bfgs", "lbfgs"),
        ("anchor", "re-entry", "reentry"),
        ("gradient", "reversed", "reverse"),
    ):  # each choice is a table's name: an unknown one answers with the nearest
        near = f"unknown {option} '{typo}' \\(did you mean '{meant}'"
        with pytest.raises(ValueError, match=near):
            OccludedMaxEntIRL(**{option: typo})
    with pytest.raises(ValueError, match="never observed"):
        OccludedMaxEntIRL().fit(IRLProblem(phi, T, 0.9), np.full(10, -1))


@pytest.mark.parametrize(
    ("setting", "needle"),
    [
        ({"n_restarts": 2.5}, "n_restarts must be an integer, got 2.5"),
        ({"n_restarts": True}, "n_restarts must be an integer, got True"),
        ({"max_evaluations": 10.5}, "max_evaluations must be an integer, got 10.5"),
        ({"temperature": "1"}, "temperature must be a finite number, got '1'"),
        ({"temperature": np.inf}, "temperature must be a finite number, got inf"),
        ({"l2": np.inf}, "l2 must be a finite number, got inf"),
        ({"tol": np.inf}, "tol must be a finite number or None, got inf"),
        ({"random_state": -1}, r"random_state must be an integer in \[0, 2\^63 - 1\], a numpy"),
        ({"random_state": "x"}, "random_state must be .*, got 'x'"),
    ],
)
def test_settings_of_the_wrong_kind_are_refused_by_the_constructor(expert, setting, needle):
    """A fractional number of starts or evaluations ran (scipy took ``maxfun=10.5``), a string
    failed as a comparison, an infinite temperature fitted nothing, and a bad seed was found
    only by ``fit``: each is now refused where the settings are checked, set_params too."""
    with pytest.raises(ValueError, match=needle):
        OccludedMaxEntIRL(**setting)
    est = OccludedMaxEntIRL()
    with pytest.raises(ValueError, match=needle):
        est.set_params(**setting)
    assert est.get_params() == OccludedMaxEntIRL().get_params()
    kept = OccludedMaxEntIRL(n_restarts=np.int64(2), random_state=np.random.default_rng(0))
    assert kept.n_restarts == 2  # numpy's integers and a Generator are settings


def test_a_problem_that_does_not_fit_together_is_refused_where_it_is_made(expert):
    T, _, phi, *_ = expert
    for kwargs, needle in (
        ({"features": phi[0]}, r"features must be \(S, A, K\), got shape \(3, 2\)"),
        ({"transitions": T[:5]}, r"transitions must be \(15, 5\), got \(5, 5\)"),
        ({"visible": np.ones(4, bool)}, r"visible must be \(5,\), got \(4,\)"),
        ({"discount": 1.0}, r"discount must be in \[0, 1\), got 1.0"),
    ):
        with pytest.raises(ValueError, match=needle):
            IRLProblem(**{"features": phi, "transitions": T, "discount": 0.9, **kwargs})
    problem = IRLProblem(phi.astype(int), T, 0.9, visible=[1, 1, 0, 0, 1])
    assert problem.features.dtype == float and problem.visible.dtype == bool
    assert problem.transitions is T  # kept as given: learn() asks which T a fit used


def test_one_estimator_fits_two_problems_as_two_fresh_ones_do(expert):
    """The problem is fit()'s: nothing of the first fit (its warm values, its operator's
    pattern) leaks into the second."""
    T, T3, phi, _, x, a = expert
    other, *_ = corridor(p=0.7)
    problems = [IRLProblem(phi, T, discount=0.9), IRLProblem(phi, other, discount=0.8)]
    reused = OccludedMaxEntIRL(random_state=0)
    for problem in problems:
        fresh = OccludedMaxEntIRL(random_state=0).fit(problem, x, a)
        reused.fit(problem, x, a)
        assert reused.problem_ is problem
        np.testing.assert_array_equal(reused.weights_, fresh.weights_)
        np.testing.assert_array_equal(reused.policy_, fresh.policy_)


# ---- interactions on boyd2 -------------------------------------------------------------------
@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def head_on(d, i_moves: bool, j_moves: bool):
    """I at (0,4) heading east and J at (0,6) heading west both want (0,5): a meeting."""
    i0, j0 = int(d.state_index(0, 4, 0)), int(d.state_index(0, 6, 2))
    i1 = int(d.state_index(0, 5, 0)) if i_moves else i0
    j1 = int(d.state_index(0, 5, 2)) if j_moves else j0
    return [np.array([i0, i1]), np.array([j0, j1])]


@pytest.mark.parametrize(
    ("i_moves", "j_moves", "expected"), [(False, True, "stop/go"), (True, False, "go/stop")]
)
def test_observed_yield_picks_the_matching_equilibrium(boyd2, i_moves, j_moves, expected):
    d = boyd2.domain
    policies = [boyd2.true_policy(i) for i in range(2)]
    assert policies[0][int(d.state_index(0, 4, 0))] == FORWARD
    assert policies[1][int(d.state_index(0, 6, 2))] == FORWARD
    series = head_on(d, i_moves, j_moves)
    w = weigh_equilibria(
        d,
        series,
        policies,
        [boyd2.true_transitions(i) for i in range(2)],
        boyd2.game.equilibria(),
        d.visible_states(1.0),
    )
    assert w.equilibrium.label() == expected
    assert w.n_meetings == 1
    assert w.weights.sum() == pytest.approx(1.0)
    assert np.argmax(w.meeting_log_likelihoods) == w.best


def test_joint_filter_matches_independent_robots_without_meetings(boyd2):
    """Far apart, the joint likelihood is the product of the two robots' own likelihoods."""
    d = boyd2.domain
    pol = [boyd2.true_policy(i) for i in range(2)]
    T = [boyd2.true_transitions(i) for i in range(2)]
    a = [int(d.state_index(0, 2, 0)), int(d.state_index(0, 3, 0))]
    b = [int(d.state_index(16, 8, 2)), int(d.state_index(16, 7, 2))]
    vis = d.visible_states(1.0)
    ll = joint_log_likelihood(d, [np.array(a), np.array(b)], pol, T, boyd2.played_equilibrium, vis)
    eps = 1e-3
    own = []
    for p, t, (s0, s1) in zip(pol, T, (a, b), strict=True):
        pi = np.full(4, eps / 4)
        pi[p[s0]] += 1 - eps
        own.append(float(pi @ t.toarray().reshape(d.n_states, 4, d.n_states)[s0, :, s1]))
    prior = -2 * np.log(d.n_states)
    assert ll == pytest.approx(prior + np.log(own[0]) + np.log(own[1]), rel=1e-9)


def test_potential_meetings_need_both_robots_in_view_and_close(boyd2):
    d = boyd2.domain
    series = head_on(d, False, True)
    assert potential_meetings(d, *series).tolist() == [True, True]
    far = [series[0], np.array([int(d.state_index(16, 8, 2))] * 2)]
    assert potential_meetings(d, *far).tolist() == [False, False]
    hidden = [series[0], np.array([-1, series[1][1]])]
    assert potential_meetings(d, *hidden).tolist() == [False, True]
    assert STOP == 3  # the yielding robot's observed 'stay' is the stop action
