"""Worlds: where the patrollers move and L watches and goes — the grid simulator
(:mod:`mirl.worlds.grid`) or differential-drive robots in MuJoCo (:mod:`mirl.worlds.physics`).

Every world keeps one contract (:mod:`mirl.worlds.contract`): its class simulates a patrol,
reads its scenario section, applies damage, models its motion for L and names what its results
depend on; an instance is one run, stepped by :func:`~mirl.experiments.episode.run_episode` and
by the environments of :mod:`mirl.envs`. The table :data:`WORLDS` (:mod:`mirl.worlds.registry`)
names them; :func:`check_world` (:mod:`mirl.worlds.checker`) checks a world against the contract.
Adding a world is a module with its class and a row of the table.

This stage sits above the simulators and L's planner (a world builds L's moves on L's model)
and below the experiments and environments that step it. Reading the table imports no
simulator; ``check_world`` loads on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mirl.worlds.contract import (
    Detection,
    MeasuredPoses,
    RunSetup,
    RunWorld,
    Simulation,
    World,
    WorldExtras,
)
from mirl.worlds.registry import (
    DEFAULT_WORLD,
    WORLDS,
    WorldSpec,
    get_world,
    make_world,
)

__all__ = [
    "Detection",
    "MeasuredPoses",
    "RunSetup",
    "RunWorld",
    "Simulation",
    "World",
    "WorldExtras",
    "DEFAULT_WORLD",
    "WORLDS",
    "WorldSpec",
    "get_world",
    "make_world",
    "check_world",
    "WorldContractError",
]


def __getattr__(name: str) -> Any:
    # PEP 562: the checker imports numpy and L's planner, which the parser's table must not
    if name in ("check_world", "WorldContractError"):
        from mirl.worlds import checker

        return getattr(checker, name)
    raise AttributeError(f"module 'mirl.worlds' has no attribute {name!r}")


if TYPE_CHECKING:
    from mirl.worlds.checker import WorldContractError, check_world
