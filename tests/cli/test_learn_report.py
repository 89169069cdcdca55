"""What ``mirl learn`` reports (mirl.cli.learn_report), on hand-made results: the JSON record
holds what was learned, JSON-ready, and the text form says the same things; a verdict's or a
drift's record reads back as the sentence of the object it was written from."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from mirl.cli.learn_report import (
    drift_line,
    feature_lines,
    learn_record,
    motion_line,
    pace_record,
    print_learn,
    verdict_sentence,
)
from mirl.learning.model_check import Check, ModelFit
from mirl.learning.motion_models import motion_sentence
from mirl.learning.results import LearnResult, ObservedAgreement, RobotModel
from mirl.learning.verdicts import FeatureUncertainty, LateralDrift, Verdict
from mirl.observations.discretise import AutoStep
from mirl.world.faults import WHEELS, DamageDefinition
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def _robot(scenario, name: str, weights, probabilities, **kwargs) -> RobotModel:
    n_states, n_actions = scenario.domain.n_states, scenario.domain.n_actions
    return RobotModel(
        name,
        np.asarray(weights, dtype=float),
        probabilities,
        sp.csr_array((n_states * n_actions, n_states)),  # not reported
        np.zeros(n_states, dtype=int),  # not reported
        **kwargs,
    )


def _result(scenario, robots, **kwargs) -> LearnResult:
    return LearnResult("mirl-t", tuple(robots), scenario.game.equilibria()[0], **kwargs)


# ---- verdicts and drifts: the record reads back as the object's sentence -----------------------
FAILED = ModelFit((Check("stalls", False, 0.001, "J stalls in runs"),))
FITS = ModelFit((Check("moves", True, 0.4),))


@pytest.mark.parametrize(
    "verdict",
    [
        Verdict("left_wheel", 0.97),
        Verdict(None, 0.88),
        Verdict(None, 0.91, ("left_wheel", "right_wheel")),
        Verdict(None, 0.8, ("navigation", "floor")),
        Verdict(None, 0.93, weakened="right_wheel", fit=FITS),
        Verdict("navigation", 0.6, fit=FAILED),
        Verdict(None, 0.7, fit=FAILED, seen_moving=False),
        Verdict("left_wheel", 1.0, (), {"left_wheel": 1.0, "navigation": 0.62}, FITS),
        Verdict("left_wheel", 0.99, (), {"left_wheel": 0.99, "right_wheel": 0.98, "floor": 0.7}),
    ],
)
def test_a_verdicts_record_reads_back_as_its_sentence(verdict):
    record = json.loads(json.dumps(verdict.to_dict()))
    assert verdict_sentence("J", record) == verdict.sentence("J")


def test_a_verdict_sentence_says_what_the_record_says():
    assert verdict_sentence("J", Verdict("left_wheel", 0.974).to_dict()) == (
        "J's left wheel is damaged (confidence 0.97)"
    )
    probs = {"left_wheel": 0.99, "right_wheel": 0.98, "floor": 0.7}
    besides = Verdict("left_wheel", 0.99, (), probs)
    assert verdict_sentence("J", besides.to_dict()) == (
        "J's left wheel is damaged (confidence 0.99); its right wheel and floor are probably "
        "damaged too (0.98, 0.70)"
    )
    said = verdict_sentence("J", Verdict(None, 0.6, fit=FAILED).to_dict())
    assert said.startswith("no part of J is damaged (confidence 0.60)")
    assert said.endswith("does not fit L's motion models: J stalls in runs")


@pytest.mark.parametrize(("mean", "side"), [(0.125, "left"), (-0.125, "right")])
def test_a_drift_line_is_its_record_in_words(mean, side):
    drift = LateralDrift(mean, 0.008, 313)
    line = drift_line(drift.to_dict())
    assert line == f"drift         {drift.sentence()} (a robot veers towards a weak wheel)"
    assert f"0.125 cell to the {side} of the centre line (± 0.008) on 313 forward steps" in line


# ---- the pace, the motion line, the features -------------------------------------------------
def test_the_pace_of_grid_data_is_nothing_and_of_poses_how_it_was_chosen():
    assert pace_record(None) == {}
    given = SimpleNamespace(step_seconds=2.0, auto_step=None)
    assert pace_record(given) == {"step_seconds": 2.0, "step_chosen": "given"}
    auto = AutoStep(1.5, 0.004)
    chosen = pace_record(SimpleNamespace(step_seconds=1.5, auto_step=auto))
    assert chosen == {"step_seconds": 1.5, "step_chosen": auto.sentence()}
    assert "the robots' pace" in chosen["step_chosen"] and "0.4%" in chosen["step_chosen"]


def test_a_motion_line_only_with_motion_models():
    assert motion_line({}) is None
    assert motion_line({"motion_models": {}}) is None
    weights = {"paper/uniform": 0.9, "paper/stop": 0.1}
    line = motion_line({"motion_models": weights, "motion_model": "paper/uniform"})
    assert line == "motion        " + motion_sentence(weights, "paper/uniform")
    assert line.endswith("L plans with it")


def test_features_without_intervals_are_one_line_with_the_parts_told_apart_or_not():
    record = {
        "feature_probabilities": {"left_wheel": 0.5414, "right_wheel": 1.0},
        "indistinguishable": [
            {"features": ["navigation", "floor"], "told_apart_by": None},
            {"features": ["left_wheel", "right_wheel"], "told_apart_by": "drift"},
        ],
    }
    (line,) = feature_lines(record, DamageDefinition())
    assert line == (
        "features      left_wheel=0.541  right_wheel=1.000  (navigation and floor: the steps "
        "cannot tell them apart; left_wheel and right_wheel: the steps cannot tell them apart; "
        "the drift tells the side)"
    )


def test_features_name_a_part_no_step_could_test():
    record = {"feature_probabilities": {"left_wheel": 0.9, "floor": 0.99}, "untested": ["floor"]}
    (line,) = feature_lines(record, DamageDefinition())
    assert line.endswith("(floor: no step L kept could test it; the interval is the prior's)")
    record["untested"] = ["navigation", "floor"]
    (line,) = feature_lines(record, DamageDefinition())
    assert "(navigation and floor: no step L kept could test them;" in line


# ---- the JSON record ---------------------------------------------------------------------------
def test_a_record_holds_what_was_learned_json_ready(boyd2):
    names = boyd2.domain.reward_feature_names
    result = _result(
        boyd2,
        [
            _robot(boyd2, "I", np.arange(len(names)), {"left_wheel": 0.9}, behavior_accuracy=0.8),
            _robot(boyd2, "J", -np.ones(len(names)), {"left_wheel": 0.6}),
        ],
        iterations=3,
        label_changes=(1, 2),
        timings={"irl": 1.23456, "labels": 0.5},
        message="converged",
    )
    out = learn_record(result, boyd2, "run.csv", 1000, 0.5)
    assert json.loads(json.dumps(out)) == out  # JSON-ready: nothing numpy left
    assert (out["method"], out["scenario"], out["observations"]) == ("mirl-t", "boyd2", "run.csv")
    assert (out["steps"], out["observability"]) == (1000, 0.5)
    assert out["robots"]["I"]["weights"] == {n: float(k) for k, n in enumerate(names)}
    assert out["robots"]["I"]["feature_probabilities"] == {"left_wheel": 0.9}
    assert out["robots"]["I"]["behavior_accuracy"] == 0.8
    assert out["robots"]["J"]["behavior_accuracy"] is None
    assert "verdict" not in out["robots"]["J"]  # none learned: no uncertainty keys at all
    eq = out["equilibrium"]
    assert eq["label"] == boyd2.game.equilibria()[0].label()
    assert [c["label"] for c in eq["candidates"]] == [e.label() for e in boyd2.game.equilibria()]
    assert all(c["weight"] is None for c in eq["candidates"])  # no weights learned
    assert (out["iterations"], out["label_changes"]) == (3, [1, 2])
    assert out["timings"] == {"irl": 1.2346, "labels": 0.5}
    assert out["message"] == "converged"
    assert "pair_equilibria" not in out  # two robots: one pair, the equilibrium itself


def test_a_record_of_data_without_truth_scores_the_observed_moves(boyd2):
    names = boyd2.domain.reward_feature_names
    result = _result(
        boyd2,
        [_robot(boyd2, r, np.zeros(len(names)), {}) for r in ("I", "J")],
        equilibrium_weights=(0.7, 0.2, 0.1),
    )
    agreement = {"J": ObservedAgreement(moves=40, followed=30, unexplained=2)}
    out = learn_record(result, boyd2, "bag", 50, 1.0, agreement)
    assert out["robots"]["J"]["observed_moves"] == {
        "moves": 40,
        "followed": 30,
        "share": 0.75,
        "unexplained": 2,
    }
    assert "observed_moves" not in out["robots"]["I"]
    assert [c["weight"] for c in out["equilibrium"]["candidates"]] == [0.7, 0.2, 0.1]


def _with_verdict(scenario) -> RobotModel:
    names = scenario.domain.reward_feature_names
    verdict = Verdict(None, 0.9, WHEELS, {"left_wheel": 0.5, "right_wheel": 0.45}, fit=FITS)
    uncertainty = FeatureUncertainty(
        {"left_wheel": (0.6, 0.9)},
        verdict,
        medians={"left_wheel": 0.712345},
        motion_models={"paper/uniform": 0.25, "paper/stop": 0.75},
        indistinguishable=(WHEELS, ("navigation", "floor")),
        sided_by_drift=True,
        untested=("floor",),
    )
    return _robot(
        scenario, "J", np.zeros(len(names)), {"left_wheel": 0.7, "right_wheel": 0.7},
        feature_intervals={"left_wheel": (0.612345, 0.9)}, verdict=verdict,
        lateral_drift=LateralDrift(0.05, 0.01, 40), uncertainty=uncertainty,
        motion_model="paper/uniform",
    )  # fmt: skip


def test_a_record_with_a_verdict_holds_its_uncertainty(boyd2):
    robot = _with_verdict(boyd2)
    out = learn_record(_result(boyd2, [robot]), boyd2, "run.csv", 10, 1.0)
    r = out["robots"]["J"]
    assert json.loads(json.dumps(out)) == out
    assert r["feature_intervals"] == {"left_wheel": [0.6123, 0.9]}
    assert r["feature_medians"] == {"left_wheel": 0.7123}
    assert (r["motion_model"], r["motion_models"]) == (
        "paper/uniform",
        {"paper/uniform": 0.25, "paper/stop": 0.75},
    )
    # the drift tells the wheels' side, not navigation's from floor's
    assert r["indistinguishable"] == [
        {"features": list(WHEELS), "told_apart_by": "drift"},
        {"features": ["navigation", "floor"], "told_apart_by": None},
    ]
    assert r["untested"] == ["floor"]
    assert r["verdict"] == robot.verdict.to_dict()
    assert r["lateral_drift"] == {"mean": 0.05, "se": 0.01, "steps": 40}


def test_a_team_records_each_pairs_equilibrium():
    team = load_scenario("boydright-3")
    names = team.domain.reward_feature_names
    go_stop, stop_go = team.game.equilibria()[:2]
    result = _result(
        team,
        [_robot(team, r, np.zeros(len(names)), {}) for r in team.robot_names],
        pair_equilibria={(0, 1): go_stop, (1, 2): stop_go},
    )
    out = learn_record(result, team, "run.csv", 10, 1.0)
    assert out["pair_equilibria"] == {"I/J": go_stop.label(), "J/K": stop_go.label()}


# ---- the text form -------------------------------------------------------------------------
def test_the_text_form_says_what_the_record_holds(boyd2, capsys):
    names = boyd2.domain.reward_feature_names
    plain = _robot(boyd2, "I", np.ones(len(names)), {}, behavior_accuracy=0.875)
    result = _result(
        boyd2,
        [plain, _with_verdict(boyd2)],
        equilibrium_weights=(0.5, 0.5, None),
        label_changes=(2,),
        iterations=4,
        timings={"irl": 1.0},
        message="labels settled",
    )
    agreement = {"J": ObservedAgreement(moves=0, followed=0, unexplained=0)}
    out = learn_record(result, boyd2, "run.csv", 10, 0.5, agreement)
    print_learn(out, result, boyd2)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "mirl-t on boyd2: run.csv (10 steps, observability 0.5)"
    i, j = lines.index("robot I"), lines.index("robot J")
    robot_i, robot_j = lines[i + 1 : j], lines[j + 1 :]
    assert robot_i[0].startswith("  weights       moved=1.000")
    assert robot_i[1] == "  features      labels settled"  # nothing learned: the message
    assert "  behaviour accuracy 0.875 (vs the scenario's truth)" in robot_i
    shown = [line.strip() for line in robot_j]
    assert any(s.startswith("features      left_wheel=0.700") for s in shown)
    assert "95 % interval left_wheel 0.61–0.90" in shown
    weights_j = out["robots"]["J"]["motion_models"]
    assert "motion        " + motion_sentence(weights_j, "paper/uniform") in shown
    assert drift_line(out["robots"]["J"]["lateral_drift"]) in shown
    assert f"verdict       {result.robot('J').verdict.sentence('J')}" in shown
    assert any(s.startswith("behaviour     no observed moves") for s in shown)
    assert not any(s.startswith("behaviour accuracy") for s in shown)  # data without truth
    eq = boyd2.game.equilibria()
    weights = f"{eq[0].label()} 0.50, {eq[1].label()} 0.50"  # the unweighted one left out
    assert f"equilibrium   {eq[0].label()} (weights: {weights})" in lines
    assert "iterations    4 (labels changed: 2; labels settled)" in lines
    assert lines[-1] == "timings       irl 1.00 s"
