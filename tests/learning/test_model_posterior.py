"""Model sets drawn from a posterior (mirl.learning.model_posterior), checked against
independent computations on small cases: the bootstrap records against the terms of the
record's likelihood, the feature draws and the posterior-averaged chance against quadrature of
the exact one-dimensional posterior, the Hessian against second differences of the loss."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import beta as beta_dist

from mirl.learning.model_posterior import (
    _feature_draws,
    _hessian,
    _Robot,
    _total_loss,
    bootstrap_series,
    draw_models,
    greedy_policy_of,
    importance_resample,
    visits,
)
from mirl.learning.results import LearnResult, RobotModel
from mirl.learning.verdicts import PriorSpec
from mirl.mdp import TabularMDP, value_iteration
from mirl.planning.belief import BeliefFilter
from mirl.planning.go import solve_observer_mdp
from mirl.planning.observer import observer_model
from mirl.planning.posterior_chance import PosteriorBeliefs
from mirl.planning.success import success_probability
from mirl.world.domain import STOP
from mirl.world.game import Equilibrium
from mirl.world.motion import transition_matrix
from mirl.world.scenario import HEALTHY_PROBABILITIES, load_scenario
from tests.planning.test_planner import CORRIDOR, _scenario


def _terms(x: np.ndarray, exclude: np.ndarray) -> list[tuple]:
    """The terms of the sequence likelihood of a record (mirl.learning.sequence), computed here
    from its definition: each observed step (s, s') whose time is not excluded, and each
    occluded gap after the first observation (exit state, length, re-entry state or -1)."""
    seen = x >= 0
    out: list[tuple] = []
    first = int(np.flatnonzero(seen)[0])
    t = first
    while t < len(x) - 1:
        if seen[t] and seen[t + 1] and not exclude[t]:
            out.append(("step", int(x[t]), int(x[t + 1])))
        if seen[t] and not seen[t + 1]:
            u = t + 1
            while u < len(x) and not seen[u]:
                u += 1
            out.append(("gap", int(x[t]), u - t, int(x[u]) if u < len(x) else -1))
        t += 1
    return out


@pytest.mark.parametrize("seed", range(20))
def test_a_bootstrap_record_holds_only_terms_of_the_record(seed):
    rng = np.random.default_rng(seed)
    H = int(rng.integers(5, 60))
    x = np.where(rng.random(H) < 0.5, rng.integers(0, 30, H), -1)
    x[int(rng.integers(0, H))] = 7  # seen at least once
    exclude = rng.random(H) < 0.1
    original = _terms(x, exclude)
    for _ in range(5):
        xb, eb = bootstrap_series(x, exclude, rng)
        assert len(xb) == len(eb)
        assert len(visits(xb)) <= len(visits(x)) or len(visits(x)) == 0
        for term in _terms(xb, eb):
            assert term in original, (term, x.tolist(), xb.tolist())


def test_visits_cut_the_record_at_re_entries():
    x = np.array([-1, 3, 4, -1, -1, 5, -1, 6, 7, -1])
    assert visits(x) == [(1, 5), (5, 7), (7, 9)]


def _stopper(sc, floor: float) -> RobotModel:
    """A patroller that always stops; with the ``uniform`` error model a failed stop moves it
    to another action's intended state, so its motion depends on the floor feature alone."""
    probs = dict(HEALTHY_PROBABILITIES, floor=floor)
    T = transition_matrix(sc.domain, probs)
    policy = np.full(sc.domain.n_states, STOP)
    return RobotModel("P0", np.zeros(4), probs, T, policy)


def _floor_posterior(k: int, n: int, m: int = 4000):
    """The floor's posterior of stop counts (k of n succeeded) under the verdicts' prior, by
    quadrature on a grid of m points."""
    prior = PriorSpec()
    h = HEALTHY_PROBABILITIES["floor"]
    p = (np.arange(m) + 0.5) / m
    dens = (1 - prior.damaged_share) * beta_dist.pdf(
        p, prior.strength * h, prior.strength * (1 - h)
    ) + prior.damaged_share
    w = dens * p**k * (1 - p) ** (n - k)
    return p, w / w.sum()


def _stop_record(sc, k: int, n: int):
    """A record of one robot at (0, 4), all in view: n steps labelled stop, of which every
    (n // (n − k))-th failed — a failed stop turns it left, or back right — and the rest held.
    Failures are spread out, so the outcomes are not clustered (no dispersion)."""
    dom = sc.domain
    states = (dom.state_index(0, 4, 0), dom.state_index(0, 4, 1))
    every = n // (n - k)
    fails = {every * (j + 1) - 1 for j in range(n - k)}
    x, side = [states[0]], 0
    for j in range(n):
        if j in fails:
            side = 1 - side
        x.append(states[side])
    return np.array(x), np.full(len(x), STOP)


def _counted(x) -> tuple[int, int]:
    """Stops that held and all steps, counted here from the record."""
    return int((x[:-1] == x[1:]).sum()), len(x) - 1


def test_feature_draws_match_the_exact_posterior_of_the_floor():
    sc = _scenario(CORRIDOR, [(0, 4, 0)])
    x, labels = _stop_record(sc, k=12, n=16)
    robot = _Robot(x, _stopper(sc, 0.75), labels)
    draws = _feature_draws(sc, robot, 4000, seed=1, soften=False)
    floor = np.array([d["floor"] for d in draws])
    p, w = _floor_posterior(*_counted(x))
    assert floor.mean() == pytest.approx(float(w @ p), abs=0.01)
    cdf = np.cumsum(w)
    for q in (0.1, 0.5, 0.9):
        assert np.quantile(floor, q) == pytest.approx(p[np.searchsorted(cdf, q)], abs=0.03)
    # a feature no step tells about keeps its prior: healthy (Beta around 0.95) w.p. 0.8; the
    # sampler's draws of it are correlated (its moves mix the prior's two parts slowly), so the
    # mean is taken over several seeds' draws
    wheel = [
        np.mean([d["left_wheel"] for d in _feature_draws(sc, robot, 4000, seed, soften=False)])
        for seed in range(1, 7)
    ]
    assert np.mean(wheel) == pytest.approx(0.8 * 0.95 + 0.2 * 0.5, abs=0.02)


def test_the_averaged_chance_is_the_posterior_predictive_chance():
    # a stopping patroller at (0, 3) facing east, seeing 2 cells: it sees L's path only once
    # a failed stop has turned it round; its floor sets how soon that happens
    sc = _scenario(CORRIDOR, [(0, 3, 0)], detect_distance=2)
    dom = sc.domain
    model = observer_model(sc)
    x, labels = _stop_record(sc, k=6, n=10)
    point = _stopper(sc, 0.6)
    eq = Equilibrium((1.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    visible = np.ones(dom.n_states, bool)
    start = [dom.state_index(0, 3, 0)]

    def filtered(robot: RobotModel) -> BeliefFilter:
        f = BeliefFilter(dom, LearnResult("hand", (robot,), eq), visible=visible)
        f.update(start)
        return f

    f = filtered(point)
    plan = solve_observer_mdp(model, f.predict(10, model), window=0, detection_penalty=0.0)
    draws = _feature_draws(sc, _Robot(x, point, labels), 800, seed=2, soften=False)
    models = [LearnResult("hand", (_stopper(sc, d["floor"]),), eq) for d in draws]
    beliefs = PosteriorBeliefs(dom, models, visible=visible)
    beliefs.update(start)
    averaged = beliefs.success(model, plan, extra=4)
    # the same chance by quadrature over the floor's exact posterior
    p, w = _floor_posterior(*_counted(x), m=200)
    grid = np.array(
        [success_probability(filtered(_stopper(sc, q)), model, plan, extra=4).success for q in p]
    )
    exact = float(w @ grid)
    assert averaged.std() > 0.02  # the floor matters to the chance here
    assert averaged.mean() == pytest.approx(exact, abs=3 * averaged.std() / np.sqrt(len(draws)))


def test_the_hessian_is_the_losss_second_difference():
    from mirl.simulation.grid import PatrolSimulator

    sc = load_scenario("boyd2")
    sim = PatrolSimulator(sc)
    sim.reset(seed=3)
    true = np.array([sim.states[0]] + [sim.step()[4]["states"][0] for _ in range(199)])
    visible = sc.domain.visible_states(0.3)
    x = np.where(visible[true], true, -1)  # what L sees of it at 30 % view
    loss = _total_loss(sc, sc.true_transitions(0), x, np.zeros(200, bool), visible, {})
    theta = np.array([3.0, 0.2, 0.1, 0.8])
    H = _hessian(loss, theta)
    e = 1e-3
    for i, j in [(0, 0), (1, 3), (2, 2)]:
        ei, ej = np.eye(4)[i] * e, np.eye(4)[j] * e
        second = (
            loss(theta + ei + ej)[0] - loss(theta + ei - ej)[0]
            - loss(theta - ei + ej)[0] + loss(theta - ei - ej)[0]
        ) / (4 * e * e)  # fmt: skip
        assert H[i, j] == pytest.approx(second, rel=2e-3, abs=2e-3)


def test_draws_of_a_fixed_part_stay_fixed():
    sc = _scenario(CORRIDOR, [(0, 3, 0)])
    point = _stopper(sc, 0.6)
    learned = LearnResult("known-r", (point,), Equilibrium((1.0, 0, 0), (1.0, 0, 0)))
    x, _ = _stop_record(sc, 5, 8)
    draws = draw_models(learned, [x], sc, visible=np.ones(sc.domain.n_states, bool), n_draws=3)
    for d in draws:  # Known R: true reward, fixed p — nothing is drawn
        assert d.robots[0].transitions is point.transitions
        assert d.robots[0].weights is point.weights


def test_policy_iteration_finds_value_iterations_greedy_policy():
    sc = load_scenario("boyd2")
    dom = sc.domain
    rng = np.random.default_rng(0)
    healthy = transition_matrix(dom, dict(HEALTHY_PROBABILITIES))
    for _ in range(10):
        R = dom.rewards(rng.normal(0.0, 2.0, 4).tolist())
        T = transition_matrix(dom, {f: rng.uniform(0.3, 1.0) for f in dom.feature_map.features})
        start = value_iteration(TabularMDP(healthy, R, sc.discount)).policy
        expected = value_iteration(TabularMDP(T, R, sc.discount)).policy
        assert np.array_equal(greedy_policy_of(T, R, sc.discount, start), expected)


def test_a_record_that_saw_no_robot_keeps_the_point_rewards():
    sc = load_scenario("boyd2")
    from mirl.learning.results import oracle_models

    truth = oracle_models(sc)
    point = LearnResult(
        "mirl-t",
        tuple(r.__class__(r.name, np.zeros(4), {}, r.transitions, r.policy) for r in truth.robots),
        truth.equilibrium,
    )
    unseen = [np.full(50, -1), np.full(50, -1)]
    draws = draw_models(
        point, unseen, sc, visible=np.zeros(sc.domain.n_states, bool), n_draws=3,
        parts=("rewards",), reward="laplace", shared=True,
    )  # fmt: skip
    for d in draws:
        for r in d.robots:
            assert np.array_equal(r.weights, np.zeros(4))


def test_importance_resampling_reaches_a_non_gaussian_posterior():
    # a banana: x0 ~ N(1, 1), x1 | x0 ~ N(x0², 0.5²); E[x1] = E[x0²] = 2, Cov(x0, x1) = 2
    def log_posterior(x):
        return -0.5 * ((x[0] - 1.0) ** 2 + (x[1] - x[0] ** 2) ** 2 / 0.25)

    rng = np.random.default_rng(4)
    # from the Gaussian of the target's means and variances, which has no covariance at all
    draws = importance_resample(
        np.array([1.0, 2.0]), np.diag([1.0, 2.5]), log_posterior, 4000, 40000, rng
    )
    x = np.array(draws)
    assert x.mean(axis=0) == pytest.approx([1.0, 2.0], abs=0.1)
    assert np.cov(x.T)[0, 1] == pytest.approx(2.0, abs=0.3)
