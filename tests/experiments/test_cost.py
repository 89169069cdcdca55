"""The cost estimate known before any work, and the one-line refusal over the budget."""

from __future__ import annotations

import pytest

from mirl.cli import main
from mirl.experiments.cost import (
    CostError,
    check_budget,
    default_max_memory,
    estimate_cost,
    planning_horizon,
)
from mirl.world.scenario import load_scenario


def test_the_estimate_grows_with_states_robots_and_steps():
    small, office = load_scenario("boyd2"), load_scenario("office")
    a = estimate_cost(small, "run", steps=300)
    b = estimate_cost(office, "run", steps=300)
    assert a.states == small.domain.n_states and b.states == office.domain.n_states
    assert b.memory > a.memory and b.seconds > a.seconds
    assert estimate_cost(small, "learn", steps=300).memory < a.memory  # no planning
    assert (
        estimate_cost(small, "learn", steps=600).seconds
        > estimate_cost(small, "learn", steps=300).seconds
    )
    # learning's solves cost by the states whatever the record's length: a two-step record on
    # the office is not estimated as nearly free (it was, at 2 s for minutes of work)
    short = estimate_cost(office, "learn", steps=2).seconds
    assert short > 0.5 * estimate_cost(office, "learn", steps=300).seconds
    # the horizon is about the run's: the window plus 3 x L's path (at least 20), the path in
    # cells (the run's counts L's turns too)
    from mirl.planning.observer import observer_model

    model = observer_model(office)
    path = int(model.distance_to_goal[model.start_state])
    assert planning_horizon(office) == pytest.approx(60 + max(20, 3 * path), rel=0.15)


def test_over_the_budget_is_one_line_naming_states_estimate_and_what_fits():
    office = load_scenario("office")
    est = estimate_cost(office, "run", steps=300)
    check_budget(office, est, est.memory)  # at the budget: fine
    with pytest.raises(CostError, match=r"3,804 states .*over the budget `max_memory`.*cells fits"):
        check_budget(office, est, est.memory - 1)
    assert default_max_memory() > 2**28


def test_the_cli_refuses_before_any_work(capsys):
    assert main(["run", "--scenario", "office", "--max-memory", "130M"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "over the budget --max-memory of 130 MB" in err[0]
    with pytest.raises(SystemExit):
        main(["run", "--max-memory", "lots"])
    assert "is not a size" in capsys.readouterr().err
