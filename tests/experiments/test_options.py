"""RunProtocol and SweepOptions: the run's and the sweep's options declared once, with the
command line's defaults; the paper's protocol is one call; the API and `mirl run` give the same
run for the same seed."""

from __future__ import annotations

import json

import pytest

from mirl._validation import OptionError
from mirl.cli import main
from mirl.experiments.cost import planning_horizon
from mirl.experiments.episode import run_episode
from mirl.experiments.options import (
    GO_RULES,
    MIN_TRAVEL,
    TRAVEL_PER_PATH_STEP,
    RunProtocol,
    SweepOptions,
)
from mirl.learning.options import LearnOptions
from mirl.world.scenario import load_scenario


def test_the_defaults_are_the_command_lines():
    run = RunProtocol()
    assert (run.obs_steps, run.watch_until_seen, run.max_obs_steps, run.max_wait) == (
        300, 40, 1800, 450,
    )  # fmt: skip
    assert (run.go_rule, run.relearn, run.relearn_growth) == ("adaptive", True, 1.5)
    sweep = SweepOptions()
    assert sweep.go_rule == run.go_rule and sweep.relearn == run.relearn
    passed_on = (("go_rule", RunProtocol), ("relearn", RunProtocol), ("em_init", LearnOptions))
    for name, owner in passed_on:
        mine, theirs = SweepOptions.spec(name), owner.spec(name)  # declared once, read twice
        assert mine.constraints is theirs.constraints and mine.doc is theirs.doc
    assert sweep.n_workers >= 1 and SweepOptions(workers=3).n_workers == 3


def test_the_papers_protocol():
    paper = RunProtocol.paper(obs_steps=150)
    assert paper.fixed_time and paper.go_rule == "value" and not paper.relearn
    assert paper.obs_steps == 150 and not RunProtocol().fixed_time


@pytest.mark.parametrize(
    ("values", "needle"),
    [
        ({"obs_steps": 0}, "`obs_steps` must be an integer in [1, 10000], got 0"),
        ({"max_wait": 10_001}, "`max_wait` must be an integer in [0, 10000]"),
        ({"watch_until_seen": 0}, "`watch_until_seen` must be an integer in [1, 10000] or None"),
        ({"watch_until_seen": 500, "max_obs_steps": 400}, "must be at most max_obs_steps"),
        (
            {"go_rule": "bold"},
            "`go_rule`: unknown go rule 'bold' (known: adaptive, adaptive-posterior, value)",
        ),
        ({"relearn_growth": 1.0}, "`relearn_growth` must be a number > 1, got 1.0"),
        ({"replan_every": 0}, "`replan_every` must be an integer >= 1"),
        ({"hazard": "markv"}, "did you mean 'markov'"),
        ({"joint": "yes"}, "`joint` must be True or False or None"),
        ({"detection_penalty": -1}, "`detection_penalty` must be a number >= 0"),
        ({"obs_step": 3}, "`obs_step` is not an option of RunProtocol (did you mean 'obs_steps'"),
    ],
)
def test_a_protocol_that_cannot_run_is_refused_by_name(values, needle):
    with pytest.raises(OptionError) as info:
        RunProtocol(**values)
    assert needle in str(info.value)


@pytest.mark.parametrize(
    ("values", "needle"),
    [
        ({"runs": 0}, "`runs` must be an integer in [1, 100000] or None"),
        ({"dask_scheduler": "h:99999"}, "`dask_scheduler` must be an address HOST:PORT"),
        ({"world": "phisics"}, "did you mean 'physics'"),
        ({"base_seed": -1}, "`base_seed` must be an integer in [0, 2^63 - 1]"),
    ],
)
def test_a_sweep_that_cannot_run_is_refused_by_name(values, needle):
    with pytest.raises(OptionError) as info:
        SweepOptions(**values)
    assert needle in str(info.value)


@pytest.mark.parametrize(
    ("values", "needle"),
    [
        ({"workers": 4, "dask_scheduler": "127.0.0.1:8786"}, "`workers` sets local processes"),
        ({"progress": False, "progress_every": 3}, "`progress_every` spaces the progress lines"),
    ],
)
def test_an_option_another_makes_unread_is_refused(values, needle):
    # the cluster runs on all its threads, and no progress means no progress lines to space
    with pytest.raises(OptionError) as info:
        SweepOptions(**values)
    assert needle in str(info.value)
    SweepOptions(**{k: v for k, v in values.items() if k in ("dask_scheduler", "progress")})


@pytest.mark.parametrize("address", ["127.0.0.1:8786", "tcp://sched:1", "[::1]:65535"])
def test_a_dask_address_is_accepted(address):
    assert SweepOptions(dask_scheduler=address).dask_scheduler == address


def test_the_travel_horizon_and_the_cost_estimate_read_the_protocol():
    assert RunProtocol().travel(3) == MIN_TRAVEL and RunProtocol().travel(10) == 30
    assert RunProtocol(travel_steps=7).travel(10) == 7 and TRAVEL_PER_PATH_STEP == 3
    boyd2 = load_scenario("boyd2")
    wide = RunProtocol(window=100)
    assert planning_horizon(boyd2, wide) - planning_horizon(boyd2) == 100 - RunProtocol().window


def test_every_go_rule_is_documented_in_its_flag():
    help_text = RunProtocol.spec("go_rule").doc
    assert all(f"{name}: " in help_text for name in GO_RULES)


@pytest.mark.parametrize("seed", [0, 3, 5])
def test_the_api_and_mirl_run_give_the_same_run(seed, capsys):
    """``run_episode``'s defaults are ``mirl run``'s: the same go time and outcome, and the
    same record, for the same seed (on seed 3 both watch on to t = 700 and go at t = 1016)."""
    api = run_episode(load_scenario("boyd2"), "mirl-t", seed=seed)
    assert main(["run", "--seed", str(seed), "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert (api.go_time, api.outcome) == (cli["go_time"], cli["outcome"])
    assert api.obs_steps == cli["obs_steps"] and cli["watch_until_seen"] == 40
    mine = {k: v for k, v in api.to_dict().items() if k != "timings"}
    theirs = {k: v for k, v in cli.items() if k != "timings"}
    assert json.loads(json.dumps(mine)) == theirs
    if seed == 3:
        assert api.go_time == 1016 and api.obs_steps == 700
