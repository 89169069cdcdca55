"""The belief filter (:mod:`mirl.planning.belief`): its three forms chosen once from the table of
modes, each checked against an independent computation (the dense joint matrix, enumeration),
negative evidence, fallbacks, and the factored filter's streamed prediction."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mirl._registry import UnknownNameError
from mirl.learning.results import LearnResult, RobotModel, oracle_models
from mirl.mdp import policy_matrix
from mirl.planning.belief import (
    BELIEF_MODES,
    NOT_WATCHING,
    UNSEEN,
    BeliefFilter,
    BeliefForm,
    FactoredBelief,
    PairBelief,
    Prediction,
    TeamBelief,
    _joint_step_matrix,
)
from mirl.planning.go import solve_observer_mdp
from mirl.planning.observer import observer_model
from mirl.planning.team_filter import game_step_matrix
from mirl.world.domain import FORWARD
from mirl.world.game import Equilibrium, game_action_to_action, meeting
from mirl.world.motion import transition_matrix
from mirl.world.scenario import HEALTHY_PROBABILITIES, Scenario, load_scenario
from tests.planning.test_planner import CORRIDOR, _scenario


# ---- the forms -----------------------------------------------------------------------------------
def test_the_modes_are_one_class_each_behind_one_interface():
    assert BELIEF_MODES.names == ("pair", "team", "factored")
    assert [BELIEF_MODES[n] for n in BELIEF_MODES] == [PairBelief, TeamBelief, FactoredBelief]
    for name, form in BELIEF_MODES.items():
        assert issubclass(form, BeliefForm) and form.name == name and form.description
    assert [f.joint for f in BELIEF_MODES.values()] == [True, True, False]


@pytest.mark.parametrize(
    ("starts", "kwargs", "mode"),
    [
        ([(0, 1, 0), (0, 5, 2)], {}, "pair"),  # S² within max_joint_states: exact
        ([(0, 1, 0), (0, 5, 2)], {"joint": False}, "factored"),
        ([(0, 1, 0), (0, 5, 2)], {"max_joint_states": 10}, "factored"),
        ([(0, 1, 0), (0, 5, 2)], {"mode": "team"}, "team"),  # the tensor code on two robots
        ([(0, 1, 0), (0, 5, 2), (0, 3, 0)], {}, "team"),
        ([(0, 1, 0), (0, 5, 2), (0, 3, 0)], {"joint": True, "max_joint_states": 1}, "team"),
        ([(0, 1, 0)], {"joint": True}, "factored"),  # one robot's marginal is its joint
    ],
)
def test_the_form_is_chosen_once_from_the_arguments(starts, kwargs, mode):
    sc = _scenario(CORRIDOR, starts)
    f = BeliefFilter(sc.domain, oracle_models(sc), **kwargs)
    assert f.mode == mode and isinstance(f.form, BELIEF_MODES[mode])
    assert f.joint == f.form.joint


@pytest.mark.parametrize(
    ("starts", "kwargs", "message"),
    [
        ([(0, 1, 0), (0, 5, 2)], {"mode": "pairs"}, "did you mean 'pair'"),
        ([(0, 1, 0), (0, 5, 2)], {"mode": "factored", "joint": True}, "is not joint"),
        ([(0, 1, 0), (0, 5, 2)], {"mode": "pair", "joint": False}, "is joint"),
        ([(0, 1, 0), (0, 5, 2), (0, 3, 0)], {"mode": "pair"}, "does not track 3 robots"),
        ([(0, 1, 0)], {"mode": "team"}, "does not track 1 robots"),
    ],
)
def test_a_mode_that_cannot_track_these_robots_is_refused(starts, kwargs, message):
    sc = _scenario(CORRIDOR, starts)
    with pytest.raises(ValueError, match=message):
        BeliefFilter(sc.domain, oracle_models(sc), **kwargs)


def test_an_unknown_mode_is_the_table_s_error():
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    with pytest.raises(UnknownNameError, match=r"^unknown belief mode 'joint' \(known: "):
        BeliefFilter(sc.domain, oracle_models(sc), mode="joint")


def test_arguments_it_cannot_work_with_are_refused_by_name():
    """A view or models of another map failed at the first product, a heading noise of 2 made
    likelihoods negative, and ``update`` took -7 as "not seen", 3.7 as state 3 and 9999 as
    an IndexError; each is refused naming the argument, and a refused update moves nothing."""
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    other = _scenario("L.G....\n", [(0, 1, 0), (0, 5, 2)])  # one cell longer
    learned, S = oracle_models(sc), sc.domain.n_states
    for kwargs, error, needle in [
        ({"visible": np.ones(S + 1, bool)}, ValueError, rf"visible must have shape \({S},\)"),
        ({"heading_noise": 2.0}, ValueError, r"`heading_noise` must be a number in \[0, 1\]"),
        ({"learned": oracle_models(other)}, ValueError, "model of P0 is not of this domain's 20"),
        ({"learned": None}, TypeError, "learned must be a mirl.LearnResult"),
    ]:
        with pytest.raises(error, match=needle):
            BeliefFilter(sc.domain, **({"learned": learned} | kwargs))
    f = BeliefFilter(sc.domain, learned)
    with pytest.raises(ValueError, match="marginals.. before any update"):
        f.marginals()
    for observed, needle in [
        ([-7, UNSEEN], r"observed\[0\] = -7 is not a state index"),
        ([0, S], rf"observed\[1\] = {S} is not a state index in \[0, {S}\)"),
        ([3.7, UNSEEN], "observed must be 2 integers, one per robot, got shape .2,. and dtype f"),
        ([UNSEEN], r"observed must be 2 integers, one per robot, got shape \(1,\)"),
    ]:
        with pytest.raises(ValueError, match=needle):
            f.update(observed)
        assert f.t == -1 and f.belief is None
    f.update(np.array([NOT_WATCHING, UNSEEN], dtype=np.int32))
    with pytest.raises(ValueError, match="`steps` must be an integer >= 0"):
        f.predict(-1, observer_model(sc))


def test_the_three_forms_agree_on_two_robots():
    """The pair, the tensor and (with no meeting possible) the factored marginals are one
    belief in three shapes: updates and predictions agree."""
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom = sc.domain
    lr = _moving_models(sc, 2, Equilibrium((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)))
    visible = np.zeros(dom.n_states, bool)
    visible[:8] = True
    pair, team = (BeliefFilter(dom, lr, visible=visible, mode=m) for m in ("pair", "team"))
    model = observer_model(sc)
    for row in ([dom.state_index(0, 1, 0), UNSEEN], [UNSEEN, UNSEEN], [NOT_WATCHING, UNSEEN]):
        pair.update(row)
        team.update(row)
        np.testing.assert_allclose(team.belief.ravel(), pair.belief, atol=1e-14)
    a, b = pair.predict(5, model), team.predict(5, model)
    for field in ("occupancy", "detection", "hazard"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), atol=1e-12)
    g = model.not_seeing(int(model.start_state + 4))
    pa, za = pair.condition_unseen(pair.belief, g)
    pb, zb = team.condition_unseen(team.belief, g)
    np.testing.assert_allclose(pb.ravel(), pa, atol=1e-14)
    assert za == pytest.approx(zb, abs=1e-14)


@pytest.mark.parametrize("mode", ["pair", "team", "factored"])
def test_conditioning_on_not_being_seen_is_bayes_rule(mode):
    """Against the joint spelled out: P(no patroller sees L) = Σ b(s, s′) g(s) g(s′) and the
    posterior b ∘ g ⊗ g over it (the factored form: each marginal alone, the product)."""
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom, S = sc.domain, sc.domain.n_states
    f = BeliefFilter(dom, oracle_models(sc), mode=mode)
    rng = np.random.default_rng(0)
    g = (rng.random(S) < 0.6).astype(float)
    if mode == "factored":
        b = rng.random((2, S))
        b /= b.sum(axis=1, keepdims=True)
        post, z = f.condition_unseen(b, g)
        assert z == pytest.approx((b[0] @ g) * (b[1] @ g))
        np.testing.assert_allclose(post, b * g / (b @ g)[:, None])
        return
    B = rng.random((S, S))
    B /= B.sum()
    kept = B * np.outer(g, g)
    post, z = f.condition_unseen(B.ravel() if mode == "pair" else B, g)
    assert z == pytest.approx(kept.sum())
    np.testing.assert_allclose(post.reshape(S, S), kept / kept.sum())


@pytest.mark.parametrize("mode", ["pair", "team", "factored"])
def test_an_impossible_observation_is_one_fallback_in_each_form(mode):
    """A robot seen where the learned model cannot have put it: a joint form counts one
    fallback for the step and trusts the observation; the factored form one per robot."""
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom = sc.domain
    lr = _moving_models(sc, 3, Equilibrium((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)))
    T = [r.transitions.toarray().reshape(dom.n_states, dom.n_actions, -1) for r in lr.robots]
    f = BeliefFilter(dom, lr, mode=mode)
    s0 = dom.state_index(0, 1, 0)
    unreachable = [s for s in range(dom.n_states) if T[0][s0, lr.robots[0].policy[s0], s] == 0]
    f.update([s0, dom.state_index(0, 5, 2)])
    f.update([unreachable[-1], dom.state_index(0, 5, 2)])
    assert f.fallbacks == 1
    m = f.marginals()
    assert m[0, unreachable[-1]] == pytest.approx(1.0)
    assert m.sum(axis=1) == pytest.approx(1.0)


# ---- against independent computations --------------------------------------------------------
def _moving_models(scenario: Scenario, seed: int, eq: Equilibrium) -> LearnResult:
    rng = np.random.default_rng(seed)
    dom = scenario.domain
    robots = []
    for i in range(len(scenario.robots)):
        probs = {f: float(rng.uniform(0.6, 0.95)) for f in HEALTHY_PROBABILITIES}
        T = transition_matrix(dom, probs)
        pol = rng.integers(0, dom.n_actions, dom.n_states)
        pol[rng.random(dom.n_states) < 0.5] = FORWARD  # plenty of meetings
        robots.append(RobotModel(f"R{i}", np.zeros(4), probs, T, pol))
    return LearnResult("hand", tuple(robots), eq)


def test_joint_step_matrix_matches_brute_force():
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom = sc.domain
    eq = Equilibrium((0.5, 0.3, 0.2), (0.1, 0.6, 0.3))
    lr = _moving_models(sc, 0, eq)
    S = dom.n_states
    M = _joint_step_matrix(dom, lr, [policy_matrix(r.transitions, r.policy) for r in lr.robots])
    T = [r.transitions.toarray().reshape(S, dom.n_actions, S) for r in lr.robots]
    pol = [r.policy for r in lr.robots]
    dense = np.zeros((S * S, S * S))
    for si, sj in itertools.product(range(S), range(S)):
        ai, aj = pol[0][si], pol[1][sj]
        if meeting(dom, si, sj, ai, aj):
            nxt = np.zeros((S, S))
            for gi, gj in itertools.product(range(3), range(3)):
                bi = int(game_action_to_action(gi, ai))
                bj = int(game_action_to_action(gj, aj))
                nxt += eq.row[gi] * eq.col[gj] * np.outer(T[0][si, bi], T[1][sj, bj])
        else:
            nxt = np.outer(T[0][si, ai], T[1][sj, aj])
        dense[si * S + sj] = nxt.ravel()
    np.testing.assert_allclose(M.toarray(), dense, atol=1e-12)
    assert dense.sum(axis=1) == pytest.approx(1.0)


@pytest.mark.parametrize("joint", [True, False])
def test_prediction_matches_dense_propagation(joint):
    sc = _scenario(CORRIDOR, [(0, 1, 0), (0, 5, 2)])
    dom = sc.domain
    lr = _moving_models(sc, 1, Equilibrium((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)))
    model = observer_model(sc)
    visible = np.zeros(dom.n_states, bool)
    visible[:8] = True  # cells (0,1), (0,2)
    f = BeliefFilter(dom, lr, visible=visible, joint=joint)
    f.update([dom.state_index(0, 1, 0), UNSEEN])
    f.update([UNSEEN, UNSEEN])
    pred = f.predict(6, model)
    S = dom.n_states
    assert pred.occupancy.sum(axis=2) == pytest.approx(1.0)
    D = model.detection.toarray()
    if joint:
        M = _joint_step_matrix(dom, lr, [policy_matrix(r.transitions, r.policy) for r in lr.robots])
        b = f.belief.copy()
        for k in range(7):
            p = b.reshape(S, S)
            np.testing.assert_allclose(pred.occupancy[k, 0], p.sum(1), atol=1e-12)
            np.testing.assert_allclose(pred.occupancy[k, 1], p.sum(0), atol=1e-12)
            # detection: P(some robot sees c) from the joint, by enumeration
            either = 1 - (1 - D)[:, None, :] * (1 - D)[None, :, :]  # (sI, sJ, c)
            np.testing.assert_allclose(
                pred.detection[k], np.einsum("ij,ijc->c", p, either), atol=1e-12
            )
            b = M.T @ b
    else:
        # factored: each marginal moves by its policy, or by its side of the game with the
        # probability q(s) = Σ_s' meet(s, s') b_other(s') that it meets the other robot
        Ps = [policy_matrix(r.transitions, r.policy).toarray() for r in lr.robots]
        eq, pol = lr.equilibrium, [r.policy for r in lr.robots]
        Gs = [
            game_step_matrix(dom, r.transitions, r.policy, side).toarray()
            for r, side in zip(lr.robots, (eq.row, eq.col), strict=True)
        ]
        si, sj = np.divmod(np.arange(S * S), S)
        meet = meeting(dom, si, sj, pol[0][si], pol[1][sj]).reshape(S, S).astype(float)
        b = f.belief.copy()
        for k in range(7):
            np.testing.assert_allclose(pred.occupancy[k], b, atol=1e-12)
            q = [meet @ b[1], meet.T @ b[0]]
            b = np.stack([(b[i] * (1 - q[i])) @ Ps[i] + (b[i] * q[i]) @ Gs[i] for i in range(2)])
    # first-order hazard, per robot by enumeration of (s at k-1, s' at k)
    Ps = [policy_matrix(r.transitions, r.policy).toarray() for r in lr.robots]
    for k in range(1, 7):
        for j, (cp, c) in enumerate(pred.pairs):
            surv = 1.0
            for i in range(2):
                b0 = pred.occupancy[k - 1, i]
                joint_ok = b0 @ (((1 - D[:, cp])[:, None] * Ps[i]) @ (1 - D[:, c]))
                surv *= joint_ok / (b0 @ (1 - D[:, cp]))
            assert pred.hazard[k, j] == pytest.approx(1 - surv, abs=1e-12)


def test_filter_uses_negative_evidence_and_survives_impossible_observations():
    sc = load_scenario("boyd2")
    dom = sc.domain
    visible = dom.visible_states(0.14)
    f = BeliefFilter(dom, oracle_models(sc), visible=visible)
    for _ in range(5):
        f.update([UNSEEN, UNSEEN])
    m = f.marginals()
    assert m[:, visible].sum() == pytest.approx(0.0)
    assert m.sum(axis=1) == pytest.approx(1.0)
    f.update([NOT_WATCHING, NOT_WATCHING])  # no evidence at all: mass flows back into view
    assert f.marginals()[:, visible].sum() > 0
    s_far = dom.state_index(16, 8, 0)
    f.update([dom.state_index(0, 1, 0), UNSEEN])
    f.update([s_far, UNSEEN])  # a jump the model cannot explain
    assert f.fallbacks >= 1
    m = f.marginals()
    assert m[0, s_far] == pytest.approx(1.0)
    assert m.sum(axis=1) == pytest.approx(1.0)



def test_streamed_prediction_and_timed_policy_are_the_full_arrays_bit_for_bit():
    # the factored filter's checkpointed prediction and the policy kept as its changes give
    # exactly the arrays of computing every step at once
    from mirl.planning.team_filter import factored_detection

    sc = load_scenario("office")
    lr = oracle_models(sc)
    model = observer_model(sc)
    f = BeliefFilter(sc.domain, lr, visible=sc.domain.visible_states(0.14), joint=False)
    for _ in range(5):
        f.update(np.full(len(lr.robots), UNSEEN))
    pred = f.predict(40, model)
    occ = np.empty((41, *f.belief.shape))
    occ[0] = f.belief
    for k in range(40):
        occ[k + 1] = f.propagate(occ[k])
    det, haz = factored_detection(occ, model.detection, f.form.step_T, model.cell_pairs)
    assert np.array_equal(pred.occupancy, occ)
    assert np.array_equal(pred.detection, np.clip(det, 0, 1))
    assert np.array_equal(pred.hazard, np.clip(haz, 0, 1))
    assert np.array_equal(pred.hazard_rows(7, 19), np.clip(haz, 0, 1)[7:19])
    full = Prediction(pred.t0, occ, np.clip(det, 0, 1), np.clip(haz, 0, 1), model.cell_pairs)
    a = solve_observer_mdp(model, pred, keep_values=True)
    b = solve_observer_mdp(model, full, keep_values=True)
    assert np.array_equal(a.values, b.values) and np.array_equal(a.go_values, b.go_values)
    assert a.policy.n_changes < 40 * model.n_states / 4  # kept as changes, not the table


