"""DBN-EM transition learner (exact E-step, monotone EM) and the random baseline."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mirl.learning.dbn_em import em_fit, em_transition_model, expected_counts, initial_transitions
from mirl.simulation.grid import simulate
from mirl.world.domain import PatrolDomain
from mirl.world.maps import parse_map
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def tiny():
    return PatrolDomain(parse_map("L.G\n", name="chain"))  # 2 cells × 4 headings


def _random_params(S: int, A: int, seed: int):
    rng = np.random.default_rng(seed)
    pi = rng.dirichlet(np.ones(A), size=S)
    T = rng.dirichlet(np.ones(S) * 0.5, size=(S, A))
    return pi, T


def _brute_force(pi, T, x):
    """Expected counts and log-likelihood by enumerating every hidden state and action path."""
    S, A, _ = T.shape
    n = len(x)
    hidden = [t for t in range(n) if x[t] < 0]
    N = np.zeros((S, A, S))
    Z = 0.0
    for fill in itertools.product(range(S), repeat=len(hidden)):
        s = np.array(x)
        s[hidden] = fill
        for acts in itertools.product(range(A), repeat=n - 1):
            w = 1.0 / S  # uniform prior on s_0
            for t, a in enumerate(acts):
                w *= pi[s[t], a] * T[s[t], a, s[t + 1]]
            Z += w
            for t, a in enumerate(acts):
                N[s[t], a, s[t + 1]] += w
    return N / Z, np.log(Z)


@pytest.mark.parametrize("series", [[3, -1, -1, 5, -1], [-1, 2, -1, 6], [0, 1, 5, 4]])
def test_e_step_matches_enumeration_of_hidden_paths(tiny, series):
    S, A = tiny.n_states, tiny.n_actions
    pi, T = _random_params(S, A, seed=len(series))
    N, ll = expected_counts(pi, T, [np.array(series)])
    N_ref, ll_ref = _brute_force(pi, T, series)
    np.testing.assert_allclose(N, N_ref, rtol=1e-9, atol=1e-12)
    assert ll == pytest.approx(ll_ref, rel=1e-10)
    assert N.sum() == pytest.approx(len(series) - 1)  # one transition per step


def test_e_step_sums_over_several_series(tiny):
    pi, T = _random_params(tiny.n_states, tiny.n_actions, seed=7)
    a, b = np.array([1, -1, 3]), np.array([-1, 4, -1, 0])
    N, ll = expected_counts(pi, T, [a, b])
    Na, la = expected_counts(pi, T, [a])
    Nb, lb = expected_counts(pi, T, [b])
    np.testing.assert_allclose(N, Na + Nb)
    assert ll == pytest.approx(la + lb)


@pytest.mark.parametrize("init", ["intended", "uniform"])
def test_em_log_likelihood_never_decreases(init):
    sc = load_scenario("boyd2")
    sim = simulate(sc, 250, seed=3, random_starts=True, observability=0.3)
    x = sim.observations.state_series(sc.domain, 0)
    assert (x >= 0).sum() > 20
    res = em_fit(sc.domain, [x], n_iter=12, tol=-np.inf, init=init)
    ll = np.array(res.log_likelihood)
    assert len(ll) == 12
    assert np.all(np.diff(ll) >= -1e-9 * np.abs(ll[1:]))
    assert ll[-1] > ll[0]


def test_em_output_is_a_transition_matrix_and_unseen_states_keep_their_init():
    sc = load_scenario("boyd2")
    dom = sc.domain
    sim = simulate(sc, 120, seed=1, random_starts=True, observability=1.0)
    x = sim.observations.state_series(dom, 0)  # fully observed
    T = em_transition_model(dom, [x], n_iter=5)
    S, A = dom.n_states, dom.n_actions
    assert T.shape == (S * A, S)
    assert np.asarray(T.sum(axis=1)).ravel() == pytest.approx(1.0)
    dense = T.toarray().reshape(S, A, S)
    init = initial_transitions(dom, "intended")
    never = np.setdiff1d(np.arange(S), x[:-1])
    np.testing.assert_allclose(dense[never], init[never])
    # actions are hidden and the init is the same for all of them: EM cannot tell them apart
    np.testing.assert_allclose(dense, np.repeat(dense[:, :1], A, axis=1))


def test_em_with_full_observation_learns_the_empirical_chain():
    sc = load_scenario("boyd2")
    dom = sc.domain
    x = simulate(sc, 400, seed=2, random_starts=True, observability=1.0).truth.state_series(dom, 1)
    res = em_fit(dom, [x], n_iter=3)
    P = np.einsum("sa,sat->st", res.policy, res.transitions)
    counts = np.zeros((dom.n_states, dom.n_states))
    np.add.at(counts, (x[:-1], x[1:]), 1)
    seen = counts.sum(axis=1) > 0
    np.testing.assert_allclose(P[seen], counts[seen] / counts[seen].sum(axis=1, keepdims=True))


def test_em_rejects_bad_input(tiny):
    with pytest.raises(ValueError, match="outside"):
        em_transition_model(tiny, [np.array([0, 99])])
    with pytest.raises(ValueError, match="initialisation"):
        em_transition_model(tiny, [np.array([0, 1])], init="bogus")


def test_random_go_is_uniform_over_the_window():
    from mirl.experiments.episode import _random_going
    from mirl.planning.observer import observer_model

    model = observer_model(load_scenario("boyd2"))
    rng = np.random.default_rng(0)
    draws = np.array([_random_going(model, 0, 5, rng).go_time for _ in range(3000)])
    assert draws.min() == 0 and draws.max() == 5
    assert np.bincount(draws) / len(draws) == pytest.approx(np.full(6, 1 / 6), abs=0.03)


def test_em_on_the_support_is_the_dense_em():
    """Where the dense T does not fit, EM runs on the intended successors only: the same
    updates, so on a map where both fit they agree to rounding, iteration by iteration."""
    from mirl.learning.dbn_em import em_fit_on_support

    sc = load_scenario("boyd2")
    runs = [simulate(sc, 300, seed=k, observability=0.5).observations for k in (1, 2)]
    for robot, obs in itertools.product(range(2), runs):
        xs = [obs.state_series(sc.domain, robot)]
        dense = em_fit(sc.domain, xs, n_iter=6, tol=-np.inf)
        sparse, history = em_fit_on_support(sc.domain, xs, n_iter=6, tol=-np.inf)
        expected = dense.transition_matrix().toarray()
        np.testing.assert_allclose(sparse.toarray(), expected, atol=1e-12)
        np.testing.assert_allclose(history, dense.log_likelihood, rtol=1e-12)


def test_observations_no_move_reaches_are_left_out_and_counted():
    """A skipped cell (a pose discretised two cells on) would make the data impossible for EM:
    that observation is left out as unseen and counted; a simulated record loses nothing."""
    from mirl.learning.dbn_em import em_transitions, unreachable_observations

    sc = load_scenario("boyd2")
    obs = simulate(sc, 300, seed=3, observability=0.5).observations
    x = obs.state_series(sc.domain, 0)
    assert not unreachable_observations(sc.domain, x).any()
    t = int(np.flatnonzero((x[:-1] >= 0) & (x[1:] >= 0))[0])  # two observed steps in a row
    far = int(np.argmax(np.abs(sc.domain.states[:, 0] - sc.domain.states[x[t], 0])))
    jumped = x.copy()
    jumped[t + 1] = far  # rows away in one step: no move reaches it
    assert np.flatnonzero(unreachable_observations(sc.domain, jumped)).tolist() == [t + 1]
    T, dropped = em_transitions(sc.domain, [jumped], n_iter=3)
    assert dropped == 1 and T.shape == (sc.domain.n_states * 4, sc.domain.n_states)
    with pytest.raises(ValueError, match="impossible"):
        em_fit(sc.domain, [jumped], n_iter=1)
