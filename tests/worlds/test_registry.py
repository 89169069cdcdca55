"""The table of worlds: its rows load classes that keep the contract's members, a row that
cannot work is refused where it is defined, names answer typos, and adding a world is one
module and one row (a toy world in fog, tests/worlds/foggy.py, run everywhere a world runs)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mirl._registry import Registry, UnknownNameError
from mirl.worlds import registry
from mirl.worlds.registry import (
    CONTRACT_MEMBERS,
    DEFAULT_WORLD,
    WORLDS,
    WorldSpec,
    check_row,
    get_world,
)

GRID = WORLDS["grid"]


def test_the_table_holds_the_grid_and_physics_worlds_by_entry_point():
    assert WORLDS.names[:2] == ("grid", "physics") and DEFAULT_WORLD in WORLDS
    assert GRID.load().__name__ == "GridRunWorld"
    for row in WORLDS.values():
        check_row(row)  # every row passed it when it was registered; still does


def test_a_typo_names_the_nearest_world():
    with pytest.raises(UnknownNameError, match="did you mean 'physics'.*known: grid, physics"):
        get_world("phisics")


@pytest.mark.parametrize(
    "change, needle",
    [
        ({"name": "Grid World"}, "lower-case letters"),
        ({"entry_point": "mirl.worlds.grid.GridRunWorld"}, "entry_point .* not 'package.module"),
        ({"drawing": "mirl.viz.runs:"}, "drawing .* not 'package.module"),
        ({"experiment_damage": 1.5}, r"experiment_damage 1.5 not in \[0, 1\]"),
        ({"requirement_extra": "physics"}, "requirement_extra without a requirement"),
        ({"requirement": "mujoco"}, "requirement 'mujoco' is not"),
        ({"description": " "}, "a description"),
        ({"section": "phyiscs"}, "unknown world section 'phyiscs' .did you mean 'physics'"),
    ],
)
def test_a_row_that_cannot_work_is_refused_where_it_is_defined(change, needle):
    with pytest.raises(ValueError, match=needle):
        Registry("world", [replace(GRID, **{"name": "other", **change})], check=check_row)


def test_a_class_without_the_contracts_members_is_refused_when_loaded():
    row = replace(GRID, name="broken", entry_point="mirl.simulation.grid:PatrolSimulator")
    with pytest.raises(TypeError, match="broken.*is not a world class .it has no "):
        row.load()
    assert all(hasattr(GRID.load(), m) for m in CONTRACT_MEMBERS)


# ---- adding a world ------------------------------------------------------------------------------
FOGGY = WorldSpec(
    "foggy", "tests.worlds.foggy:FoggyGridWorld", "the grid world in fog",
    damage="a transition feature's success probability", experiment_damage=0.7,
)  # fmt: skip


@pytest.fixture
def with_foggy(monkeypatch):
    """The table with one more row, as a world's author would write it."""
    table = Registry("world", [*WORLDS.values(), FOGGY], check=check_row)
    monkeypatch.setattr(registry, "WORLDS", table)
    return table


def test_adding_a_world_is_one_module_and_one_row(with_foggy, tmp_path):
    from mirl.envs import PenetrationEnv, TeamEnv
    from mirl.experiments.episode import run_episode
    from mirl.viz.runs import save_run_png
    from mirl.world.scenario import load_scenario
    from mirl.worlds import check_world

    check_world(with_foggy["foggy"])
    boyd2 = load_scenario("boyd2")
    fast = {"obs_steps": 60, "watch_until_seen": None, "max_wait": 20, "window": 10}
    foggy = run_episode(boyd2, "oracle", seed=1, world="foggy", observability=0.5, protocol=fast)
    clear = run_episode(boyd2, "oracle", seed=1, observability=0.5, protocol=fast)
    assert foggy.world == "foggy" and foggy.outcome in ("success", "detected", "timeout")
    # the same patrollers, seen through fog: some of the same sightings, while both watched
    t = min(foggy.observations.horizon, clear.observations.horizon)
    np.testing.assert_array_equal(foggy.true_states[:t], clear.true_states[:t])
    sightings = [
        {(int(a), int(b)) for a, b in zip(o.t, o.robot, strict=True) if a < t}
        for o in (foggy.observations, clear.observations)
    ]
    assert sightings[0] < sightings[1]
    assert save_run_png(boyd2, foggy, tmp_path / "run.png").stat().st_size > 10_000
    sim = get_world("foggy").load().simulate(boyd2, 200, seed=0, observability=1.0)
    assert sim.report[-1].startswith("fog: ") and 0 < len(sim.observations) < len(sim.truth)
    env = PenetrationEnv(boyd2, world="foggy", max_steps=5)
    env.reset(seed=0)
    assert env.step(3)[4]["t"] == 1
    team = TeamEnv(boyd2, world="foggy", max_cycles=5)
    team.reset(seed=0)
    assert team.step({"I": 0, "J": 0, "L": 3})[4]["L"]["t"] == 1


def test_the_command_line_simulates_the_added_world(with_foggy, capsys, tmp_path):
    from mirl.cli.commands import COMMANDS
    from mirl.cli.parser import build_parser

    args = build_parser().parse_args(
        ["simulate", "--scenario", "boyd2", "--steps", "50", "--observability", "1",
         "--observations", str(tmp_path / "o.csv")]
    )  # fmt: skip
    args.world = "foggy"  # the parser's --world choices were read when it was imported
    assert COMMANDS["simulate"](args) == 0
    out = capsys.readouterr().out
    assert "  fog: " in out and "sightings lost" in out
