"""`mirl.learning.learn` and `mirl learn`: methods, the relabelling loop, the CLI."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mirl.cli import main
from mirl.learning.learn import LoopTrace, learn
from mirl.learning.methods import LEARNING_METHODS, METHODS
from mirl.learning.options import LearnOptions
from mirl.learning.results import LearnResult, oracle_models
from mirl.learning.transitions import (
    count_subsets,
    observed_steps,
    perception_labels,
    policy_labels,
)
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
    at = learn(obs, boyd2, "mirl-t", observability=1.0, options={"label_tol": first / n})
    assert at.iterations == 1 and at.success
    assert f"labels converged ({first} of {n} changed, within label_tol)" in at.message
    looser = {"label_tol": (first - 0.5) / n}
    below = learn(obs, boyd2, "mirl-t", observability=1.0, options=looser)
    assert below.iterations > 1
    assert below.label_changes == result.label_changes[: below.iterations]  # the same rounds
    with pytest.raises(ValueError, match=r"`label_tol` must be a number in \[0, 1\]"):
        learn(obs, boyd2, "mirl-t", options={"label_tol": 1.5})


@pytest.mark.parametrize("method", [m for m in LEARNING_METHODS if m != "mirl-t"])
def test_every_method_returns_models(boyd2, method):
    run = simulate(boyd2, 120, seed=1, observability=0.5, random_starts=True)
    options = {"p": 0.8} if METHODS[method].uses_p else {}
    result = learn(run.observations, boyd2, method, observability=0.5, options=options)
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


# ---- warm starts (a re-learn on a grown record) ------------------------------------------------
def test_a_warm_start_on_the_same_record_settles_at_once_on_its_labels(boyd2, full_run, relabelled):
    """Started from a solution of the very same record, the rounds start at that solution's
    fixed point: its final labels, unchanged by one round."""
    result, trace = relabelled
    assert result.label_changes[-1] == 0  # the solution is a fixed point of the relabelling
    again = LoopTrace()
    warm = learn(
        full_run.observations, boyd2, "mirl-t", observability=1.0, warm_start=result, trace=again
    )
    assert warm.iterations == 1 and warm.label_changes == (0,) and warm.success
    for first, last in zip(again.labels[0], trace.labels[-1], strict=True):
        np.testing.assert_array_equal(first, last)
    # the IRL, started at the earlier optimum, may drift along a flat direction of its loss:
    # the policies agree wherever the robot was seen, not necessarily elsewhere
    for i, (a, b) in enumerate(zip(warm.robots, result.robots, strict=True)):
        x = full_run.observations.state_series(boyd2.domain, i)
        np.testing.assert_array_equal(a.policy[x[x >= 0]], b.policy[x[x >= 0]])
    assert warm.equilibrium == result.equilibrium


def _without(obs, robot: int, before: int):
    """``obs`` with robot ``robot``'s sightings before step ``before`` removed."""
    return obs.select(~((obs.robot == robot) & (obs.t < before)))


@pytest.fixture(scope="module")
def grown(boyd2):
    """A record of 240 steps at half view and its first 120 steps."""
    obs = simulate(boyd2, 240, seed=3, observability=0.5, random_starts=True).observations
    return obs, obs.truncate(120)


def _valid(boyd2, result):
    assert result.method == "mirl-t" and result.iterations == len(result.label_changes)
    assert result.equilibrium in boyd2.game.equilibria()
    for r in result.robots:
        assert np.isfinite(r.weights).all() and r.policy.shape == (124,)
        assert 0.0 <= r.behavior_accuracy <= 1.0


def test_a_warm_start_on_a_longer_record(boyd2, grown):
    """A re-learn on the grown record, warm-started from the learning of its first half: the
    rounds start from the labels the first solution gives the steps it learned from and from
    perception on the new ones, and end at least as settled as a cold start's."""
    obs, first_half = grown
    first = learn(first_half, boyd2, "mirl-t", observability=0.5)
    assert first.horizon == 120
    trace, cold_trace = LoopTrace(), LoopTrace()
    warm = learn(obs, boyd2, "mirl-t", observability=0.5, warm_start=first, trace=trace)
    cold = learn(obs, boyd2, "mirl-t", observability=0.5, trace=cold_trace)
    _valid(boyd2, warm)
    assert warm.success and warm.iterations <= cold.iterations
    series = [obs.state_series(boyd2.domain, i) for i in range(2)]
    earlier = policy_labels(
        boyd2.domain, series, [r.policy for r in first.robots], first.equilibrium
    )
    for got, old, perceived in zip(trace.labels[0], earlier, cold_trace.labels[0], strict=True):
        np.testing.assert_array_equal(got[:120], old[:120])
        np.testing.assert_array_equal(got[120:], perceived[120:])
    assert abs(np.mean([r.behavior_accuracy for r in warm.robots])
               - np.mean([r.behavior_accuracy for r in cold.robots])) <= 0.1  # fmt: skip


def test_a_warm_start_from_a_record_that_never_saw_a_robot(boyd2, grown):
    """J first seen after the earlier learning: the model L had of it (the others' reward)
    labels none of its steps — all are new, and start from perception, as in a cold start —
    so the rounds cannot settle on that model."""
    obs, _ = grown
    record = _without(obs, 1, 120)
    first = learn(record.truncate(120), boyd2, "mirl-t", observability=0.5)
    assert "never observed: J" in first.message
    np.testing.assert_array_equal(first.robots[1].weights, first.robots[0].weights)
    trace, cold_trace = LoopTrace(), LoopTrace()
    warm = learn(record, boyd2, "mirl-t", observability=0.5, warm_start=first, trace=trace)
    learn(record, boyd2, "mirl-t", observability=0.5, trace=cold_trace)
    _valid(boyd2, warm)
    assert "never observed" not in warm.message
    np.testing.assert_array_equal(trace.labels[0][1], cold_trace.labels[0][1])


def test_a_warm_start_for_a_record_that_never_sees_a_robot(boyd2, grown):
    """J seen in the earlier record but not in the new one (a record that does not extend the
    earlier): J gets the others' reward, as in a cold start."""
    obs, first_half = grown
    first = learn(first_half, boyd2, "mirl-t", observability=0.5)
    warm = learn(_without(obs, 1, 240), boyd2, "mirl-t", observability=0.5, warm_start=first)
    _valid(boyd2, warm)
    assert "never observed: J" in warm.message
    np.testing.assert_array_equal(warm.robots[1].weights, warm.robots[0].weights)


def test_a_warm_start_from_no_record_starts_only_the_irl(boyd2, grown):
    """Models not learned from a record (here the truth) have no labels to give: the rounds
    start from perception, the IRL from their weights."""
    obs, _ = grown
    truth = oracle_models(boyd2)
    assert truth.horizon is None
    trace, cold_trace = LoopTrace(), LoopTrace()
    learn(obs, boyd2, "mirl-t", observability=0.5, warm_start=truth, trace=trace)
    learn(obs, boyd2, "mirl-t", observability=0.5, trace=cold_trace)
    for a, b in zip(trace.labels[0], cold_trace.labels[0], strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("method", ["mirl", "dbn-em"])
def test_a_method_that_does_not_relabel_keeps_its_labels_and_starts_the_irl_warm(
    boyd2, grown, method
):
    """Without relabelling only the IRL's start changes: the labels are perception's, and the
    IRL starts once, from the earlier weights."""
    obs, first_half = grown
    first = learn(first_half, boyd2, "mirl-t", observability=0.5)
    cold_trace, warm_trace = LoopTrace(), LoopTrace()
    two = LearnOptions(n_restarts=2)
    cold = learn(obs, boyd2, method, observability=0.5, options=two, trace=cold_trace)
    warm = learn(
        obs, boyd2, method, observability=0.5, options=two, warm_start=first, trace=warm_trace
    )
    for a, b in zip(warm_trace.labels[0], cold_trace.labels[0], strict=True):
        np.testing.assert_array_equal(a, b)
    assert warm.iterations == cold.iterations == 1
    for w, c in zip(warm_trace.irl, cold_trace.irl, strict=True):
        assert len(w.result_.starts) == 1 and len(c.result_.starts) == 2
    np.testing.assert_array_equal(warm.robots[0].transitions.toarray(),
                                  cold.robots[0].transitions.toarray())  # fmt: skip


def test_a_warm_start_of_other_robots_or_another_map_is_refused(boyd2, grown, relabelled):
    obs, _ = grown
    result, _ = relabelled
    with pytest.raises(TypeError, match="warm_start must be"):
        learn(obs, boyd2, warm_start=[r.weights for r in result.robots])
    with pytest.raises(ValueError, match=r"warm_start models robots \['I'\]"):
        learn(obs, boyd2, warm_start=replace(result, robots=result.robots[:1]))
    small = replace(result.robots[0], policy=np.zeros(5, dtype=int))
    with pytest.raises(ValueError, match="not of this map"):
        learn(obs, boyd2, warm_start=replace(result, robots=(small, result.robots[1])))


def test_bad_arguments(boyd2, full_run):
    with pytest.raises(ValueError, match="unknown method"):
        learn(full_run.observations, boyd2, "magic")
    with pytest.raises(ValueError, match="`p` must be"):
        learn(full_run.observations, boyd2, "mirl", options={"p": 1.5})
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


def test_verdicts_read_intentions_from_the_final_models_labels(monkeypatch):
    """Where the relabelling stops unsettled (a patrol's end turned left or right, the two nearly
    tied for the IRL), the labels the last round learned from are a round behind its policies.
    The verdicts read each step's intention from the final policies' labels: a stale label is
    not the meeting rule's, and kept as one it counted the robot's successful left turns as
    failed right turns (the all-worn robot below was said damaged at 0.9985)."""
    import mirl.learning.learn as learn_module

    sc = load_scenario("boyd2-healthy")
    for part in sc.feature_map.features:
        sc = sc.with_damage("I", part, 0.9)
    run = simulate(sc, 450, seed=5000, observability=1.0)
    seen: list = []
    real = learn_module.robot_uncertainty

    def spy(domain, record, *args, **kwargs):
        seen.append((np.asarray(record.labels), kwargs.get("own_policy")))
        return real(domain, record, *args, **kwargs)

    monkeypatch.setattr(learn_module, "robot_uncertainty", spy)
    trace = LoopTrace()
    learn(run.observations, sc, "mirl-t", observability=1.0, trace=trace)
    assert not trace.converged  # the case: the loop stopped with labels still changing
    series = [run.observations.state_series(sc.domain, i) for i in range(2)]
    stale = 0
    for i, (labels, own) in enumerate(seen):
        np.testing.assert_array_equal(labels, trace.final_labels[i])
        t, s, _ = observed_steps(series[i])
        stale += int((trace.labels[-1][i][t] != labels[t]).sum())
        # the final labels are the final policy's but at meetings (the meeting rule's)
        assert (labels[t] == own[s]).mean() > 0.9
    assert stale > 0


def test_listing_the_robots_in_another_order_learns_the_same(tmp_path, capsys):
    """Each robot's random streams (its IRL's restarts, its verdict's sampler) follow its name,
    not its place in the scenario: boyd2 with J listed first learns the same from one record."""
    import mirl.world.scenario as scenario_module

    shipped = Path(scenario_module.__file__).parent.parent / "data/scenarios/boyd2.toml"
    head, *robots = shipped.read_text().split("[[robots]]")
    reversed_toml = tmp_path / "reversed.toml"
    listed = "".join("[[robots]]" + r.rstrip() + "\n\n" for r in robots[::-1])
    reversed_toml.write_text(head + listed)
    obs = tmp_path / "obs.csv"
    simulate(load_scenario("boyd2"), 450, seed=2, observability=1.0).observations.to_csv(obs)
    learned = []
    for scenario in ("boyd2", str(reversed_toml)):
        args = ["learn", "--scenario", scenario, "--observations", str(obs), "--json"]
        assert main(args) == 0
        learned.append(json.loads(capsys.readouterr().out)["robots"])
    assert list(learned[1]) == ["J", "I"]
    for name in ("I", "J"):
        for key in ("feature_probabilities", "weights", "verdict", "feature_intervals"):
            assert learned[0][name][key] == learned[1][name][key], (name, key)
