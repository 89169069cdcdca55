"""The contract every world implements: :class:`World`, what its class does, and
:class:`RunWorld`, what one of its instances does during a run.

A *world* is where the patrollers move and L watches and then goes: the grid simulator
(:mod:`mirl.worlds.grid`) or the MuJoCo physics (:mod:`mirl.worlds.physics`). Its class is
built from a :class:`RunSetup` into a :class:`RunWorld`, which
:func:`~mirl.experiments.episode.run_episode` and the environments of :mod:`mirl.envs` step;
the class itself also simulates a patrol for ``mirl simulate`` (:meth:`World.simulate`), reads
its own scenario section (:meth:`World.read_section`), says what a damage value means in it
(:meth:`World.apply_damage`), how L models its motion (:meth:`World.modelled`), which parts are
really damaged (:meth:`World.damaged_parts`) and what its results depend on besides mirl
(:meth:`World.version`). Both halves are :class:`typing.Protocol` classes: each world module
assigns its class to a variable of type :class:`World`, so mypy checks the class (and, through
``__call__``, its instances) against the contract, and :func:`mirl.worlds.check_world` checks
what a type cannot: shapes, ranges and determinism by seed.

The module imports nothing at run time beyond the standard library, so the table of worlds
(:mod:`mirl.worlds.registry`) that names it stays cheap to read.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import numpy as np

    from mirl.observations.poses import PoseTracks
    from mirl.observations.trajectories import Trajectories
    from mirl.planning.observer import ObserverModel
    from mirl.world.scenario import Scenario

__all__ = [
    "Detection",
    "RunSetup",
    "WorldExtras",
    "RunWorld",
    "MeasuredPoses",
    "Simulation",
    "World",
]


@dataclass(frozen=True)
class Detection:
    """A patroller seeing L.

    Parameters
    ----------
    t : int
        The step.
    robot : str
        The patroller's name.
    robot_state : (int, int, int)
        Its (row, col, heading).
    observer_cell : (int, int)
        L's cell.
    """

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
    """What a world records beyond the contract (the physics world's contacts, its MuJoCo
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

    def notes(self) -> tuple[str, ...]:
        """What the run report says of the world's run beyond its truth, one line each (a run
        outside what the world's calibration measured)."""
        ...


class RunWorld(Protocol):
    """A world as a run sees it: the patrollers moving, L watching from its room, then L moving.

    Time advances in decision steps. ``seen[t]`` and ``true[t]`` hold, per patroller, the state
    index L saw at step ``t`` (-1: not seen) and the patroller's true state; both hold step 0
    from the start, so after ``k`` steps they have ``k + 1`` entries.
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

    def step(
        self, observer_action: int | None = None, *, patroller_actions: np.ndarray | None = None
    ) -> np.ndarray:
        """Advance one step.

        Parameters
        ----------
        observer_action : int, optional
            L's action, an index into :data:`mirl.world.domain.ACTIONS`; None: L stands still (and
            draws no failure).
        patroller_actions : ndarray of int, shape (N,), optional
            The patrollers' actions, each taken through the robot's true transition function
            (no policy, no game at meetings: the agents of :class:`mirl.envs.TeamEnv` choose);
            None: they follow their true policies.

        Returns
        -------
        ndarray of int, shape (N,)
            The patrollers' true states at the new step.

        Raises
        ------
        NotImplementedError
            ``patroller_actions`` given to a world whose class has
            ``takes_patroller_actions = False``; nothing moves.
        """
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
        """What this world records beyond the contract, for the run's record."""
        ...


@dataclass(frozen=True)
class MeasuredPoses:
    """The poses a world measures itself while it simulates (its camera's), with the truth.

    Parameters
    ----------
    observed : PoseTracks
        What L's sensor measured: one pose per seen patroller per step.
    true : PoseTracks
        Every robot's true pose (L's too, as robot ``L``) at ``true_rate_hz``.
    true_rate_hz : float
        The rate of the true poses.
    """

    observed: PoseTracks
    true: PoseTracks
    true_rate_hz: float


@dataclass(frozen=True)
class Simulation:
    """What :meth:`World.simulate` records of ``steps`` steps of patrol with L in its room.

    Parameters
    ----------
    observations : Trajectories
        What L saw, on the grid (t = 0 … steps − 1).
    truth : Trajectories
        Every patroller's true grid trajectory.
    observability : float
        The degree of L's view the simulation used.
    conditions : str, default ""
        What the world ran with that the scenario's grid model does not say, for the summary's
        first line (the physics world: its motor strengths); "" for nothing.
    step_seconds : float or None, default None
        Seconds of simulated time per step, for a world that simulates time within a step (its
        real-time factor is then reported); None for a world whose steps are decisions only.
    report : tuple of str, default ()
        The world's own counts, one line each (the grid: the patrollers' meetings; physics:
        contact events).
    poses : MeasuredPoses or None, default None
        The poses the world measured itself; None for a world without poses (``mirl simulate
        --poses`` then synthesises poses from ``observations``).
    """

    observations: Trajectories
    truth: Trajectories
    observability: float
    conditions: str = ""
    step_seconds: float | None = None
    report: tuple[str, ...] = ()
    poses: MeasuredPoses | None = None

    @property
    def steps(self) -> int:
        """The steps simulated."""
        return int(self.truth.horizon)

    def observed_share(self) -> np.ndarray:
        """Per patroller, the share of steps at which L saw it.

        Returns
        -------
        ndarray of shape (N,)
            Shares in [0, 1].
        """
        import numpy as np

        counts = np.bincount(self.observations.robot, minlength=len(self.truth.robot_names))
        return counts / max(self.steps, 1)


class World(Protocol):
    """A world's class, as :meth:`WorldSpec.load <mirl.worlds.registry.WorldSpec.load>`
    returns it: constructed from a :class:`RunSetup` into a :class:`RunWorld`, and the
    class-level half of the contract below (static methods or class methods)."""

    takes_patroller_actions: bool
    """Whether :meth:`RunWorld.step` takes ``patroller_actions`` (the team environment needs
    it)."""

    def __call__(self, setup: RunSetup) -> RunWorld:
        """A new world for one run."""
        ...

    def simulate(
        self,
        scenario: Scenario,
        steps: int,
        *,
        seed: int,
        observability: float | None = None,
        heading_noise: float = 0.0,
        random_starts: bool = False,
    ) -> Simulation:
        """``steps`` steps (t = 0 … steps − 1) of the patrollers following their true policies, L
        watching from its room; ``mirl simulate``.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        steps : int
            Steps to record, at least 1.
        seed : int
            Seeds the simulation; the same arguments give the same simulation.
        observability : float, optional
            The fraction of the hallway L sees; the scenario's by default.
        heading_noise : float, default 0.0
            The probability that L misreads an observed heading, for a world whose perception is a
            grid reading; a world with a sensor of its own refuses a nonzero value.
        random_starts : bool, default False
            Start each patroller at a random state of its patrol cycle instead of its scenario
            start.

        Returns
        -------
        Simulation
            What L saw and the truth.

        Raises
        ------
        ValueError
            A nonzero ``heading_noise`` in a world with a sensor of its own, or fewer than one step.
        """
        ...

    def read_section(self, scenario: Scenario) -> object:
        """The world's own parameters from its scenario section, validated.

        The section is a table of :data:`~mirl.world.world_sections.WORLD_SECTIONS`.

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        object
            The parameters; None for a world without a section.

        Raises
        ------
        ValueError
            A bad table, in one line naming the file and the field.
        """
        ...

    def apply_damage(self, scenario: Scenario, robot: str, feature: str, value: float) -> Scenario:
        """The scenario with ``robot``'s ``feature`` damaged to ``value``.

        What ``--damage ROBOT:FEATURE=VALUE`` means in this world.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        robot : str
            A patroller's name.
        feature : str
            The part to damage.
        value : float
            Its damaged level.

        Returns
        -------
        Scenario
            The damaged scenario.

        Raises
        ------
        ValueError
            A robot, feature or value the world does not have.
        """
        ...

    def healthy_value(self, scenario: Scenario, feature: str) -> float:
        """The value ``--damage ROBOT:FEATURE=VALUE`` takes for an undamaged ``feature``.

        What a part of a robot the scenario leaves alone has in this world: a sweep that states
        all of a point's damage heals a scenario's damaged part to it.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        feature : str
            The part.

        Returns
        -------
        float
            The healthy value (:meth:`apply_damage`'s scale).
        """
        ...

    def modelled(self, scenario: Scenario) -> Scenario:
        """The scenario as L models this world.

        The ξ, error model and damage definition its learner, filter and planner use. The
        patrollers' true policies are the scenario's.

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        Scenario
            The scenario as modelled.
        """
        ...

    def damaged_parts(self, scenario: Scenario) -> dict[str, tuple[str, ...]]:
        """Per robot (every one of the scenario's), the parts that are really damaged in this world.

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        dict of str to tuple of str
            Robot name -> damaged parts (empty: none).
        """
        ...

    def version(self) -> str:
        """What, besides mirl, this world's results depend on, recorded beside every sweep row.

        Returns
        -------
        str
            "" for nothing.
        """
        ...
