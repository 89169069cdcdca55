"""The worlds a run can happen in: one interface every world implements, and the table of them.

A *world* is where the patrollers move and L watches and then goes: the grid simulator
(:mod:`mirl.experiments.grid_world`) or the MuJoCo physics (:mod:`mirl.experiments.physics_world`).
:func:`~mirl.experiments.episode.run_episode` drives any of them through :class:`RunWorld`,
and the sweep, the command line and the reports learn what they need of a world from its row
of :data:`WORLDS`. Adding a world is a module with a class implementing :class:`RunWorld` and a
row here.

The table names each world's class by an entry point (``"module:Class"``, as gymnasium's
registry does), so reading the table imports no simulator: the command line builds its parser
from it cheaply, and a world whose optional dependency is missing is refused in one line when it
is asked for, not when mirl starts.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from importlib import import_module
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import numpy as np

    from mirl.planning.observer import ObserverModel
    from mirl.world.scenario import Scenario

__all__ = [
    "Detection",
    "RunSetup",
    "RunWorld",
    "WorldExtras",
    "WorldSpec",
    "WORLDS",
    "DEFAULT_WORLD",
    "get_world",
    "make_world",
]


@dataclass(frozen=True)
class Detection:
    """A patroller seeing L: time, robot, the robot's (row, col, heading) and L's cell."""

    t: int
    robot: str
    robot_state: tuple[int, int, int]
    observer_cell: tuple[int, int]


@dataclass(frozen=True)
class RunSetup:
    """What a world is built from for one run.

    Parameters
    ----------
    scenario : Scenario
        The patrollers, their true models and L's map.
    observer : ObserverModel
        L's model: its start, goal, moves, action failure probability and who can see it.
    observability : float
        The degree of L's view from its room.
    seed : int
        Seeds the patrollers' world (random starts on their patrol cycles, outcomes).
    noise : numpy.random.SeedSequence
        Seeds L's own action failures where the world draws them, a stream apart from the
        patrollers'.
    """

    scenario: Scenario
    observer: ObserverModel
    observability: float
    seed: int
    noise: np.random.SeedSequence


class WorldExtras(Protocol):
    """What a world records beyond the interface (the physics world's contacts, its MuJoCo
    version and its continuous tracks); kept in :attr:`RunResult.extras
    <mirl.experiments.records.RunResult>`."""

    def to_dict(self) -> dict[str, Any]:
        """The extras' entries in a run's JSON record."""
        ...

    def truth(self) -> str | None:
        """What is really damaged in this world, for the run report (None: the scenario's)."""
        ...

    def damaged(self) -> bool | None:
        """Whether some part is really damaged in this world (None: as in the scenario)."""
        ...


class RunWorld(Protocol):
    """A world as a run sees it: the patrollers moving, L watching from its room, then L moving.

    Time advances in decision steps. ``seen[t]`` and ``true[t]`` hold, per patroller, the state
    index L saw at step ``t`` (-1: not seen) and the patroller's true state.
    """

    visible: np.ndarray
    """(S,) bool: the patroller states L can see from its room."""
    seen: list[np.ndarray]
    """Per step so far, (N,) int: the state L saw of each patroller (-1 unseen)."""
    true: list[np.ndarray]
    """Per step so far, (N,) int: each patroller's true state."""
    seen_lateral: list[np.ndarray] | None
    """Per step so far, (N,) float: how far across its heading L saw each patroller from its
    cell's centre line (cells, left positive; NaN unseen); None in a world without poses
    (:attr:`mirl.observations.trajectories.Trajectories.lateral`)."""

    @property
    def t(self) -> int:
        """The current step."""
        ...

    def step(self, observer_action: int | None = None) -> np.ndarray:
        """Advance one step: the patrollers move, and L takes ``observer_action`` (an index
        into :data:`mirl.world.domain.ACTIONS`) or stands still (None); returns the
        patrollers' true states at the new step."""
        ...

    def observer_state(self) -> int:
        """L's state in its own model's domain, as L knows it (its plan acts on this)."""
        ...

    def detections(self) -> list[Detection]:
        """The patrollers that saw L during the last step (empty: none)."""
        ...

    def at_goal(self) -> bool:
        """Whether L has reached its goal."""
        ...

    def extras(self) -> WorldExtras | None:
        """What this world records beyond the interface, for the run's record."""
        ...


@dataclass(frozen=True)
class WorldSpec:
    """One row of the table of worlds.

    Parameters
    ----------
    name : str
        The name ``run_episode(world=...)`` and ``--world`` take.
    entry_point : str
        ``"module:Class"`` of the class implementing :class:`RunWorld`. It is constructed from
        a :class:`RunSetup` (``Class(setup)``) and also provides
        ``apply_damage(scenario, robot, feature, value)`` (what a ``--damage`` value means there),
        ``modelled(scenario)`` (the scenario as L models that world: the ξ its motion has),
        ``damaged_parts(scenario)`` (per robot, the parts that are really damaged there) and
        ``version()`` (what, besides mirl, its results depend on; "" for nothing).
    description : str
        One line for ``--help``.
    damage : str
        What a damage value sets in this world (for ``--help`` and messages).
    experiment_damage : float
        The value the experiments give a damaged part in this world (the calibration of the
        fault verdicts, ``mirl experiment verdicts``).
    requirement : str or None
        ``"module:function"`` raising ImportError with a one-line message when the world's
        optional dependencies are missing; None when it has none.
    requirement_extra : str or None
        The pip extra that installs them (``pip install "mirl[EXTRA]"``).
    records_poses : bool
        Whether the world measures poses itself (L's camera), so that ``simulate`` writes
        its tracks instead of synthesising poses from grid states.
    """

    name: str
    entry_point: str
    description: str
    damage: str
    experiment_damage: float
    requirement: str | None = None
    requirement_extra: str | None = None
    records_poses: bool = False

    def check(self) -> None:
        """Raise ImportError (one line) when the world cannot run on this installation."""
        if self.requirement is not None:
            _resolve(self.requirement)()

    def load(self) -> Any:
        """The world's class, after :meth:`check`."""
        self.check()
        return _resolve(self.entry_point)


def _resolve(entry_point: str) -> Callable[..., Any]:
    module, _, attr = entry_point.partition(":")
    return getattr(import_module(module), attr)  # type: ignore[no-any-return]


_ROWS = (
    WorldSpec(
        "grid", "mirl.experiments.grid_world:GridRunWorld",
        "the grid simulator of the paper's simulations",
        damage="a transition feature's success probability",
        experiment_damage=0.7,  # the paper's damaged wheel
    ),
    WorldSpec(
        "physics", "mirl.experiments.physics_world:PhysicsRunWorld",
        "differential-drive robots in MuJoCo, seen through cameras",
        damage="a wheel motor's strength (1 = healthy)",
        experiment_damage=0.6,  # boyd2's weak motor
        requirement="mirl.physics:require_mujoco",
        requirement_extra="physics",
        records_poses=True,
    ),
)  # fmt: skip

WORLDS: dict[str, WorldSpec] = {w.name: w for w in _ROWS}
"""Every world by name."""

DEFAULT_WORLD = "grid"


def get_world(name: str) -> WorldSpec:
    """The row of world ``name``; a ValueError naming the known worlds otherwise."""
    if name not in WORLDS:
        raise ValueError(f"unknown world '{name}' (known: {', '.join(WORLDS)})")
    return WORLDS[name]


def make_world(
    name: str,
    scenario: Scenario,
    observer: ObserverModel,
    *,
    observability: float,
    seed: int,
    noise: np.random.SeedSequence,
) -> RunWorld:
    """A new world ``name`` for one run (the arguments are those of :class:`RunSetup`)."""
    cls = get_world(name).load()
    world: RunWorld = cls(RunSetup(scenario, observer, observability, seed, noise))
    return world
