"""Memory grows linearly with the number of states: peak traced memory of planning (and, in the
slow suite, of a whole run with learning) on generated offices of growing size, fitted as
memory ∝ states^k; k must stay ≤ 1.1 (docs/design.md, "Memory linear in the states").

The planning horizon grows with the office (3 × L's path), so a planner holding horizon ×
states arrays fits k ≈ 1.4–1.5 here."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from mirl.world.office_maps import office_map_from_name
from mirl.world.scenario import load_scenario

MAX_EXPONENT = 1.1


def office_scenario(side: int, tmp_path):
    """A generated side × side office patrolled by two robots paid for moving."""
    g = office_map_from_name(f"office-{side}x{side}-s1")
    hall = np.argwhere(g.patroller)
    a, b = hall[len(hall) // 3], hall[2 * len(hall) // 3]
    path = tmp_path / f"office{side}.toml"
    path.write_text(
        f'name = "office{side}"\nmap = "office-{side}x{side}-s1"\n[reward]\n'
        'features = [{ name = "moved", kind = "moved" }]\nweights = { moved = 1.0 }\n'
        f'[[robots]]\nname = "I"\nstart = [{a[0]}, {a[1]}, 0]\n'
        f'[[robots]]\nname = "J"\nstart = [{b[0]}, {b[1]}, 2]\n'
    )
    return load_scenario(path)


def _plan(scenario) -> None:
    from mirl.experiments.cost import planning_horizon
    from mirl.learning.results import oracle_models
    from mirl.planning.belief import UNSEEN, BeliefFilter
    from mirl.planning.go import solve_observer_mdp
    from mirl.planning.observer import observer_model

    model = observer_model(scenario)
    f = BeliefFilter(scenario.domain, oracle_models(scenario), joint=False)
    for _ in range(20):
        f.update([UNSEEN, UNSEEN])
    solve_observer_mdp(model, f.predict(planning_horizon(scenario), model), window=60)


def _run(scenario) -> None:
    from mirl.experiments.episode import run_episode

    run_episode(scenario, seed=0, protocol={"obs_steps": 300, "watch_until_seen": None})


def _exponent(work, sides, tmp_path) -> tuple[float, list[tuple[int, int]]]:
    rows = []
    for side in sides:
        scenario = office_scenario(side, tmp_path)
        assert scenario.domain.n_states > 0  # built before tracing: not what is measured
        tracemalloc.start()
        try:
            work(scenario)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        rows.append((scenario.domain.n_states, peak))
    states, peaks = np.log(np.array(rows, dtype=float)).T
    return float(np.polyfit(states, peaks, 1)[0]), rows


def test_planning_memory_is_linear_in_the_states(tmp_path):
    k, rows = _exponent(_plan, (30, 45, 60), tmp_path)
    assert k <= MAX_EXPONENT, f"planning memory ∝ states^{k:.2f}: {rows}"


@pytest.mark.slow
def test_run_memory_is_linear_in_the_states(tmp_path):
    k, rows = _exponent(_run, (20, 30, 40, 60), tmp_path)
    assert k <= MAX_EXPONENT, f"run memory ∝ states^{k:.2f}: {rows}"
