"""The table of worlds, :data:`WORLDS`: every world a run, a simulation, a sweep or an
environment can happen in, by name.

A row (:class:`WorldSpec`) names a world's class by an entry point (``"module:Class"``, as
gymnasium's registry does), so reading the table imports no simulator: the command line builds
its parser from it cheaply, and a world whose optional dependency is missing is refused in one
line when it is asked for, not when mirl starts. Its drawing is an entry point too, into
:mod:`mirl.viz`, which sits above this stage and is imported only when a run is drawn. A row
that cannot work is refused where the table is defined (:func:`check_row`); what only the class
can show is checked by :func:`mirl.worlds.check_world`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

from mirl._registry import Registry, check_entry_point, resolve
from mirl.world.world_sections import WORLD_SECTIONS
from mirl.worlds.contract import RunSetup, RunWorld, World

if TYPE_CHECKING:
    import numpy as np

    from mirl.planning.observer import ObserverModel
    from mirl.world.scenario import Scenario

__all__ = [
    "WorldSpec",
    "WORLDS",
    "DEFAULT_WORLD",
    "CONTRACT_MEMBERS",
    "check_row",
    "get_world",
    "make_world",
]

# what load() finds on a world's class before it returns it (the contract's class-level half)
CONTRACT_MEMBERS = (
    "takes_patroller_actions",
    "simulate",
    "read_section",
    "apply_damage",
    "healthy_value",
    "modelled",
    "damaged_parts",
    "version",
)


@dataclass(frozen=True)
class WorldSpec:
    """One row of the table of worlds.

    Parameters
    ----------
    name : str
        The name ``run_episode(world=...)``, the environments and ``--world`` take.
    entry_point : str
        ``"module:Class"`` of the world's class, a :class:`~mirl.worlds.contract.World`.
    description : str
        One line for ``--help``.
    damage : str
        What a damage value sets in this world (for ``--help`` and messages).
    experiment_damage : float
        The value the experiments give a damaged part in this world (the calibration of the
        fault verdicts, ``mirl experiment verdicts``), in [0, 1].
    requirement : str or None, default None
        ``"module:function"`` raising ImportError with a one-line message when the world's
        optional dependencies are missing; None when it has none.
    requirement_extra : str or None, default None
        The pip extra that installs them (``pip install "mirl[EXTRA]"``); only with a
        ``requirement``.
    records_poses : bool, default False
        Whether the world measures poses itself (L's camera), so that ``simulate`` writes its
        tracks (:attr:`Simulation.poses <mirl.worlds.contract.Simulation>`) instead of
        synthesising poses from grid states.
    drawing : str, default ``"mirl.viz.runs:draw_run"``
        ``"module:function"`` drawing a run of this world on a map panel,
        ``function(ax, scenario, result, **options) -> ax`` (``options``: ``context``, the
        steps drawn before L left); the grid drawing draws the run's grid trace.
    section : str or None, default None
        The world's own scenario section, one of
        :data:`~mirl.world.world_sections.WORLD_SECTIONS` (``"physics"``: ``[physics]``),
        read by the class's ``read_section``; None for a world without one.
    """

    name: str
    entry_point: str
    description: str
    damage: str
    experiment_damage: float
    requirement: str | None = None
    requirement_extra: str | None = None
    records_poses: bool = False
    drawing: str = "mirl.viz.runs:draw_run"
    section: str | None = None

    def check(self) -> None:
        """Raise ImportError (one line) when the world cannot run on this installation."""
        if self.requirement is not None:
            resolve(self.requirement)()

    def load(self) -> World:
        """The world's class, after :meth:`check`.

        Returns
        -------
        World
            The class named by ``entry_point``.

        Raises
        ------
        ImportError
            The world cannot run on this installation (one line, naming the extra to install).
        TypeError
            The entry point names something that lacks a member of the contract.
        """
        self.check()
        cls = resolve(self.entry_point)
        missing = [m for m in CONTRACT_MEMBERS if not hasattr(cls, m)]
        if not callable(cls) or missing:
            raise TypeError(
                f"world '{self.name}': {self.entry_point} is not a world class"
                + (f" (it has no {', '.join(missing)})" if missing else "")
            )
        return cast(World, cls)  # each world module assigns its class to a `World` for mypy


def _entry_point(value: str | None, what: str, row: str) -> None:
    check_entry_point(value, f"world '{row}': {what}")


def check_row(row: WorldSpec) -> None:
    """Refuse a row that cannot work.

    Run on every row as it is registered; imports nothing.

    Parameters
    ----------
    row : WorldSpec
        The row.

    Raises
    ------
    ValueError
        One line: a name that is not a usable ``--world`` value, an entry point that is not
        ``"module:name"``, a damage value outside [0, 1], a pip extra without the requirement it
        installs, or a scenario section the scenario format does not declare.
    """
    name = row.name
    if not name or not all(part.isalnum() for part in name.split("-")) or name != name.lower():
        raise ValueError(f"world '{name}': a name is lower-case letters, digits and '-'")
    for what, value in (("entry_point", row.entry_point), ("drawing", row.drawing)):
        _entry_point(value, what, name)
    if row.requirement is not None:
        _entry_point(row.requirement, "requirement", name)
    elif row.requirement_extra is not None:
        raise ValueError(f"world '{name}': requirement_extra without a requirement to check")
    if not 0.0 <= row.experiment_damage <= 1.0:
        raise ValueError(f"world '{name}': experiment_damage {row.experiment_damage} not in [0, 1]")
    if not row.description.strip() or not row.damage.strip():
        raise ValueError(f"world '{name}': a description and what damage sets are needed")
    if row.section is not None and row.section not in WORLD_SECTIONS:
        raise ValueError(
            f"world '{name}': {WORLD_SECTIONS.unknown(row.section)} (a world's section is "
            "declared in mirl.world.world_sections.WORLD_SECTIONS)"
        )


WORLDS: Registry[WorldSpec] = Registry(
    "world",
    [
        WorldSpec(
            "grid", "mirl.worlds.grid:GridRunWorld",
            "the grid simulator of the paper's simulations",
            damage="a transition feature's success probability",
            experiment_damage=0.7,  # the paper's damaged wheel
        ),
        WorldSpec(
            "physics", "mirl.worlds.physics:PhysicsRunWorld",
            "differential-drive robots in MuJoCo, seen through cameras",
            damage="a wheel motor's strength (1 = healthy)",
            experiment_damage=0.6,  # boyd2's weak motor
            requirement="mirl.physics:require_mujoco",
            requirement_extra="physics",
            records_poses=True,
            drawing="mirl.viz.physics_run:draw_physical_run",
            section="physics",
        ),
    ],
    check=check_row,
)  # fmt: skip
"""Every world by name."""

DEFAULT_WORLD = "grid"


def get_world(name: str) -> WorldSpec:
    """The row of world ``name``.

    Parameters
    ----------
    name : str
        A world's name.

    Returns
    -------
    WorldSpec
        The row.

    Raises
    ------
    UnknownNameError
        A ValueError naming the nearest and the known worlds.
    """
    return WORLDS.lookup(name)


def make_world(
    name: str,
    scenario: Scenario,
    observer: ObserverModel,
    *,
    observability: float,
    seed: int,
    noise: np.random.SeedSequence,
) -> RunWorld:
    """A new world ``name`` for one run.

    Parameters
    ----------
    name : str
        A world's name.
    scenario : Scenario
        The patrollers, their true models and L's map.
    observer : ObserverModel
        L's model.
    observability : float
        The degree of L's view from its room.
    seed : int
        Seeds the patrollers' world.
    noise : numpy.random.SeedSequence
        Seeds L's own action failures where the world draws them.

    Returns
    -------
    RunWorld
        The world, at step 0 (see :class:`~mirl.worlds.contract.RunSetup`).

    Raises
    ------
    UnknownNameError
        An unknown world.
    ImportError
        A world that cannot run on this installation.
    """
    return get_world(name).load()(RunSetup(scenario, observer, observability, seed, noise))
