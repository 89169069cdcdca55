"""The model check before a verdict (mirl.learning.model_check): each check on small hand-made
records, the stall tail against simulation, and what a failed check does to the verdict."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mirl.learning.model_check import (
    ALPHA,
    CRAWL_SHARE,
    PACE_SETTER,
    check_jams,
    check_moves,
    check_pace,
    check_pinned,
    check_record_length,
    check_slides,
    check_stalls,
    check_unexplained,
    held_back,
    longest_run_tail,
    no_pace_setter,
    sets_the_pace,
    stay_runs,
)
from mirl.learning.motion_models import DEFAULT_PRIOR
from mirl.learning.verdicts import (
    CONFIDENT,
    MODEL_TRUST,
    RobotRecord,
    robot_uncertainty,
    tempered_trust,
)
from mirl.world.domain import ACTIONS
from mirl.world.scenario import load_scenario

FORWARD, TURN_LEFT, STOP = (ACTIONS.index(a) for a in ("forward", "turn_left", "stop"))


# ---- unexplained steps --------------------------------------------------------------------------
def test_a_few_misread_steps_are_tolerated():
    unexplained = np.zeros(400, dtype=bool)
    unexplained[[10, 200, 300]] = True
    assert check_unexplained(unexplained, np.zeros(400, dtype=bool)).ok


def test_moves_across_two_cells_fail_and_say_what_fixes_them():
    """13 of 81 moves span two cells (a tracker read at too long a step)."""
    unexplained = np.zeros(81, dtype=bool)
    unexplained[:13] = True
    check = check_unexplained(unexplained, unexplained)
    assert not check.ok and check.p_value < ALPHA
    assert "13 of 81" in check.reason and "13 moved more than one cell" in check.reason
    assert "`step_seconds`" in check.fix
    assert check.misfit.tolist() == list(range(13))


def test_other_unexplained_steps_fail_without_a_step_to_blame():
    unexplained = np.zeros(100, dtype=bool)
    unexplained[::5] = True
    check = check_unexplained(unexplained, np.zeros(100, dtype=bool))
    assert not check.ok and check.fix == ""


# ---- slides -------------------------------------------------------------------------------------
def test_a_rare_backward_move_kept_is_tolerated_as_two_misreads():
    slid = np.zeros(450, dtype=bool)
    slid[[40, 300]] = True  # two in 450 steps: P = 0.06 at two misreads in a row
    check = check_slides(slid)
    assert check.ok and check.p_value > ALPHA


def test_backward_moves_a_robot_stays_at_fail_and_are_misfit():
    """8 of 299 steps slide a cell back and stay: a robot wedged on a wall while it drives."""
    slid = np.zeros(299, dtype=bool)
    slid[np.arange(30, 299, 33)[:8]] = True
    check = check_slides(slid)
    assert not check.ok and check.p_value < ALPHA
    assert "8 of 299" in check.reason and "pushed or slid" in check.reason
    assert check.fix == ""  # nothing in the user's hands
    assert check.misfit.tolist() == np.flatnonzero(slid).tolist()


def test_a_slide_is_a_backward_move_the_next_observed_step_stays_at():
    from mirl.learning.verdicts import _slid

    d = load_scenario("boyd2-healthy").domain
    at = [d.state_index(0, c, 0) for c in (5, 4, 3)]  # facing east, one cell further west each
    none = np.zeros(0, dtype=int)
    assert _slid(d, none, none, none).tolist() == []
    # a backward move with no step after it, one read back, one stayed at, one then unobserved
    assert _slid(d, np.array([3]), np.array([at[0]]), np.array([at[1]])).tolist() == [False]
    back_and_forth = _slid(d, np.array([3, 4]), np.array([at[0], at[1]]), np.array([at[1], at[0]]))
    assert back_and_forth.tolist() == [False, False]
    kept = _slid(d, np.array([3, 4]), np.array([at[0], at[1]]), np.array([at[1], at[1]]))
    assert kept.tolist() == [True, False]
    gap = _slid(d, np.array([3, 9]), np.array([at[0], at[1]]), np.array([at[1], at[1]]))
    assert gap.tolist() == [False, False]


def _wedged_record(slide: bool):
    """boyd2-healthy's I, healthy, as L sees it at full view: it stays in its
    cell facing east as if driving on, and (``slide``) every 40 steps it is one cell further
    west, where it stays — a physical robot wedged on a wall for its whole record — labelled as
    its policy would (forward)."""
    scenario = load_scenario("boyd2-healthy")
    d = scenario.domain
    r, c = 0, 8
    assert d.state_index(r, c - 7, 0) >= 0  # the hallway behind it is free
    x = np.full(300, -1)
    for k in range(300):
        x[k] = d.state_index(r, c - (k // 40 if slide else 0), 0)
    labels = np.full(300, FORWARD)
    return scenario, x, labels


def test_a_healthy_robot_wedged_for_its_whole_record_is_not_confidently_damaged(monkeypatch):
    scenario, x, labels = _wedged_record(slide=True)
    probs = scenario.robots[0].feature_probabilities
    record = RobotRecord(x, labels)
    u = robot_uncertainty(scenario.domain, record, probs, scenario.faults)
    failed = [ch.name for ch in u.verdict.fit.checks if not ch.ok]
    assert "slides" in failed and "pushed or slid" in u.verdict.fit.reason
    assert u.verdict.confidence < 0.9
    # the backward moves are explained by no action, so they never count as failures
    assert u.verdict.fit.left_out["explained by no action"] == 7
    import mirl.learning.verdicts as verdicts

    # without the check the stays alone call a part damaged with confidence (the stall check
    # finds them explained by the failure rate fitted to them)
    monkeypatch.setattr(verdicts, "check_slides", lambda slid: check_slides(slid[:0]))
    blind = robot_uncertainty(scenario.domain, record, probs, scenario.faults)
    assert blind.verdict.names_damage and blind.verdict.confidence >= 0.9
    assert "stalls" not in [ch.name for ch in blind.verdict.fit.checks if not ch.ok]


def test_a_robot_that_only_stays_has_no_slides():
    scenario, x, labels = _wedged_record(slide=False)
    probs = scenario.robots[0].feature_probabilities
    u = robot_uncertainty(scenario.domain, RobotRecord(x, labels), probs, scenario.faults)
    slides = [ch for ch in u.verdict.fit.checks if ch.name == "slides"]
    assert slides and slides[0].ok and slides[0].misfit.size == 0


# ---- stalls -------------------------------------------------------------------------------------
def test_stay_runs_follow_consecutive_times():
    t = np.array([0, 1, 2, 3, 5, 6, 7])
    stayed = np.array([1, 1, 0, 1, 1, 1, 0], dtype=bool)
    runs = stay_runs(t, stayed)
    assert [r.tolist() for r in runs] == [[0, 1], [3], [4, 5]]


@pytest.mark.parametrize(("q", "rho", "length"), [(0.3, 0.0, 6), (0.3, 0.4, 8), (0.05, 0.0, 4)])
def test_the_longest_run_tail_matches_simulation(q, rho, length):
    """The Poisson clumping approximation of P(a run of at least ``length`` stays) against a
    two-state Markov chain simulated 20 000 times, with a gap in the record."""
    rng = np.random.default_rng(0)
    n = 300
    t = np.arange(n)
    t[150:] += 5
    hits, reps = 0, 20000
    stays = np.zeros((reps, n), dtype=bool)
    for i in range(n):
        p = np.full(reps, q)
        if i and t[i] == t[i - 1] + 1:
            p = np.where(stays[:, i - 1], q + rho * (1 - q), q * (1 - rho))
        stays[:, i] = rng.random(reps) < p
    for row in stays:
        hits += max((len(r) for r in stay_runs(t, row)), default=0) >= length
    approx = longest_run_tail(np.full((1, n), q), t, length, rho)[0]
    assert approx == pytest.approx(hits / reps, abs=0.01 + 0.05 * hits / reps)


def test_a_stall_no_failure_rate_explains_fails_and_its_steps_are_misfit():
    """A robot that stays put on 5 % of its steps, then stands still for 12 in a row."""
    rng = np.random.default_rng(1)
    n = 400
    t = np.arange(n)
    stayed = rng.random(n) < 0.05
    stayed[200:212] = True
    q = np.full((50, n), 0.05)
    check, limit = check_stalls(t, stayed, q)
    assert not check.ok and "12 steps in a row" in check.reason
    assert set(range(200, 212)) <= set(check.misfit.tolist())
    assert 2 <= limit <= 12
    ok, _ = check_stalls(t, rng.random(n) < 0.05, q)
    assert ok.ok


def test_a_weak_robot_may_stall_a_while():
    """Half its forward steps fail: a run of 8 stays in 400 steps is nothing unusual."""
    t = np.arange(400)
    stayed = np.zeros(400, dtype=bool)
    stayed[::2] = True
    stayed[100:108] = True
    assert check_stalls(t, stayed, np.full((50, 400), 0.5))[0].ok


# ---- jams ---------------------------------------------------------------------------------------
def test_stays_beside_another_robot_are_a_jam():
    n = 300
    stayed = np.zeros(n, dtype=bool)
    near = np.zeros(n, dtype=bool)
    near[100:140] = True
    stayed[100:130] = True  # 30 of 40 steps beside another robot
    stayed[::50] = True
    check = check_jams(stayed, near, np.full((50, n), 0.05))
    assert not check.ok and "beside another robot" in check.reason
    assert set(check.misfit.tolist()) == set(np.flatnonzero(stayed & near).tolist())


def test_stays_as_frequent_beside_another_robot_are_no_jam():
    rng = np.random.default_rng(2)
    stayed = rng.random(300) < 0.1
    near = rng.random(300) < 0.3
    assert check_jams(stayed, near, np.full((50, 300), 0.1)).ok


# ---- in the way ---------------------------------------------------------------------------------
def test_steps_in_another_robot_s_way_are_left_out_whatever_the_test_says():
    """The held steps are the check's misfit steps (left out of the evidence) whether or not
    the robot stayed put on them more often than elsewhere: they are chosen by where the
    other robot was, not by what the step did."""
    rng = np.random.default_rng(3)
    n = 300
    labels = rng.integers(0, 3, n)
    held = np.zeros(n, dtype=bool)
    held[rng.choice(n, 12, replace=False)] = True
    stayed = rng.random(n) < 0.1  # as often held as not: the test passes
    fair = held_back(stayed, held, labels)
    assert fair.ok and set(fair.misfit.tolist()) == set(np.flatnonzero(held).tolist())
    blocked = stayed | held  # every held step stayed put: significant, but 12 of 300 steps
    check = held_back(blocked, held, labels)
    assert check.ok and check.p_value < ALPHA
    assert set(check.misfit.tolist()) == set(np.flatnonzero(held).tolist())
    assert held_back(stayed, np.zeros(n, dtype=bool), labels).misfit.size == 0


@pytest.mark.parametrize(("n", "n_held"), [(300, 240), (300, 281), (300, 290), (30, 14), (30, 16)])
def test_a_record_mostly_held_back_by_another_robot_does_not_fit(n, n_held):
    """Held steps on which the robot stayed put far more often than elsewhere fail the check
    only when they are more than half its steps and fewer than 20 free steps are left: L's
    policy was then learned mostly from the other robot's pace. Held as often as not, a record
    of any share of held steps fits."""
    rng = np.random.default_rng(4)
    labels = rng.integers(0, 3, n)
    held = np.zeros(n, dtype=bool)
    held[rng.choice(n, n_held, replace=False)] = True
    stayed = rng.random(n) < 0.1
    blocked = (stayed & ~held) | held  # every held step stayed put
    check = held_back(blocked, held, labels)
    significant = check.p_value < ALPHA
    assert check.ok == (not significant or 2 * n_held <= n or n - n_held >= 20)
    if n == 300:
        assert significant
    if not check.ok:
        assert f"in its way on {n_held} of its {n} steps" in check.reason
        assert "most of its record" in check.reason
    assert set(check.misfit.tolist()) == set(np.flatnonzero(held).tolist())
    assert held_back(stayed, held, labels).ok


def test_the_in_the_way_test_is_the_mantel_haenszel_tail():
    """One stratum: the Mantel–Haenszel statistic is the hypergeometric mean and variance of
    the held stays; its continuity-corrected normal tail against a direct computation."""
    from scipy.stats import hypergeom, norm

    n, n_held, k, observed = 200, 20, 30, 9
    held = np.zeros(n, dtype=bool)
    held[:n_held] = True
    stayed = np.zeros(n, dtype=bool)
    stayed[:observed] = True
    stayed[n_held : n_held + k - observed] = True
    h = hypergeom(n, k, n_held)
    expected = norm.sf((observed - h.mean() - 0.5) / h.std())
    assert held_back(stayed, held, np.zeros(n, dtype=int)).p_value == pytest.approx(expected)


# ---- moves --------------------------------------------------------------------------------------
def _kinds(rng, probs, n):
    return rng.choice(len(probs), size=n, p=probs)


def test_moves_the_policy_predicts_fit():
    rng = np.random.default_rng(3)
    probs = np.array([0.8, 0.1, 0.1])
    q = np.broadcast_to(probs, (20, 400, 3))
    assert check_moves(_kinds(rng, probs, 400), q).ok


def test_moves_the_policy_does_not_predict_fail():
    """L's policy says the robot stops on 60 % of its steps; it moves forward on 60 %."""
    rng = np.random.default_rng(4)
    observed = _kinds(rng, np.array([0.6, 0.1, 0.3]), 400)
    q = np.broadcast_to(np.array([0.3, 0.1, 0.6]), (20, 400, 3))
    check = check_moves(observed, q)
    assert not check.ok and "L's policy does not say" in check.reason


def test_a_significant_but_small_mismatch_passes():
    """Off by 2 % of a long record's steps: significant, and too small to move a part across
    the damage margin."""
    observed = np.array([0] * 9300 + [1] * 500 + [2] * 200)
    q = np.broadcast_to(np.array([0.91, 0.05, 0.04]), (20, 10000, 3))
    check = check_moves(observed, q)
    assert check.p_value < ALPHA and check.ok


# ---- few trials ---------------------------------------------------------------------------------
def test_a_feature_pinned_by_few_trials_fails():
    counts = [(("navigation", "floor"), 0, 3), (("floor",), 40, 40)]
    check = check_pinned({"navigation": 0.0, "floor": 1.0}, counts)
    assert not check.ok and "navigation at 0 by 3 trials" in check.reason
    assert check_pinned({"navigation": 0.0, "floor": 1.0}, [(("navigation",), 0, 30)]).ok
    assert check_pinned({"navigation": 0.6}, [(("navigation",), 2, 3)]).ok
    # a healthy part at 1 on a short record claims nothing
    assert check_pinned({"floor": 1.0}, [(("floor",), 3, 3)]).ok


# ---- few steps ----------------------------------------------------------------------------------
def test_a_record_of_fewer_than_twenty_steps_fails_and_says_what_would_fix_it():
    check = check_record_length(19)
    assert not check.ok and "19 steps L saw from start to end, fewer than 20" in check.reason
    assert "longer" in check.fix
    assert check_record_length(20).ok and check_record_length(400).ok
    assert "rests on 1 step L saw" in check_record_length(1).reason


def test_a_short_record_of_a_clean_robot_gets_no_confident_no_part(monkeypatch):
    """A robot seen moving flawlessly on 15 steps: the steps alone would say "no part" at
    high confidence, but a record that short cannot rule out what made it short."""
    scenario = load_scenario("boyd2-healthy")
    from mirl.simulation.grid import simulate

    sim = simulate(scenario, 300, seed=1, observability=1.0, random_starts=True)
    full = sim.observations.state_series(scenario.domain, 0)
    labels = np.where(full >= 0, scenario.true_policy(0)[np.maximum(full, 0)], -1)
    x = np.full_like(full, -1)
    x[100:116] = full[100:116]  # 15 steps observed at both ends
    probs = scenario.robots[0].feature_probabilities
    short = robot_uncertainty(scenario.domain, RobotRecord(x, labels), probs, scenario.faults)
    assert not short.verdict.fit.ok and "15 steps" in short.verdict.fit.reason
    assert short.verdict.confidence < 0.9
    import mirl.learning.verdicts as verdicts

    monkeypatch.setattr(
        verdicts, "check_record_length", lambda n: check_record_length(n, min_steps=0)
    )
    untempered = robot_uncertainty(scenario.domain, RobotRecord(x, labels), probs, scenario.faults)
    assert untempered.verdict.part is None and untempered.verdict.confidence >= 0.9
    monkeypatch.undo()
    x[100:130] = full[100:130]  # 29 steps: the check passes
    longer = robot_uncertainty(scenario.domain, RobotRecord(x, labels), probs, scenario.faults)
    assert [c.name for c in longer.verdict.fit.checks if not c.ok] == []


# ---- what a failed check does to the verdict -----------------------------------------------------
def _long_step_record():
    """A robot read at twice its step: many of its moves span two cells."""
    scenario = load_scenario("boyd2-healthy")
    from mirl.simulation.grid import simulate

    sim = simulate(scenario, 600, seed=0, observability=1.0, random_starts=True)
    x = sim.observations.state_series(scenario.domain, 0)[::2]
    labels = np.where(x >= 0, scenario.true_policy(0)[np.maximum(x, 0)], -1)
    return scenario, x, labels


def test_a_record_that_does_not_fit_gets_no_confident_verdict():
    scenario, x, labels = _long_step_record()
    d = scenario.domain
    probs = scenario.robots[0].feature_probabilities
    u = robot_uncertainty(d, RobotRecord(x, labels), probs, scenario.faults)
    fit = u.verdict.fit
    assert not fit.ok and "moved more than one cell" in fit.reason
    assert "`step_seconds`" in fit.fix
    assert u.verdict.confidence < 0.9
    assert "does not fit L's motion models" in u.verdict.sentence("I")
    # the unexplained steps are left out of the evidence, never counted as failures
    assert fit.left_out["explained by no action"] == sum(
        c.misfit.size for c in fit.checks if c.name == "unexplained"
    )
    record = fit.to_dict()
    assert record["ok"] is False and record["reason"] == fit.reason
    # the tempered confidence is w × the models' probability + (1 - w) × the prior's
    assert 0.0 <= fit.untempered <= 1.0 and record["untempered"] == round(fit.untempered, 4)
    w = tempered_trust(_prior_no_part(d, scenario.faults))
    assert w == MODEL_TRUST  # the default prior's P0 ~ 0.49 does not lower it
    prior_part = (u.verdict.confidence - w * fit.untempered) / (1 - w)
    assert -1e-9 <= prior_part <= 0.52 + 0.02  # at most max(P0, 1 - P0), up to the draws' error


def _prior_no_part(domain, definition, prior=DEFAULT_PRIOR, n=200_000) -> float:
    """P(no part damaged) under a prior, by sampling it."""
    from scipy.special import expit

    from mirl.learning.motion_models import sample_feature_prior

    features = domain.feature_map.features
    h = np.array([min(definition.healthy_level(f), 0.999) for f in features])
    p = expit(sample_feature_prior(np.random.default_rng(3), n, h, prior))
    thresholds = np.array([definition.threshold(f) for f in features])
    return float((p >= thresholds).all(axis=1).mean())


@given(p0=st.floats(0.0, 1.0))
def test_the_models_weight_keeps_a_certain_statement_below_confident(p0):
    w = tempered_trust(p0)
    q = max(p0, 1 - p0)
    assert 0.0 <= w <= MODEL_TRUST
    assert w == 0.0 or w + (1 - w) * q < CONFIDENT
    if 0.0 < w < MODEL_TRUST:  # lowered only as far as it must be
        assert w + (1 - w) * q == pytest.approx(CONFIDENT, abs=1e-6)


def test_a_misfit_record_under_a_confident_prior_stays_below_confident():
    """A prior that finds four healthy parts likely (damaged share 0.05: P0 ~ 0.85) would put a
    "no part" near-certain under the models at 0.5 u + 0.5 × 0.85 > 0.9 at even odds; the
    weight drops instead. The record: a healthy robot seen flawlessly on 15 steps (few steps)."""
    from dataclasses import replace

    scenario = load_scenario("boyd2-healthy")
    from mirl.simulation.grid import simulate

    sim = simulate(scenario, 300, seed=1, observability=1.0, random_starts=True)
    full = sim.observations.state_series(scenario.domain, 0)
    labels = np.where(full >= 0, scenario.true_policy(0)[np.maximum(full, 0)], -1)
    x = np.full_like(full, -1)
    x[100:116] = full[100:116]
    d = scenario.domain
    confident_prior = replace(DEFAULT_PRIOR, damaged_share=0.05)
    p0 = _prior_no_part(d, scenario.faults, confident_prior)
    assert p0 > 0.8
    probs = scenario.robots[0].feature_probabilities
    u = robot_uncertainty(d, RobotRecord(x, labels), probs, scenario.faults, prior=confident_prior)
    v = u.verdict
    assert not v.fit.ok and v.part is None and not v.candidates
    assert MODEL_TRUST * v.fit.untempered + (1 - MODEL_TRUST) * p0 >= CONFIDENT  # even odds
    assert v.confidence < CONFIDENT


def test_a_record_that_fits_passes_every_check():
    scenario = load_scenario("boyd2")
    from mirl.simulation.grid import simulate

    sim = simulate(scenario, 450, seed=0, observability=1.0, random_starts=True)
    d = scenario.domain
    for i in range(2):
        x = sim.observations.state_series(d, i)
        labels = np.where(x >= 0, scenario.true_policy(i)[np.maximum(x, 0)], -1)
        probs = scenario.robots[i].feature_probabilities
        u = robot_uncertainty(d, RobotRecord(x, labels), probs, scenario.faults)
        assert u.verdict.fit.ok, u.verdict.fit.reason


def test_a_robot_never_seen_moving_gets_no_verdict():
    scenario = load_scenario("boyd2")
    d = scenario.domain
    x = np.full(50, -1)
    x[[3, 10, 20]] = d.state_index(0, 3, 0)  # seen, never at two consecutive steps
    u = robot_uncertainty(d, RobotRecord(x, np.full(50, -1)), {}, scenario.faults)
    v = u.verdict
    assert not v.seen_moving and not v.names_damage
    assert v.sentence("J") == "L never saw J move: no verdict on its parts"
    assert v.to_dict()["seen_moving"] is False and v.to_dict()["fit"]["ok"] is False


# ---- pace ---------------------------------------------------------------------------------------
TWO_PACES = (
    "the robots' moves stay within one cell at 4 s, a multiple of the tracker's interval (2 s)"
)


def test_a_record_at_no_pace_fails_and_says_what_fixes_it():
    assert check_pace("").ok and check_pace("").name == "pace"
    check = check_pace(TWO_PACES)
    assert not check.ok and check.reason == TWO_PACES and "`step_seconds`" in check.fix
    assert check.misfit.size == 0  # which stays a healthy robot would have completed, none says


def test_a_crawl_at_the_step_given_asks_for_more_than_the_step_again():
    """A team that crawls at the step the user gave is told no step alone: asked for "the
    decision interval" it would be given the same step and refused the same way."""
    reason = no_pace_setter({"I": (15, 5), "J": (12, 9)}, 2.0, given=True)
    check = check_pace(reason, step_given=True)
    assert not check.ok and check.fix == PACE_SETTER and check.reason == reason
    assert "if the step given is not it" in check.fix and "crossing a cell" in check.fix
    assert check_pace(reason).fix != PACE_SETTER  # read at a step mirl chose: the step fits


@pytest.mark.parametrize(("robot", "wheel"), [("J", "left_wheel"), ("I", "right_wheel")])
def test_a_damaged_robot_s_record_at_no_pace_claims_nothing_with_confidence(robot, wheel):
    """A wheel at 0.5, fully seen: named with confidence from a record at its pace (the pace
    check listed, passed, changing nothing), at most even odds from one that fits two paces."""
    scenario = load_scenario("boyd2-healthy")
    from mirl.simulation.grid import simulate

    damaged = scenario.with_damage(robot, wheel, 0.5)
    i = damaged.robot_index(robot)
    sim = simulate(damaged, 450, seed=3, observability=1.0, random_starts=True)
    d = damaged.domain
    x = sim.observations.state_series(d, i)
    labels = np.where(x >= 0, damaged.true_policy(i)[np.maximum(x, 0)], -1)
    probs = damaged.robots[i].feature_probabilities

    def verdict(off_pace):
        record = RobotRecord(x, labels, off_pace=off_pace)
        return robot_uncertainty(d, record, probs, damaged.faults).verdict

    grid, at_pace = verdict(None), verdict("")
    assert grid.names_damage and grid.confidence >= 0.9
    assert (at_pace.part, at_pace.candidates, at_pace.confidence) == (
        grid.part, grid.candidates, grid.confidence
    )
    assert "pace" not in grid.fit.to_dict()["checks"]
    assert at_pace.fit.to_dict()["checks"]["pace"] == {"ok": True}
    off = verdict(TWO_PACES)
    assert not off.fit.ok and TWO_PACES in off.fit.reason and off.confidence < 0.9
    assert "does not fit L's motion models" in off.sentence(robot)


def test_a_record_at_its_tracker_s_interval_has_a_pace_when_one_robot_moves():
    """Every robot judged (20 free steps or more) staying on more than half of them: no pace
    setter, and the reason names the interval and each robot's stays. One robot seen to move on
    most of its steps beyond chance sets the pace; one that moves on half of them does not; a
    robot seen too little is not judged."""
    crawling = {"I": (15, 5), "J": (12, 9)}
    reason = no_pace_setter(crawling, 1.0)
    assert "tracker's interval (1 s)" in reason and "I 15/20, J 12/21" in reason
    assert no_pace_setter({**crawling, "K": (3, 30)}, 1.0) == ""  # K crosses a cell a step
    assert no_pace_setter({**crawling, "K": (10, 10)}, 1.0).startswith("at the tracker's")
    assert CRAWL_SHARE == 0.5
    assert no_pace_setter({**crawling, "K": (0, 19)}, 1.0) == reason  # K not judged
    assert no_pace_setter({"I": (15, 4)}, 2.0) == ""  # nobody seen long enough
    assert no_pace_setter({"I": (15, 4)}, 2.0, min_steps=10).startswith("at the tracker's")


def test_healthy_robots_read_at_half_their_decision_interval_set_no_pace():
    """Healthy robots read at half their decision interval stay on about half their free steps,
    on either side of one half by chance: a healthy physical pair's poses as Nav2's AMCL publishes
    them, read at 1 s (robots that decide every 2 s), had I stay on 369 of 687 and J on 230 of 466.
    Compared as a share, J's 0.49 set the pace and both robots were called damaged at 1.00;
    as a test it sets none. A robot with a motor at 0.6 read at its own pace (109 of 303) and
    a healthy one (12 of 300) still set it."""
    reason = no_pace_setter({"I": (369, 318), "J": (230, 236)}, 1.0, given=True)
    assert reason.startswith("at the step given (1 s), no robot is seen to cross a cell")
    assert "I 369/687, J 230/466" in reason
    assert no_pace_setter({"I": (109, 194), "J": (100, 211)}, 2.0) == ""
    assert no_pace_setter({"I": (369, 318), "J": (12, 288)}, 1.0, given=True) == ""


@given(st.integers(0, 400), st.integers(1, 400))
def test_a_pace_setter_is_a_one_sided_binomial_test_at_the_checks_level(stayed, steps):
    """sets_the_pace is the exact one-sided binomial test of "stays on at least half" at ALPHA
    (scipy.stats as the reference), and monotone: fewer stays of as many steps never lose it."""
    from scipy.stats import binomtest

    stayed = min(stayed, steps)
    p = binomtest(stayed, steps, CRAWL_SHARE, alternative="less").pvalue
    assert sets_the_pace(stayed, steps) == (p < ALPHA) or abs(p - ALPHA) < 1e-12
    if sets_the_pace(stayed, steps) and stayed > 0:
        assert sets_the_pace(stayed - 1, steps)


def test_a_step_the_user_gives_is_asked_of_the_robots_moves_as_the_tracker_s_interval_is():
    """The same rule at a given step, named as such; the same record at a step where a robot
    moves on most of its free steps has its pace."""
    crawling = {"I": (15, 5), "J": (12, 9)}
    reason = no_pace_setter(crawling, 0.5, given=True)
    assert reason.startswith("at the step given (0.5 s)") and "I 15/20, J 12/21" in reason
    assert no_pace_setter({**crawling, "K": (3, 30)}, 0.5, given=True) == ""


@pytest.mark.parametrize("scenario", ["boyd2-healthy", "boydright"])
def test_healthy_grid_robots_read_at_a_quarter_of_their_step_get_no_confident_part(
    tmp_path, capsys, scenario
):
    """Grid robots decide every 2 s; read at a given 0.5 s they stay in their cells on three
    steps of four, which counted as failures called every healthy robot damaged at confidence
    1.00. The pace check now asks the given step as it asks a tracker's interval: the record
    does not fit, and no healthy robot is called damaged with confidence. At the auto step the
    check passes."""
    from mirl.cli import main

    poses = tmp_path / "poses.csv"
    assert main(["simulate", "--scenario", scenario, "--steps", "300", "--seed", "2",
                 "--observability", "1", "--poses", str(poses)]) == 0  # fmt: skip
    capsys.readouterr()
    learn = ["learn", "--scenario", scenario, "--observations", str(poses), "--json"]
    assert main([*learn, "--step-seconds", "0.5"]) == 0
    robots = json.loads(capsys.readouterr().out)["robots"]
    truth = {r.name: r.feature_probabilities for r in load_scenario(scenario).robots}
    for name, r in robots.items():
        fit = r["verdict"]["fit"]
        assert not fit["checks"]["pace"]["ok"] and "step given (0.5 s)" in fit["reason"]
        assert PACE_SETTER in fit["fix"]  # not the step again: the user gave it
        names_a_part = bool(r["verdict"]["part"] or r["verdict"]["candidates"])
        if min(truth[name].values()) >= 0.9 and names_a_part:  # a healthy robot called damaged
            assert r["verdict"]["confidence"] < 0.9
    assert main(learn) == 0  # the auto step: the robots' own pace
    for r in json.loads(capsys.readouterr().out)["robots"].values():
        assert r["verdict"]["fit"]["checks"]["pace"]["ok"]
