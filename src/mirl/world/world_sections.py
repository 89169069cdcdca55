"""The scenario sections that belong to one world (``[physics]``): which top-level tables a
scenario file may carry for a world, declared here so that a file is checked when it is loaded
(a misspelt table is refused then, not run as if absent) and a world's row names its section
(:data:`mirl.worlds.WORLDS`). The module imports nothing heavy: the table of worlds, which the
command line reads at start-up, checks its rows against it."""

from __future__ import annotations

from dataclasses import dataclass

from mirl._registry import Registry

__all__ = ["WorldSection", "WORLD_SECTIONS"]


@dataclass(frozen=True)
class WorldSection:
    """A top-level table of a scenario that belongs to one world (``[physics]``): the scenario
    keeps it as written (:meth:`Scenario.section <mirl.world.scenario.Scenario.section>`) and
    that world reads it (:meth:`mirl.worlds.contract.World.read_section`).

    Parameters
    ----------
    name : str
        The table's name in the TOML file, the world's ``section`` in :data:`mirl.worlds.WORLDS`.
    holds : str
        What the table sets, for messages and documentation.
    """

    name: str
    holds: str


def _check_section(row: WorldSection) -> None:
    if not row.name.isidentifier():
        raise ValueError(f"world section '{row.name}': not a TOML bare key of letters and '_'")


# The worlds sit above this stage and cannot be asked; a world's row names its section here and
# is refused if it is not declared (docs/design.md, "The world interface").
WORLD_SECTIONS: Registry[WorldSection] = Registry(
    "world section",
    [WorldSection("physics", "the physical world's parameters (mirl.physics.config)")],
    check=_check_section,
)
"""Every world's own scenario section, by name."""
