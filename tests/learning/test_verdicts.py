"""Intervals and fault verdicts (mirl.learning.verdicts), checked against a brute-force grid
posterior, on simulated data, and through learn(). The motion models' evidence and the model
check have their own tests (test_motion_models.py, test_model_check.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import beta as beta_dist

from mirl.learning.learn import learn
from mirl.learning.transitions import observed_steps
from mirl.learning.verdicts import (
    LateralDrift,
    PriorSpec,
    RobotRecord,
    Verdict,
    drift_log_likelihood,
    failure_dispersion,
    feature_uncertainty,
    free_pace,
    held_by_others,
    in_company,
    lateral_drift,
    point_verdict,
    posterior_draws,
    robot_uncertainty,
    verdict_from_draws,
)
from mirl.simulation.grid import PatrolSimulator
from mirl.world.domain import FORWARD as FORWARD_ACTION
from mirl.world.faults import WHEELS, DamageDefinition, DriftSpec
from mirl.world.scenario import load_scenario

FEATURES = ("left_wheel", "right_wheel", "navigation", "floor")
FORWARD = FEATURES
TURN_LEFT = ("right_wheel", "navigation", "floor")
TURN_RIGHT = ("left_wheel", "navigation", "floor")


def _grid_posterior(obs, healthy, prior, m=600):
    """The posterior of two features (a, b) on an m × m grid of p, by direct evaluation."""
    p = (np.arange(m) + 0.5) / m
    pa, pb = np.meshgrid(p, p, indexing="ij")

    def prior_pdf(x, h):
        k = prior.strength
        return (1 - prior.damaged_share) * beta_dist.pdf(
            x, k * h, k * (1 - h)
        ) + prior.damaged_share

    log = np.log(prior_pdf(pa, healthy["a"])) + np.log(prior_pdf(pb, healthy["b"]))
    for subset, k, n in obs:
        q = (pa if "a" in subset else 1.0) * (pb if "b" in subset else 1.0)
        log += k * np.log(q) + (n - k) * np.log1p(-q)
    w = np.exp(log - log.max())
    return pa, pb, w / w.sum()


@pytest.mark.parametrize(
    "obs",
    [
        [(("a", "b"), 14, 20), (("a",), 9, 10)],  # b identified through a
        [(("a", "b"), 7, 10)],  # only the product: a ridge
        [(("a", "b"), 40, 40)],
    ],
)
def test_draws_match_a_brute_force_posterior(obs):
    healthy = {"a": 0.95, "b": 0.9}
    prior = PriorSpec()
    definition = DamageDefinition(healthy, 0.15)
    pa, pb, w = _grid_posterior(obs, healthy, prior)
    p, weights = posterior_draws(("a", "b"), obs, healthy, n_draws=4000, random_state=3)
    for i, grid in enumerate((pa, pb)):
        exact = float((w * grid).sum())
        assert weights @ p[:, i] == pytest.approx(exact, abs=0.02)
    damaged_a = float(w[pa < definition.threshold("a")].sum())
    verdict = verdict_from_draws(("a", "b"), p, weights, definition)
    assert verdict.damage_probabilities["a"] == pytest.approx(damaged_a, abs=0.04)
    none = float(w[(pa >= definition.threshold("a")) & (pb >= definition.threshold("b"))].sum())
    if not verdict.names_damage:
        assert verdict.confidence == pytest.approx(none, abs=0.04)


def _obs(forward, left, right, stop):
    return [
        (FORWARD, *forward),
        (TURN_LEFT, *left),
        (TURN_RIGHT, *right),
        (("floor",), *stop),
    ]


def test_a_damaged_left_wheel_is_named():
    u = feature_uncertainty(
        FEATURES, _obs((70, 100), (48, 50), (35, 50), (50, 50)), DamageDefinition()
    )
    assert u.verdict.part == "left_wheel"
    assert u.verdict.confidence > 0.85
    lo, hi = u.intervals["left_wheel"]
    assert lo < 0.7 < hi < 0.85
    assert "J's left wheel is damaged" in u.verdict.sentence("J")


def test_forward_steps_alone_cannot_tell_the_wheels_apart():
    u = feature_uncertainty(FEATURES, [(FORWARD, 30, 60)], DamageDefinition())
    v = u.verdict
    assert v.part is None and len(v.candidates) >= 2
    assert {"left_wheel", "right_wheel"} <= set(v.candidates)
    assert v.confidence > 0.9
    assert "cannot tell which" in v.sentence("I")


def test_healthy_data_give_no_part():
    u = feature_uncertainty(
        FEATURES, _obs((190, 200), (48, 50), (48, 50), (50, 50)), DamageDefinition()
    )
    assert u.verdict.part is None and not u.verdict.candidates
    assert u.verdict.confidence > 0.95
    assert u.verdict.sentence("I").startswith("no part of I is damaged")


def test_no_data_is_no_confident_verdict():
    u = feature_uncertainty(FEATURES, [], DamageDefinition())
    assert u.verdict.confidence < 0.9


def test_dispersion_widens_the_intervals():
    obs = _obs((70, 100), (48, 50), (35, 50), (50, 50))
    narrow = feature_uncertainty(FEATURES, obs, DamageDefinition())
    wide = feature_uncertainty(FEATURES, obs, DamageDefinition(), dispersion=4.0)
    widths = [np.subtract(*u.intervals["left_wheel"][::-1]) for u in (narrow, wide)]
    assert widths[1] > 1.5 * widths[0]
    with pytest.raises(ValueError, match="`dispersion`"):
        feature_uncertainty(FEATURES, obs, DamageDefinition(), dispersion=0.5)


@pytest.mark.slow
def test_intervals_cover_the_truth_drawn_from_the_prior():
    """Bayesian coverage: truths drawn from the prior, data from the truths; the 95 % intervals
    contain the truth in about 95 % of cases."""
    rng = np.random.default_rng(0)
    prior = PriorSpec()
    hits, total = 0, 0
    for rep in range(150):
        h = np.array([0.95, 0.95, 0.97, 0.99])
        p = rng.beta(prior.strength * h, prior.strength * (1 - h))
        hurt = rng.random(4) < prior.damaged_share
        p[hurt] = rng.random(hurt.sum())
        truth = dict(zip(FEATURES, p, strict=True))
        obs = []
        for subset, n in ((FORWARD, 60), (TURN_LEFT, 15), (TURN_RIGHT, 15), (("floor",), 20)):
            q = float(np.prod([truth[f] for f in subset]))
            obs.append((subset, int(rng.binomial(n, q)), n))
        u = feature_uncertainty(FEATURES, obs, DamageDefinition(), random_state=rep)
        for f in FEATURES:
            lo, hi = u.intervals[f]
            hits += lo <= truth[f] <= hi
            total += 1
    assert 0.90 <= hits / total <= 0.99


def test_verdict_records():
    v = Verdict(None, 0.93, ("left_wheel", "right_wheel"), {"left_wheel": 0.6})
    assert v.is_right(("right_wheel",)) and not v.is_right(("floor",)) and not v.is_right(())
    assert Verdict(None, 0.9).is_right(()) and not Verdict(None, 0.9).is_right(("floor",))
    assert v.to_dict()["candidates"] == ["left_wheel", "right_wheel"]
    assert "one of I's wheels is weak" in v.sentence("I")
    truth = point_verdict({"left_wheel": 0.7, "right_wheel": 0.95}, DamageDefinition())
    assert truth.part == "left_wheel" and truth.confidence == 1.0


def _draws_damaging(probabilities, n=2000, seed=0):
    """Equally weighted draws of four parts, each below its threshold (0.8) with the given
    probability, independently."""
    rng = np.random.default_rng(seed)
    damaged = rng.random((n, len(FEATURES))) < np.array(probabilities)
    p = np.where(damaged, 0.5, 0.95)
    return p, np.full(n, 1.0 / n)


def test_a_part_the_draws_single_out_is_named_and_another_likely_one_said_besides():
    """The verdict names the fewest parts that hold the probability of damage; a part more
    probably damaged than not beyond them is damaged besides, not an alternative L cannot
    tell from the named one."""
    p, w = _draws_damaging([1.0, 0.0, 0.6, 0.0])
    v = verdict_from_draws(FEATURES, p, w, DamageDefinition())
    assert v.part == "left_wheel" and v.confidence == pytest.approx(1.0)
    assert v.also == ("navigation",)
    said = v.sentence("J")
    assert said.startswith("J's left wheel is damaged (confidence 1.00)")
    assert "its navigation is probably damaged too (0.6" in said
    assert "cannot tell which" not in said
    assert v.to_dict()["also"] == ["navigation"]
    p, w = _draws_damaging([0.99, 0.97, 0.0, 0.0])
    v = verdict_from_draws(FEATURES, p, w, DamageDefinition())
    assert v.part == "left_wheel" and v.also == ("right_wheel",)
    p, w = _draws_damaging([0.55, 0.0, 0.45, 0.0])  # neither alone holds the damage
    v = verdict_from_draws(FEATURES, p, w, DamageDefinition())
    assert set(v.candidates) == {"left_wheel", "navigation"} and v.also == ()
    assert "cannot tell which" in v.sentence("J")
    p, w = _draws_damaging([0.3, 0.0, 0.0, 0.0])
    v = verdict_from_draws(FEATURES, p, w, DamageDefinition())
    assert not v.names_damage and v.also == () and "also" not in v.to_dict()


def test_the_parts_said_damaged_are_those_whose_median_is_below_the_threshold():
    """One answer per question: a part is named or said damaged besides exactly when more than
    half its draws are damaged (its median below the threshold)."""
    for seed in range(20):
        rng = np.random.default_rng(seed)
        probs = rng.choice([0.0, 0.2, 0.45, 0.55, 0.8, 1.0], size=4)
        p, w = _draws_damaging(probs, seed=seed)
        v = verdict_from_draws(FEATURES, p, w, DamageDefinition())
        if not v.names_damage:
            continue
        medians = np.median(p, axis=0)
        below = {f for f, m in zip(FEATURES, medians, strict=True) if m < 0.8}
        assert below <= set(v.named) | set(v.also)
        assert set(v.also) == {f for f in below if f not in v.named}


def _steps(seed=0, steps=300):
    scenario = load_scenario("boyd2")
    sim = PatrolSimulator(scenario, observability=1.0)
    _, info = sim.reset(seed=seed)
    states = [info["states"].copy()]
    for _ in range(steps):
        info = sim.step()[-1]
        states.append(info["states"].copy())
    return scenario, np.asarray(states)


def _full_view_record(scenario, seed: int, steps: int):
    """The patrollers' record of a grid simulation, every step seen."""
    from mirl.observations.trajectories import Trajectories

    sim = PatrolSimulator(scenario, observability=1.0)
    _, info = sim.reset(seed=seed)
    states = [info["states"].copy()]
    for _ in range(steps):
        states.append(sim.step()[-1]["states"].copy())
    return Trajectories.from_states(scenario.domain, scenario.robot_names, np.asarray(states))


def test_dispersion_sees_clustered_failures():
    scenario, states = _steps()
    d = scenario.domain
    t, s, s_next = observed_steps(states[:, 1])
    labels = scenario.true_policy(1)[s]
    probs = scenario.robots[1].feature_probabilities
    independent = failure_dispersion(d, t, s, labels, s_next, probs)
    assert independent < 1.6
    stuck = s_next.copy()
    stuck[100:140] = s[100:140]  # forty failures in a row (a robot on a wall)
    stuck_labels = labels.copy()
    stuck_labels[100:140] = 0  # each labelled forward
    assert failure_dispersion(d, t, s, stuck_labels, stuck, probs) > independent + 0.2


def test_learn_returns_intervals_and_verdicts():
    scenario, states = _steps(seed=1, steps=300)
    from mirl.observations.trajectories import Trajectories

    obs = Trajectories.from_states(scenario.domain, scenario.robot_names, states)
    res = learn(obs, scenario, "mirl-t", observability=1.0)
    j = res.robot("J")
    assert set(j.feature_intervals) == set(FEATURES)
    for lo, hi in j.feature_intervals.values():
        assert 0 <= lo <= hi <= 1
    assert j.verdict is not None and j.verdict.part == "left_wheel"
    assert "verdicts" in res.timings
    fixed = learn(obs, scenario, "mirl", observability=1.0)
    assert all(r.verdict is None and not r.feature_intervals for r in fixed.robots)


@pytest.mark.parametrize("gap", [-0.6, -0.1, 0.0, 0.05, 0.4])
@pytest.mark.parametrize("mean", [-0.12, 0.0, 0.07])
def test_drift_likelihood_integrates_the_drift_scale_out(gap, mean):
    """The skew-normal closed form against numerical integration over κ ~ N⁺(0, scale²)."""
    from scipy import integrate
    from scipy.stats import norm

    drift, spec = LateralDrift(mean, 0.01, 100), DriftSpec()
    s = np.hypot(drift.se, spec.tolerance)
    ref = integrate.quad(
        lambda k: norm.pdf(mean, k * gap, s) * 2 * norm.pdf(k, 0, spec.scale), 0, np.inf
    )[0]
    got = float(np.exp(drift_log_likelihood(np.array([gap]), drift, spec))[0])
    assert got == pytest.approx(ref, rel=1e-7)


@pytest.mark.parametrize("gap", [-0.6, -0.1, 0.0, 0.05, 0.4])
@pytest.mark.parametrize("mean", [-0.12, 0.0, 0.07])
def test_drift_likelihood_with_a_measured_drift_per_gap(gap, mean):
    """κ measured (N(m, (spread m)²)): the normal closed form against numerical integration."""
    from scipy import integrate
    from scipy.stats import norm

    drift, spec = LateralDrift(mean, 0.01, 100), DriftSpec(per_gap=0.25, spread=0.3)
    s = np.hypot(drift.se, spec.tolerance)
    sd = spec.spread * spec.per_gap
    ref = integrate.quad(
        lambda k: norm.pdf(mean, k * gap, s) * norm.pdf(k, spec.per_gap, sd), -np.inf, np.inf
    )[0]
    got = float(np.exp(drift_log_likelihood(np.array([gap]), drift, spec))[0])
    assert got == pytest.approx(ref, rel=1e-7)


def test_a_measured_drift_per_gap_pins_the_gap_a_free_one_does_not():
    """With κ unknown a small gap with a large κ explains a drift as well as a large gap; with κ
    measured the drift says how far apart the wheels are."""
    drift = LateralDrift(0.085, 0.01, 100)
    gaps = np.array([0.1, 0.35])  # p_right − p_left: a veer to the left
    free = drift_log_likelihood(gaps, drift, DriftSpec())
    known = drift_log_likelihood(gaps, drift, DriftSpec(per_gap=0.25))
    assert abs(free[0] - free[1]) < 0.5
    assert known[1] - known[0] > 2.5


def test_the_scenario_says_how_a_weak_wheel_drifts():
    """The verdict reads κ from the scenario's fault definition: a measured κ turns a drift that
    a free κ leaves open into the wheel."""
    # the physical world's ξ: turns need no wheel (mirl.physics.config.physical_feature_map)
    obs = [(FORWARD, 170, 300), (("navigation", "floor"), 32, 40), (("floor",), 98, 109)]
    drift = LateralDrift(0.085, 0.009, 100)
    free = feature_uncertainty(FEATURES, obs, DamageDefinition(), drift=drift).verdict
    measured = DamageDefinition(drift=DriftSpec(per_gap=0.25))
    known = feature_uncertainty(FEATURES, obs, measured, drift=drift).verdict
    assert known.damage_probabilities["left_wheel"] > free.damage_probabilities["left_wheel"]
    assert known.part == "left_wheel" and known.damage_probabilities["right_wheel"] < 0.05


@pytest.mark.parametrize("side", [+1, -1])
def test_drift_tells_the_wheels_apart_where_forward_steps_cannot(side):
    """Forward steps alone fix only the product of the wheels; a robot that veers left
    (positive offset) has the weaker left wheel, one that veers right the weaker right."""
    obs = [(FORWARD, 30, 60), (TURN_LEFT, 10, 10), (TURN_RIGHT, 10, 10), (("floor",), 20, 20)]
    without = feature_uncertainty(FEATURES, obs, DamageDefinition()).verdict
    drift = LateralDrift(side * 0.1, 0.01, 60)
    u = feature_uncertainty(FEATURES, obs, DamageDefinition(), drift=drift)
    weak, other = ("left_wheel", "right_wheel")[::side]
    probs = u.verdict.damage_probabilities
    assert probs[weak] > 0.8 > 0.2 > probs[other]
    assert probs[weak] > without.damage_probabilities[weak] + 0.2
    assert u.drift is drift


def test_no_drift_is_no_evidence_of_a_side():
    obs = [(FORWARD, 30, 60), (TURN_LEFT, 10, 10), (TURN_RIGHT, 10, 10)]
    u = feature_uncertainty(FEATURES, obs, DamageDefinition(), drift=LateralDrift(0.0, 0.01, 60))
    probs = u.verdict.damage_probabilities
    assert abs(probs["left_wheel"] - probs["right_wheel"]) < 0.1


def test_lateral_drift_is_the_mean_offset_after_forward_steps():
    d = load_scenario("boyd2").domain
    east = [d.state_index(0, c, 0) for c in range(1, 8)]  # along the top hallway, facing east
    turned = d.state_index(0, 7, 1)
    series = np.array(east + [turned, -1, -1])
    labels = np.array([0] * 6 + [1, 0, -1, -1])  # forward ×6, then turn_left (index 1)
    lateral = np.array([0.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.5, np.nan, np.nan])
    t, s, s_next = observed_steps(series)
    got = lateral_drift(d, t, s, labels[t], s_next, lateral)
    assert got.steps == 6 and got.mean == pytest.approx(0.1)  # the turn's end is left out
    assert got.se == pytest.approx(0.0)
    assert lateral_drift(d, t, s, labels[t], s_next, np.full(10, np.nan)) is None
    # a forward step that failed (stayed put) is no drift: a robot on a wall is off for the wall
    stuck = np.array(east[:4] + [east[3]] * 3 + [-1] * 3)
    t, s, s_next = observed_steps(stuck)
    got = lateral_drift(d, t, s, np.zeros(len(t), dtype=int), s_next, lateral, min_steps=1)
    assert got.steps == 3 and got.mean == pytest.approx(0.1)  # the three that arrived
    assert LateralDrift(-0.125, 0.008, 313).sentence() == (
        "0.125 cell to the right of the centre line (± 0.008) on 313 forward steps"
    )


def test_drift_leaves_out_steps_in_company():
    """Robots passing each other keep to one side: those steps say nothing of a wheel."""
    d = load_scenario("boyd2").domain
    east = np.array([d.state_index(0, c, 0) for c in range(1, 9)])
    far = np.full(8, d.state_index(16, 8, 2))  # the other robot, 16 cells away
    near = far.copy()
    near[4:] = d.state_index(0, 8, 2)  # ... until it appears at the hallway's end, coming west
    near[6] = -1  # unseen: not known to be near
    lateral = np.array([0.0] * 4 + [-0.2] * 4)
    labels = np.zeros(7, dtype=int)
    t, s, s_next = observed_steps(east)
    alone = in_company(d, [east, far], 0, 6.0)
    assert not alone.any()
    company = in_company(d, [east, near], 0, 6.0)
    assert company.tolist() == [False] * 4 + [True, True, False, True]
    assert lateral_drift(d, t, s, labels, s_next, lateral, alone).steps == 7
    got = lateral_drift(d, t, s, labels, s_next, lateral, company, min_steps=3)
    assert got.steps == 3 and got.mean == pytest.approx(0.0)


def test_a_robot_following_or_leading_another_is_not_in_company():
    """Only a robot coming the other way, ahead or alongside, makes a robot keep to one side:
    one following it, one it follows, and one it has passed do not."""
    d = load_scenario("boyd2").domain
    east = np.array([d.state_index(0, c, 0) for c in range(2, 7)])
    behind = np.array([d.state_index(0, c, 0) for c in range(1, 6)])  # follows, same way
    ahead = np.array([d.state_index(0, c, 0) for c in range(3, 8)])  # leads, same way
    passed = np.full(5, d.state_index(0, 1, 2))  # behind it, going west: they have passed
    coming = np.full(5, d.state_index(0, 8, 2))  # ahead, coming west
    for other in (behind, ahead, passed):
        assert not in_company(d, [east, other], 0, 6.0).any()
    assert in_company(d, [east, coming], 0, 6.0).all()


def test_a_robot_crossing_ahead_is_company():
    """A robot crossing the hallway ahead (heading at a right angle, either way) makes a
    physical robot keep right as one coming the other way does; one crossing behind it, or
    farther than the distance, does not."""
    d = load_scenario("boydright-3").domain
    north = np.array([d.state_index(r, 10, 1) for r in (5, 4, 3, 2, 1)])  # K up its branch
    for heading in (0, 2):  # I on the top hallway, going east or west, near the crossing
        crossing = np.full(5, d.state_index(0, 9, heading))
        assert in_company(d, [north, crossing], 0, 6.0).all()
        far = np.full(5, d.state_index(0, 2, heading))
        assert not in_company(d, [north, far], 0, 6.0).any()
    behind = np.full(4, d.state_index(5, 10, 0))  # crossing behind K, which starts a cell on
    assert not in_company(d, [north[1:], behind], 0, 6.0).any()


def test_a_robot_in_the_way_holds_a_robot():
    """Another robot in a robot's cell or up to two cells ahead of it holds it; one behind it,
    one three cells ahead, one two cells away across the robot's heading and one L does not
    see do not. Either robot of the pair may be the one held."""
    d = load_scenario("boydright").domain
    east = np.full(6, d.state_index(0, 3, 0))
    others = [
        (d.state_index(0, 3, 2), True),  # the same cell, any heading
        (d.state_index(0, 4, 2), True),  # the cell ahead
        (d.state_index(0, 5, 2), True),  # two cells ahead, coming the other way
        (d.state_index(0, 5, 0), True),  # two cells ahead, going the same way
        (d.state_index(0, 2, 0), False),  # the cell behind
        (d.state_index(0, 6, 2), False),  # three cells ahead
        (-1, False),  # unseen
    ]
    for state, held in others:  # no step starts at the last time
        assert held_by_others(d, [east, np.full(6, state)], 0).tolist() == [held] * 5 + [False]
    # the other way round: the robot going east holds the other only where it is ahead of it
    assert held_by_others(d, [np.full(6, d.state_index(0, 5, 2)), east], 0)[:5].all()
    assert not held_by_others(d, [np.full(6, d.state_index(0, 5, 0)), east], 0).any()


def test_a_robot_in_the_way_at_the_step_s_end_holds_a_robot():
    """The step from t to t + 1 is held when the other robot is in the way at t + 1 only: it
    came into the cell the robot was heading for. Read against where the robot was at t. Where
    L did not see the other robot, its cell a step earlier (later) counts, one cell nearer."""
    d = load_scenario("boyd2").domain
    robot = np.array([d.state_index(0, 3, 0)] * 5)
    ahead = np.array([-1, -1, d.state_index(0, 4, 2), -1, -1])  # seen in the cell ahead at t = 2
    # steps 1 (its end) and 2 (its start); 0 and 3 from a step away: within one cell
    assert held_by_others(d, [robot, ahead], 0).tolist() == [True, True, True, True, False]
    two = np.array([-1, -1, d.state_index(0, 5, 2), -1, -1])  # seen two cells ahead at t = 2
    assert held_by_others(d, [robot, two], 0).tolist() == [False, True, True, False, False]
    # a robot moving on: at t = 1 it is at (0, 2), the other three cells ahead at t = 2; at
    # t = 3 the robot is at (0, 4), the other one cell ahead a step before
    moving = np.array([d.state_index(0, c, 0) for c in (1, 2, 3, 4, 5)])
    far = np.array([-1, -1, d.state_index(0, 5, 2), -1, -1])
    assert held_by_others(d, [moving, far], 0).tolist() == [False, False, True, True, False]


def test_a_step_blocked_two_cells_ahead_is_left_out():
    """A healthy robot whose forward steps fail only while a slow robot stands two cells
    ahead of it (the one it has caught up with): those steps are left out, never failures of
    its parts, and L is sure it is healthy; counted, they make it look damaged."""
    scenario, states = _steps()
    d = scenario.domain
    i = scenario.robot_index("I")
    x = states[:, i].copy()
    policy = scenario.true_policy(i)
    blocked = []
    other = np.full(len(x), -1)
    for k in range(20, len(x) - 2, 5):  # now and then, a robot two cells ahead stops it
        one = d.intended[x[k], FORWARD_ACTION]
        two = d.intended[one, FORWARD_ACTION]
        if policy[x[k]] != FORWARD_ACTION or one == x[k] or two == one:
            continue
        x[k + 1 :] = np.concatenate([[x[k]] * 2, x[k + 1 : -2]])  # two steps put, then on
        other[k : k + 2] = two
        blocked += [k, k + 1]
    assert len(blocked) >= 40
    t, s, s_next = observed_steps(x)
    labels = np.full(len(x), -1)
    labels[t] = policy[s]
    probs = scenario.robots[i].feature_probabilities
    held = held_by_others(d, [x, other], 0)
    assert held[blocked].all()
    counted = robot_uncertainty(d, RobotRecord(x, labels), probs, scenario.faults)
    free = robot_uncertainty(d, RobotRecord(x, labels, held=held), probs, scenario.faults)
    assert counted.verdict.names_damage
    assert free.verdict.fit.left_out["in another robot's way"] == int(held[t].sum())
    assert free.verdict.part is None and not free.verdict.candidates
    assert free.verdict.confidence > 0.9


def test_steps_held_by_another_robot_are_no_evidence_of_a_part():
    """A healthy robot jammed against another for forty steps fails every step there; those
    steps are the other robot's doing, and left out, L is sure the robot is healthy again."""
    scenario, states = _steps()
    d = scenario.domain
    i = scenario.robot_index("I")
    x = states[:, i].copy()
    x[101:141] = x[100]  # stuck from step 100 on ...
    other = np.full(len(x), -1)
    other[100:141] = d.state_index(*d.states[x[100]][:2], (d.states[x[100]][2] + 2) % 4)
    t, s, s_next = observed_steps(x)
    labels = np.full(len(x), -1)
    labels[t] = scenario.true_policy(i)[s]
    probs = scenario.robots[i].feature_probabilities
    definition = scenario.faults
    jammed = robot_uncertainty(d, RobotRecord(x, labels), probs, definition)
    held = held_by_others(d, [x, other], 0)
    assert held[99:141].all() and held.sum() == 42  # from the step that ends beside it
    free = robot_uncertainty(d, RobotRecord(x, labels, held=held), probs, definition)
    # the jam makes a damaged part likely, or fails the check; left out, it is gone
    assert jammed.verdict.part is not None or jammed.verdict.candidates or not jammed.verdict.fit.ok
    assert free.verdict.fit.ok
    assert free.verdict.part is None and free.verdict.confidence > 0.99
    # the step into the other's cell and the forty stuck there; the stuck robot's jump back
    # to its own track at step 140 is explained by no action
    assert free.verdict.fit.left_out["in another robot's way"] == 41


def test_a_record_spent_queueing_gives_no_confident_verdict():
    """A healthy robot that stood behind another for nearly all its record, whose labels come
    from a policy that learned from the queue to stand: its 15 free moves look like failed
    stays. The queue's steps are left out either way; with them most of the record and fewer
    than 20 free steps left, the record does not fit and the verdict is not confident."""
    from mirl.world.actions import STOP

    scenario, states = _steps()
    d = scenario.domain
    i = scenario.robot_index("I")
    x0 = states[:16, i]
    assert (x0[1:] != x0[:-1]).all()  # 15 moves
    x = np.repeat(x0, 29)[28:]  # each state held 28 steps before the move on
    queued = np.flatnonzero(x[1:] == x[:-1])
    held = np.zeros(len(x), dtype=bool)
    held[queued] = True  # another robot in its way (held_by_others's tests say where)
    t, _, _ = observed_steps(x)
    assert len(t) - held[t].sum() == 15
    labels = np.full(len(x), STOP)  # what a policy learned from the queue says
    probs = scenario.robots[i].feature_probabilities
    # the free moves alone, judged by those labels, say a part is damaged (15 steps: too few
    # for a confident claim, which the "few steps" check says of them alone)
    free = robot_uncertainty(d, RobotRecord(x0, labels[:16]), probs, scenario.faults)
    assert free.verdict.names_damage
    assert [c.name for c in free.verdict.fit.checks if not c.ok] == ["few steps"]
    queue = robot_uncertainty(d, RobotRecord(x, labels, held=held), probs, scenario.faults)
    assert queue.verdict.fit.left_out["in another robot's way"] == held[t].sum()
    checks = {c.name: c for c in queue.verdict.fit.checks}
    assert not checks["in the way"].ok and "most of its record" in checks["in the way"].reason
    assert queue.verdict.confidence < 0.8


def test_a_wheel_that_only_drifts_is_weakened_not_damaged():
    """A robot that veers to the right beyond a healthy robot's spread, where the verdict is
    that no part is damaged: its right wheel is weakened, its moves unaffected."""
    from mirl.learning.verdicts import weakened_wheel

    spec = DriftSpec(per_gap=0.25)
    right = LateralDrift(-0.06, 0.008, 120)
    assert weakened_wheel(right, spec, ()) == "right_wheel"
    assert weakened_wheel(LateralDrift(0.06, 0.008, 120), spec, ()) == "left_wheel"
    assert weakened_wheel(LateralDrift(-0.02, 0.008, 120), spec, ()) is None  # within τ
    assert weakened_wheel(right, spec, ("right_wheel",)) is None  # damaged, said so
    assert weakened_wheel(None, spec, ()) is None
    v = Verdict(None, 0.97, weakened="right_wheel")
    assert v.sentence("I") == (
        "no part of I is damaged (confidence 0.97); its right wheel is weakened, its moves "
        "unaffected"
    )
    assert v.to_dict()["weakened"] == "right_wheel"


# ---- parts every move needs, and parts that together fail every move --------------------------
def _brute_force_together(subsets, common):
    """Every set of non-common parts that holds a part of each move's subset, minimal by
    inclusion, united: by enumerating all sets of the features."""
    import itertools

    rest = [set(s) - common for s in subsets]
    pool = sorted(set().union(*rest))
    sets = [
        set(c) for k in range(len(pool) + 1) for c in itertools.combinations(pool, k)
    ]  # fmt: skip
    hitting = [h for h in sets if all(r & h for r in rest)]
    minimal = [h for h in hitting if not any(o < h for o in hitting)]
    return set().union(*minimal) if all(rest) else set()


def test_parts_that_fail_every_move_under_the_papers_xi():
    from mirl.learning.motion_models import candidate_models
    from mirl.learning.verdicts import confounded_parts

    scenario = load_scenario("boyd2")
    models = candidate_models(scenario.domain.feature_map)
    paper, free, mirror = {m.xi: m.feature_map for m in models}.values()
    assert confounded_parts(paper) == ({"navigation", "floor"}, {"left_wheel", "right_wheel"})
    assert confounded_parts(mirror) == confounded_parts(paper)  # the same parts, swapped
    # turns that need no wheel fail only with a common part: no confounding
    assert confounded_parts(free) == ({"navigation", "floor"}, frozenset())


@pytest.mark.parametrize("seed", range(6))
def test_confounded_parts_match_a_brute_force(seed):
    from mirl.learning.verdicts import MOVING_ACTIONS, confounded_parts
    from mirl.world.domain import FeatureMap

    rng = np.random.default_rng(seed)
    features = ("a", "b", "c", "d", "e")
    subsets = {
        a: tuple(f for f in features if rng.random() < 0.6) or ("a",)
        for a in (*MOVING_ACTIONS, "stop")
    }
    fm = FeatureMap(features, subsets)
    common, together = confounded_parts(fm)
    moving = [set(subsets[a]) for a in MOVING_ACTIONS]
    assert common == set.intersection(*moving)
    assert together == _brute_force_together(moving, set(common))


def test_both_wheels_are_not_ruled_out_for_navigation_or_floor():
    """Both of J's wheels at 0.7 on the grid: its labelled steps fail alike whatever they
    try, and a verdict that names navigation or the floor names the wheels with them."""
    scenario = load_scenario("boyd2-healthy")
    scenario = scenario.with_damage("J", "left_wheel", 0.7).with_damage("J", "right_wheel", 0.7)
    named_wheel = 0
    for seed in range(3):
        obs = _full_view_record(scenario, seed, 450)
        verdict = learn(obs, scenario, "mirl-t", observability=1.0).robot("J").verdict
        assert verdict is not None and verdict.names_damage
        if verdict.confidence >= 0.9:
            assert verdict.is_right(("left_wheel", "right_wheel")), verdict
        named_wheel += any(w in verdict.named for w in WHEELS)
    assert named_wheel == 3


@pytest.mark.parametrize(("paper_weight", "widened"), [(0.03, True), (0.005, False)])
def test_a_model_the_record_does_not_rule_out_widens_a_common_part(paper_weight, widened):
    """The draws say the floor is damaged; a model whose turns need a wheel (both wheels then
    fail every move, as the floor does) held at 0.03 of the weight is not ruled out, and the
    wheels join the verdict with their pooled probability; at 0.005 it is (odds under 1 : 99)."""
    from mirl.learning.motion_models import MotionPosterior, candidate_models
    from mirl.learning.verdicts import NOT_RULED_OUT, _common_parts_widened

    scenario = load_scenario("boyd2")
    fm = scenario.domain.feature_map
    pair = ("paper/uniform", "free-turns/uniform")
    models = tuple(m for m in candidate_models(fm) if m.name in pair)
    assert [m.name for m in models] == ["paper/uniform", "free-turns/uniform"]
    assert NOT_RULED_OUT <= 0.03 and 0.005 < NOT_RULED_OUT
    post = MotionPosterior(
        fm.features, models, np.array([paper_weight, 1 - paper_weight]), draws=()
    )
    rng = np.random.default_rng(0)
    p = rng.uniform(0.9, 1.0, (200, 4))
    p[:, 3] = rng.uniform(0.5, 0.7, 200)  # the floor, damaged in every draw
    p[:50, 0] = 0.6  # the left wheel damaged in a quarter of them
    w = np.full(200, 1 / 200)
    floor = Verdict("floor", 1.0, (), {})
    out = _common_parts_widened(floor, post, fm.features, p, w, scenario.faults)
    if widened:
        assert set(out.named) == {"floor", "left_wheel", "right_wheel"}
        assert out.confidence == pytest.approx(1.0)
    else:
        assert out == floor


def test_a_robot_s_free_pace_counts_its_stays_and_moves_alone_that_keep_its_heading():
    """Steps that stay in the cell and steps that move one cell, keeping the heading; turns,
    steps with an unseen end and steps with another robot in the way are not counted."""
    d = load_scenario("boydright").domain
    e = [d.state_index(0, c, 0) for c in range(8)]
    robot = np.array([e[1], e[1], e[2], e[2], e[3], d.state_index(0, 3, 1), -1, e[5], e[5]])
    alone = np.full(len(robot), -1)
    # stays: 0->1, 2->3; moves: 1->2, 3->4; a turn 4->5; unseen ends 5->6, 6->7; a stay 7->8
    assert free_pace(d, [robot, alone], 0) == (3, 2)
    other = alone.copy()
    other[7] = d.state_index(0, 6, 2)  # in the way of the last step
    assert free_pace(d, [robot, other], 0) == (2, 2)


# --------------------------------------------------------------------------------------------
# The robot beside its team


@pytest.mark.parametrize(
    ("own", "other", "ratio"),
    [((221, 283), (279, 282), 0.842), ((30, 40), (38, 40), 0.842), ((5, 5), (0, 3), 0.9),
     ((90, 100), (95, 100), 0.5)],
)  # fmt: skip
def test_below_probability_agrees_with_sampling(own, other, ratio):
    from mirl.learning.verdicts import below_probability

    rng = np.random.default_rng(0)
    n = 400_000
    a = rng.beta(1 + own[0], 1 + own[1] - own[0], n)
    b = rng.beta(1 + other[0], 1 + other[1] - other[0], n)
    sampled = float(np.mean(a < ratio * b))
    assert below_probability(own, other, ratio) == pytest.approx(sampled, abs=0.004)


@given(
    own=st.tuples(st.integers(0, 900), st.integers(0, 900)),
    other=st.tuples(st.integers(0, 900), st.integers(0, 900)),
    ratio=st.floats(0.05, 1.0),
)
@settings(max_examples=60, deadline=None)
def test_below_probability_is_scipy_stats_beta_quadrature_bit_for_bit(own, other, ratio):
    """The reference: the same quantile average through scipy.stats.beta."""
    from scipy.stats import beta

    from mirl.learning.verdicts import TEAM_QUANTILES, below_probability

    (s, f), (so, fo) = own, other
    u = (np.arange(TEAM_QUANTILES) + 0.5) / TEAM_QUANTILES
    ref = float(np.mean(beta.cdf(ratio * beta.ppf(u, 1 + so, 1 + fo), 1 + s, 1 + f)))
    assert below_probability((s, s + f), (so, so + fo), ratio) == ref


@given(n=st.integers(1, 2000), share=st.floats(0.0, 1.0), ratio=st.floats(0.05, 1.0))
@settings(max_examples=60, deadline=None)
def test_robots_seen_alike_are_never_more_likely_below_than_not(n, share, ratio):
    """Two robots with the same forward counts have one posterior: θ < θ′ has probability 1/2,
    θ < ratio · θ′ less, so a team comparison never turns their "no part" verdict."""
    from mirl.learning.verdicts import below_probability

    s = round(share * n)
    assert below_probability((s, n), (s, n), ratio) < 0.5 + 1e-3


def test_team_ratio_is_the_smallest_forward_parts_margin():
    from mirl.learning.verdicts import team_ratio

    definition = load_scenario("boyd2").faults  # wheels 0.95, navigation 0.97, floor 0.99
    assert team_ratio(definition, FORWARD) == pytest.approx(1 - 0.15 / 0.95)
    assert team_ratio(definition, ("floor",)) == pytest.approx(1 - 0.15 / 0.99)


def _said(conf, part=None, candidates=(), fit_ok=True, forward=(0, 0)):
    from mirl.learning.model_check import Check, ModelFit
    from mirl.learning.verdicts import FeatureUncertainty

    fit = ModelFit((Check("record", fit_ok, None, "" if fit_ok else "it crawls"),))
    verdict = Verdict(part, conf, tuple(candidates), dict.fromkeys(FEATURES, 0.0), fit)
    intervals = dict.fromkeys(FEATURES, (0.9, 1.0))
    return FeatureUncertainty(intervals, verdict, forward_steps=forward)


def test_a_robot_well_below_its_teammate_is_not_called_healthy():
    """I's forward steps succeed 0.78 of the time, J's 0.99: "no part of I" at 0.99 (four
    healthy parts a little low, by the scenario's levels) becomes one of forward's parts."""
    from mirl.learning.verdicts import compared_with_team

    definition = load_scenario("boyd2").faults
    before = [_said(0.99, forward=(221, 283)), _said(1.0, forward=(279, 282))]
    after = compared_with_team(before, ("I", "J"), definition, FORWARD)
    v = after[0].verdict
    assert v.candidates == FORWARD and v.confidence > 0.95 and v.is_right(("right_wheel",))
    assert v.beside is not None and v.beside.robot == "J" and v.beside.own == (221, 283)
    assert "221 of 283" in v.sentence("I") and v.to_dict()["beside"]["robot_forward"] == [279, 282]
    assert after[1] is before[1]  # J is above I: nothing to say


def test_a_team_comparison_only_lowers_a_healthy_verdict():
    from mirl.learning.verdicts import compared_with_team

    definition = load_scenario("boyd2").faults
    cases = [
        # a part named: left as it is, however far below
        ([_said(0.9, part="left_wheel", forward=(50, 100)), _said(1.0, forward=(99, 100))], 0),
        # a record that does not fit: its verdict already claims nothing high
        ([_said(0.7, fit_ok=False, forward=(50, 100)), _said(1.0, forward=(99, 100))], 0),
        # alike: decisively not below (b < 0.01)
        ([_said(0.99, forward=(95, 100)), _said(0.99, forward=(96, 100))], 0),
        # no other robot with forward steps
        ([_said(0.99, forward=(50, 100)), _said(1.0)], 0),
    ]
    for before, i in cases:
        after = compared_with_team(before, ("I", "J"), definition, FORWARD)
        assert after[i] is before[i]
    # a little below, on few steps: "no part" stays, at no more than 1 - b (b = 0.21)
    before = [_said(0.99, forward=(18, 20)), _said(1.0, forward=(20, 20))]
    after = compared_with_team(before, ("I", "J"), definition, FORWARD)
    v = after[0].verdict
    assert not v.names_damage and v.beside is not None
    assert v.confidence == pytest.approx(1 - v.beside.below) and v.confidence < 0.99


def test_a_damaged_wheel_below_a_teammate_better_than_the_healthy_levels_is_found():
    """Grid robots whose healthy parts work every time (better than the scenario's healthy
    levels, as the physical world's robots do) and I's left wheel at 0.78, damaged (below
    0.95 - 0.15): its forward steps succeed about as often as the levels' product (0.87), so
    the features alone call it four healthy parts a little low; beside J it is found."""
    scenario = load_scenario("boyd2-healthy")
    for robot in ("I", "J"):
        for f in FEATURES:
            scenario = scenario.with_damage(robot, f, 1.0)
    scenario = scenario.with_damage("I", "left_wheel", 0.78)
    confident_healthy = 0
    for seed in range(3):
        obs = _full_view_record(scenario, seed, 450)
        result = learn(obs, scenario, "mirl-t", observability=1.0)
        v = result.robot("I").verdict
        assert v is not None
        confident_healthy += (not v.names_damage) and v.confidence >= 0.9
        j = result.robot("J").verdict
        assert j is not None and not j.names_damage and j.beside is None
    assert confident_healthy == 0


# A part no kept step tests

WET_PATCH = """
[transition_features]
features = ["left_wheel", "right_wheel", "navigation", "floor"]
actions = { forward = ["left_wheel", "right_wheel", "navigation"], turn_left = ["right_wheel", "navigation"], turn_right = ["left_wheel", "navigation"], stop = [] }
override = [ { cells = [[0, 2], [0, 3], [0, 4], [0, 5], [0, 6], [0, 7], [0, 8]], actions = ["forward", "turn_left", "turn_right", "stop"], add = ["floor"] } ]

"""  # noqa: E501  (the floor matters only on the upper hallway: a wet patch)


def _wet_patch_scenario(tmp_path):
    from importlib.resources import files

    text = (files("mirl.data.scenarios") / "boyd2-healthy.toml").read_text()
    at = text.index("[[robots]]")
    path = tmp_path / "wet.toml"
    path.write_text(text[:at] + WET_PATCH + text[at:])
    return load_scenario(str(path))


def test_untested_features_are_those_in_no_subset_of_any_action_there(tmp_path):
    from mirl.learning.motion_models import candidate_models
    from mirl.learning.verdicts import untested_features

    scenario = _wet_patch_scenario(tmp_path)
    d = scenario.domain
    models = candidate_models(d.feature_map)
    on_patch = int(d.state_index(0, 5, 2))
    off_patch = [int(d.state_index(16, c, h)) for c in range(2, 9) for h in range(4)]
    assert untested_features(d, models, off_patch) == ("floor",)
    assert untested_features(d, models, [*off_patch, on_patch]) == ()
    assert untested_features(d, models, []) == FEATURES
    # the drift tests the wheels whatever the steps' subsets
    assert untested_features(d, models, [], drift=True) == ("navigation", "floor")
    # the paper's scenario: every action needs the floor, so one step tests it
    plain = load_scenario("boyd2-healthy").domain
    assert untested_features(plain, models, off_patch[:1]) == ()


def test_a_part_no_step_tests_is_left_to_the_prior(tmp_path):
    """J's floor is damaged, but the floor matters only on the upper hallway, which J's patrol
    never crosses: the record says nothing about it, so "no part of J is damaged" can be no
    surer than the prior that J's floor is healthy (0.83), whatever the learner's seed."""
    scenario = _wet_patch_scenario(tmp_path).with_damage("J", "floor", 0.6)
    obs = _full_view_record(scenario, 5000, 450)
    j = obs.robot == scenario.robot_names.index("J")
    assert not ((obs.row[j] == 0) & (obs.col[j] >= 2)).any()  # J never on the patch
    h = scenario.faults.healthy_level("floor")
    t = scenario.faults.threshold("floor")
    prior_healthy = 0.2 * (1 - t) + 0.8 * beta_dist.sf(t, 50 * h, 50 * (1 - h))
    for seed in range(3):
        result = learn(obs, scenario, "mirl-t", observability=1.0, random_state=seed)
        u = result.robot("J").uncertainty
        assert u is not None and u.untested == ("floor",)
        assert not u.verdict.names_damage
        assert u.verdict.confidence <= prior_healthy + 0.03
        assert result.robot("I").uncertainty.untested == ()
