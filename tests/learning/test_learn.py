"""`mirl.learning.learn` and `mirl learn`: methods, the relabelling loop, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mirl.cli import main
from mirl.learning.learn import LoopTrace, learn
from mirl.learning.methods import LEARNING_METHODS
from mirl.learning.results import LearnResult
from mirl.learning.transitions import count_subsets, observed_steps, perception_labels
from mirl.simulation.grid import simulate
from mirl.world.domain import FORWARD, TURN_LEFT, TURN_RIGHT
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


@pytest.fixture(scope="module")
def full_run(boyd2):
    return simulate(boyd2, 150, seed=2, observability=1.0, random_starts=True)


@pytest.fixture(scope="module")
def relabelled(boyd2, full_run):
    trace = LoopTrace()
    result = learn(full_run.observations, boyd2, "mirl-t", observability=1.0, trace=trace)
    return result, trace


def test_mirl_t_result_has_everything(boyd2, relabelled):
    result, trace = relabelled
    assert isinstance(result, LearnResult) and result.method == "mirl-t"
    assert [r.name for r in result.robots] == ["I", "J"]
    for r in result.robots:
        assert r.weights.shape == (4,)
        assert set(r.feature_probabilities) == set(boyd2.feature_map.features)
        assert r.transitions.shape == (4 * 124, 124) and r.policy.shape == (124,)
        assert 0.8 <= r.behavior_accuracy <= 1.0
    assert result.equilibrium in boyd2.game.equilibria()
    assert len(result.equilibrium_weights) == 3
    assert sum(result.equilibrium_weights) == pytest.approx(1.0)
    assert result.iterations == len(trace.labels) == len(result.label_changes)
    assert {"labels", "transitions", "irl", "equilibria", "total"} <= set(result.timings)


def test_relabelling_turns_a_perceived_turn_into_a_failed_forward(boyd2, full_run, relabelled):
    """J meant to go forward, a failure turned it: perception reads a turn, the learned
    policy's relabel says forward — so the step now counts as a failure of forward."""
    result, trace = relabelled
    d, j = boyd2.domain, boyd2.robot_index("J")
    truth = full_run.truth.state_series(d, j)
    t, s, s_next = observed_steps(truth)
    perceived = perception_labels(d, s, s_next)
    failed = t[(boyd2.true_policy(j)[s] == FORWARD) & np.isin(perceived, [TURN_LEFT, TURN_RIGHT])]
    assert failed.size > 0
    first, last = trace.labels[0][j], trace.labels[-1][j]
    assert np.isin(first[failed], [TURN_LEFT, TURN_RIGHT]).all()  # perception's reading
    assert (last[failed] == FORWARD).mean() >= 0.9  # relabelled by the learned policy
    assert result.label_changes[0] > 0
    # the loop stops: here the labels fixate within the cap
    assert result.label_changes[-1] == 0 and result.success
    assert result.iterations < 5
    forward = d.subset_index[0, FORWARD]
    before = count_subsets(d, s, first[t], s_next)
    after = count_subsets(d, s, last[t], s_next)
    assert before.successes[forward] == before.trials[forward]  # perception: never a failure
    assert after.successes[forward] < after.trials[forward]
    # J's damaged left wheel shows up once failures are counted
    probs = result.robot("J").feature_probabilities
    assert probs["left_wheel"] < probs["right_wheel"]


def test_label_tol_counts_a_round_within_it_as_converged(boyd2, full_run, relabelled):
    """A relabelling that changes at most ``label_tol`` of the labelled steps ends the loop
    (converged, and the message says how many changed); one label fewer allowed goes on."""
    result, _ = relabelled
    first = result.label_changes[0]
    series = [full_run.observations.state_series(boyd2.domain, i) for i in range(2)]
    n = sum(len(observed_steps(x)[0]) for x in series)
    assert first > 0.01 * n  # the default tolerance did not stop it after one round
    obs = full_run.observations
    at = learn(obs, boyd2, "mirl-t", observability=1.0, label_tol=first / n)
    assert at.iterations == 1 and at.success
    assert f"labels converged ({first} of {n} changed, within label_tol)" in at.message
    below = learn(obs, boyd2, "mirl-t", observability=1.0, label_tol=(first - 0.5) / n)
    assert below.iterations > 1
    assert below.label_changes == result.label_changes[: below.iterations]  # the same rounds
    with pytest.raises(ValueError, match="label_tol must be in"):
        learn(obs, boyd2, "mirl-t", label_tol=1.5)


@pytest.mark.parametrize("method", [m for m in LEARNING_METHODS if m != "mirl-t"])
def test_every_method_returns_models(boyd2, method):
    run = simulate(boyd2, 120, seed=1, observability=0.5, random_starts=True)
    result = learn(run.observations, boyd2, method, observability=0.5, p=0.8)
    assert result.method == method
    assert len(result.robots) == 2
    for r in result.robots:
        assert r.policy.shape == (124,)
        assert 0.0 <= r.behavior_accuracy <= 1.0
    if method in ("known-r-t", "known-r", "oracle"):
        assert result.equilibrium == boyd2.played_equilibrium
        np.testing.assert_array_equal(result.robots[0].weights, boyd2.robots[0].weights)
    if method in ("mirl", "known-r"):
        assert result.robots[0].feature_probabilities == {}
        assert "p=0.8" in result.message
        assert result.robots[0].transitions[0].toarray().max() == pytest.approx(0.8)
    if method == "known-r-t":
        assert set(result.robots[1].feature_probabilities) == set(boyd2.feature_map.features)


def test_learning_is_deterministic_given_the_seed(boyd2):
    run = simulate(boyd2, 200, seed=4, observability=0.3, random_starts=True)
    a, b = (learn(run.observations, boyd2, random_state=3) for _ in range(2))
    for ra, rb in zip(a.robots, b.robots, strict=True):
        np.testing.assert_array_equal(ra.weights, rb.weights)
        np.testing.assert_array_equal(ra.policy, rb.policy)


def test_bad_arguments(boyd2, full_run):
    with pytest.raises(ValueError, match="unknown method"):
        learn(full_run.observations, boyd2, "magic")
    with pytest.raises(ValueError, match="p must be"):
        learn(full_run.observations, boyd2, "mirl", p=1.5)
    other = load_scenario("boyd2")
    renamed = type(full_run.observations)(
        ("A", "B"),
        *[
            getattr(full_run.observations, f)
            for f in ("t", "robot", "row", "col", "heading", "horizon")
        ],
    )
    with pytest.raises(ValueError, match="robots"):
        learn(renamed, other)


# ---- CLI ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def obs_csv(tmp_path_factory, boyd2):
    path = tmp_path_factory.mktemp("learn") / "obs.csv"
    simulate(boyd2, 200, seed=5, observability=0.3, random_starts=True).observations.to_csv(path)
    return path


def test_cli_learn_text(obs_csv, capsys):
    args = ["learn", "--scenario", "boyd2", "--observations", str(obs_csv)]
    assert main([*args, "--observability", "0.3"]) == 0
    out = capsys.readouterr().out
    for needle in ("robot I", "robot J", "left_wheel=", "behaviour accuracy", "equilibrium"):
        assert needle in out
    assert "timings" in out and "irl" in out


def test_cli_learn_json(obs_csv, capsys):
    args = ["learn", "--scenario", "boyd2", "--observations", str(obs_csv), "--json"]
    assert main([*args, "--method", "known-r-t", "--observability", "0.3"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"robots", "equilibrium", "iterations", "timings"} <= set(out)
    assert set(out["robots"]) == {"I", "J"}
    for r in out["robots"].values():
        assert {"weights", "feature_probabilities", "behavior_accuracy"} <= set(r)
        assert set(r["weights"]) == {"moved", "upper_hallway", "lower_hallway", "turn_around"}
    assert out["equilibrium"]["label"] == "stop/go"


def test_cli_learn_bad_csv_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,robot,row,col,heading\n0,I,0,1,x\n")
    assert main(["learn", "--scenario", "boyd2", "--observations", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "line 2" in err and "not an integer" in err


# ---- statistics (slow) -----------------------------------------------------------------------
@pytest.mark.slow
def test_full_observability_accuracy_over_ten_seeds(boyd2):
    acc = []
    for seed in range(10):
        run = simulate(boyd2, 450, seed=seed, observability=1.0, random_starts=True)
        result = learn(run.observations, boyd2, "mirl-t", observability=1.0, random_state=seed)
        acc.append(np.mean([r.behavior_accuracy for r in result.robots]))
    assert np.mean(acc) >= 0.95
