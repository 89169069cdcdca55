"""A run's records and their JSON form: every field a run reports is there, plain JSON, and an
optional key is absent rather than null when its value is not set."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mirl.experiments.options import RunProtocol
from mirl.experiments.records import Detection, PlanAttempt, Relearn, RunResult
from mirl.learning.results import oracle_models
from mirl.observations.trajectories import Trajectories
from mirl.world.scenario import load_scenario


def test_a_planning_round_states_its_chance_only_under_the_adaptive_rule():
    assert PlanAttempt(5, 0.25, None).to_dict() == {"t": 5, "best_value": 0.25, "go_time": None}
    adaptive = PlanAttempt(5, 0.25, 9, predicted_success=0.8).to_dict()
    assert adaptive == {"t": 5, "best_value": 0.25, "go_time": 9, "predicted_success": 0.8}


def test_a_relearn_leaves_its_wall_time_out_of_the_json():
    r = Relearn(40, 12, {"I": {"left_wheel": 0.9}}, {"I": "no part of I is damaged"}, None, 1.5)
    assert r.to_dict() == {
        "t": 40,
        "observed_steps": 12,
        "feature_probabilities": {"I": {"left_wheel": 0.9}},
        "verdicts": {"I": "no part of I is damaged"},
        "behavior_accuracy": None,
    }


def run_result(**kw):
    values = dict(
        scenario="boyd2",
        method="mirl-t",
        seed=3,
        observability=0.14,
        obs_steps=300,
        outcome="detected",
        go_time=310,
        plan_value=0.4,
        behavior_accuracy=0.9,
        behavior_accuracy_per_robot={"I": 0.95, "J": 0.85},
        feature_probabilities={"I": {"left_wheel": 1.0}},
        timings={"total": 2.0},
        observer_path=np.array([[310, 0, 0, 0], [311, 0, 1, 0]]),
        detections=(Detection(311, "J", (2, 1, 3), (0, 1)),),
        true_states=np.zeros((312, 2), int),
        observations=Trajectories(("I", "J"), *(np.zeros(0, int) for _ in range(5)), horizon=1),
        attempts=(PlanAttempt(300, 0.4, 310),),
        robot_names=("I", "J"),
        end_time=311,
    )
    return RunResult(**{**values, **kw})


def test_a_run_by_hand_has_the_documented_keys_and_no_optional_ones():
    d = run_result().to_dict()
    assert list(d) == [
        "scenario", "method", "seed", "observability", "obs_steps", "outcome", "go_time",
        "plan_value", "behavior_accuracy", "behavior_accuracy_per_robot",
        "feature_probabilities", "timings", "seen_steps", "plan_attempts", "detections",
        "observer_path", "end_time",
    ]  # fmt: skip
    assert d["detections"] == [
        {"t": 311, "robot": "J", "robot_state": [2, 1, 3], "observer_cell": [0, 1]}
    ]
    assert d["observer_path"] == [[310, 0, 0, 0], [311, 0, 1, 0]]
    assert d["plan_attempts"] == [{"t": 300, "best_value": 0.4, "go_time": 310}]
    assert json.loads(json.dumps(d)) == d  # plain JSON through and through


def test_the_optional_keys_appear_when_set():
    protocol = RunProtocol()  # mirl's default: watch until each patroller is seen 40 times
    relearn = Relearn(320, 50, {}, {}, 0.9, 0.1)
    r = run_result(protocol=protocol, predicted_success=0.7, relearns=(relearn,))
    d = r.to_dict()
    assert r.watch_until_seen == d["watch_until_seen"] == 40
    assert d["predicted_success"] == 0.7
    assert d["relearns"] == [relearn.to_dict()]
    assert d["never_seen"] == ["I", "J"]  # the run by hand saw nobody before it went at 310
    seen_j = Trajectories(("I", "J"), *(np.array([v]) for v in (305, 1, 0, 1, 0)), horizon=311)
    assert run_result(predicted_success=0.7, observations=seen_j).to_dict()["never_seen"] == ["I"]
    late_i = Trajectories(("I", "J"), *(np.array([v]) for v in (311, 0, 0, 1, 0)), horizon=312)
    assert run_result(predicted_success=0.7, observations=late_i).never_seen == ("I", "J")
    assert run_result(relearns=()).to_dict()["relearns"] == []  # re-learning, never needed
    assert run_result(protocol=RunProtocol.paper()).watch_until_seen is None  # a fixed time


@pytest.fixture(scope="module")
def truth():
    return oracle_models(load_scenario("boyd2"))


def test_learned_models_give_their_intervals_and_verdicts(truth):
    d = run_result(learned=truth).to_dict()
    names = [r.name for r in truth.robots]
    assert list(d["feature_intervals"]) == list(d["verdicts"]) == names
    j = truth.robot("J")
    assert d["feature_intervals"]["J"] == {
        f: [round(float(p), 4)] * 2 for f, p in j.feature_probabilities.items()
    }
    assert d["verdicts"]["J"] == j.verdict.to_dict()
    assert "lateral_drifts" not in d  # grid states: no robot veered
    assert json.loads(json.dumps(d)) == d


def test_a_worlds_extras_join_the_record():
    class Extras:
        def to_dict(self):
            return {"world": "fog", "visibility_m": 3}

    d = run_result(extras=Extras(), world="fog").to_dict()
    assert (d["world"], d["visibility_m"]) == ("fog", 3)
