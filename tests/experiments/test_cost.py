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


def test_a_stray_late_row_is_a_long_learn_said_before_it_starts(tmp_path, capsys, monkeypatch):
    """One row at t = 100 000 after a 450-step record makes the record 100 001 steps long, which
    takes minutes to learn on boyd2 (0.9 ms a step measured) where the estimate said 3 s. The
    estimate now counts the per-step work, says the wait before any work, in one warning that
    names the file, the span and the rows' times; the record's own 450 steps say nothing."""
    import mirl.learning.learn as learning

    obs = tmp_path / "obs.csv"
    assert main(["simulate", "--scenario", "boyd2", "--steps", "450", "--seed", "1",
                 "--observations", str(obs)]) == 0  # fmt: skip
    late = tmp_path / "late.csv"
    late.write_text(obs.read_text() + "100000,I,0,4,2\n")
    assert estimate_cost(load_scenario("boyd2"), "learn", steps=100_001).seconds > 100
    capsys.readouterr()

    class Stop(Exception):
        pass

    def stop(*args, **kwargs):
        raise Stop

    monkeypatch.setattr(learning, "learn", stop)  # the warning comes before any learning
    with pytest.raises(Stop):
        main(["learn", "--scenario", "boyd2", "--observations", str(late)])
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"mirl: warning: {late}: learning a record")
    assert "100,001 steps" in err[0] and "to 100000" in err[0] and "min" in err[0]
    with pytest.raises(Stop):
        main(["learn", "--scenario", "boyd2", "--observations", str(obs)])
    assert capsys.readouterr().err == ""
