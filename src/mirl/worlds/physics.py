"""The physical world: the same contract as the grid's with
:class:`mirl.physics.patrol.PhysicalWorld` in place of the grid simulator.

Only the world changes. L learns from what its camera saw (discretised pose measurements) and
plans on the grid with the unchanged code; then it *drives* its time-indexed plan with the same
controller as the patrollers: each decision step it discretises its own estimated pose, takes
the plan's action there and the controller drives. The patrollers' cameras watch for it at
10 Hz once it is out of its room. L has reached its goal when its true centre is inside the goal
cell; it is detected when a patroller's camera saw it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mirl.physics import mujoco_version
from mirl.physics.calibration import damaged_wheels
from mirl.physics.config import (
    PHYSICAL_ERROR_MODEL,
    PhysicsConfig,
    physical_feature_map,
    scenario_physics,
    with_motor_strength,
)
from mirl.physics.patrol import PhysicalWorld
from mirl.physics.robot import KOBUKI
from mirl.world.scenario import Scenario
from mirl.worlds.contract import (
    Detection,
    MeasuredPoses,
    RunSetup,
    Simulation,
    World,
)

__all__ = ["PhysicsRunWorld", "PhysicsExtras"]


@dataclass(frozen=True)
class PhysicsExtras:
    """What a physics run records beyond the contract.

    Parameters
    ----------
    world : PhysicalWorld
        The MuJoCo world itself (continuous tracks, cameras, contacts).
    mujoco : str
        The MuJoCo release that computed it.
    """

    world: PhysicalWorld
    mujoco: str

    def to_dict(self) -> dict[str, Any]:
        """The extras' entries in a run's JSON record.

        Returns
        -------
        dict
            ``world``, ``mujoco``, ``contacts``, ``wall_contacts`` and ``notes``.
        """
        return {
            "world": "physics",
            "mujoco": self.mujoco,
            "contacts": self.world.contacts,
            "wall_contacts": self.world.wall_contacts,
            "notes": list(self.notes()),
        }

    def truth(self) -> str:
        """The motor strengths the robots drive with.

        The scenario's grid probabilities are only what it would mean on the grid, not what L
        watches.

        Returns
        -------
        str
            ``physics, motor strength: …`` naming every weakened motor.
        """
        strengths = self.world.cfg.motor_strength
        weak = [f"{r}:{w}={s:g}" for r, ws in strengths.items() for w, s in ws.items() if s < 1]
        return f"physics, motor strength: {', '.join(weak) or 'all motors healthy'}"

    def notes(self) -> tuple[str, ...]:
        """The run outside the cells the world is calibrated on, if it is
        (:func:`out_of_calibration`).

        Returns
        -------
        tuple of str
            The note, or nothing.
        """
        return world_notes(self.world)

    def damaged(self) -> bool:
        """Whether some motor is weaker than a healthy one.

        Returns
        -------
        bool
            True if some strength is below 1.
        """
        strengths = self.world.cfg.motor_strength
        return any(s < 1 for ws in strengths.values() for s in ws.values())


CALIBRATED_CELL = 0.9
"""Metres: cells narrower than this are outside what the world's calibration measured (1 m
cells). With robots 0.354 m across, boyd2-healthy at 0.75 m cells touched walls 0.23–0.34 times a
robot-step against 0.01–0.02 at 1 m (two seeds each, 450 steps); on a real map at 0.4–0.5 m cells
healthy robots wedged or scraped and their records read as damaged ones'."""
WALL_CONTACTS_NOTED = 0.1
"""Wall contacts per robot and step above which a run is noted, whatever the cell size: three
times the most measured on the shipped 1 m cells (boydright-3, 300 steps, 0.033; boyd2-healthy
0.01–0.02)."""


def out_of_calibration(scenario: Scenario, wall_contacts: int, robot_steps: int) -> tuple[str, ...]:
    """A note when the simulation is outside what the world's calibration measured: cells
    narrower than :data:`CALIBRATED_CELL`, or robots that touched walls more than
    :data:`WALL_CONTACTS_NOTED` times a robot-step. The controller drives a robot to its cell's
    centre, so in a narrow cell beside a wall a robot touches or wedges against it, and its
    steps there fail by contact, not by its motors: a record whose failures a healthy robot's
    verdict then blames on its parts.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    wall_contacts : int
        The simulation's contacts between a robot and a wall.
    robot_steps : int
        Robots × steps simulated.

    Returns
    -------
    tuple of str
        The note in one line, or nothing.
    """
    cell = scenario.map.frame.cell_size
    many = robot_steps > 0 and wall_contacts > WALL_CONTACTS_NOTED * robot_steps
    if cell >= CALIBRATED_CELL and not many:
        return ()
    return (
        f"robots {2 * KOBUKI.base_radius:g} m across in {cell:g} m cells touched walls "
        f"{wall_contacts} times in {robot_steps} robot-steps; the world is calibrated on 1 m "
        "cells, and where a robot touches or wedges against a wall its steps fail by contact, "
        "not by its motors, which a verdict on its record cannot tell from damage",
    )


def world_notes(world: PhysicalWorld) -> tuple[str, ...]:
    """:func:`out_of_calibration` of a world after its steps so far (step 0 included).

    Parameters
    ----------
    world : PhysicalWorld
        The world.

    Returns
    -------
    tuple of str
        The note, or nothing.
    """
    return out_of_calibration(world.scenario, world.wall_contacts, world.n * (world.t + 1))


def _strengths(cfg: PhysicsConfig) -> str:
    """The motor strengths the scenario sets, as ``physics: I:left_wheel=0.6, ...``."""
    given = [f"{r}:{w}={s:g}" for r, ws in cfg.motor_strength.items() for w, s in ws.items()]
    return f"physics: {', '.join(given) or 'all motors healthy'}"


class PhysicsRunWorld:
    """A :class:`~mirl.physics.patrol.PhysicalWorld` behind the world contract.

    Parameters
    ----------
    setup : RunSetup
        As for the grid world; its ``noise`` stream is unused, since L's failures here are
        physical.
    """

    takes_patroller_actions = False  # the patrollers drive by their policies and the game

    def __init__(self, setup: RunSetup) -> None:
        scenario, observer = setup.scenario, setup.observer
        start_heading = int(observer.domain.states[observer.start_state][2])
        self.physics = PhysicalWorld(
            scenario,
            observability=setup.observability,
            seed=setup.seed,
            random_starts=True,
            observer_heading=start_heading,
        )
        self.visible = self.physics.visible
        self.domain = scenario.domain
        self.names = scenario.robot_names
        self.observer = observer
        self.true = self.physics.true
        self.seen = self.physics.seen
        self.seen_lateral: list[np.ndarray] | None = self.physics.records.seen_lateral
        self._observer_state = observer.start_state
        self._sightings_before = 0
        goal = observer.domain.states[np.flatnonzero(observer.goal)]
        self._goal_cells = {(int(r), int(c)) for r, c, _ in goal}

    # ---- the class-level half of the contract ------------------------------------------------
    @staticmethod
    def simulate(
        scenario: Scenario,
        steps: int,
        *,
        seed: int,
        observability: float | None = None,
        heading_noise: float = 0.0,
        random_starts: bool = False,
    ) -> Simulation:
        """The patrollers in MuJoCo with L's camera at its door (L stands still).

        Its grid record, contact events, and the poses the camera measured with the true ones at the
        control rate.

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
            The observations, truth, contacts and measured poses.

        Raises
        ------
        ValueError
            A nonzero ``heading_noise`` (L's camera measures headings with its own noise), or fewer
            than one step.
        """
        if heading_noise:
            raise ValueError(
                "`heading_noise` applies to the grid world's perception; the physics world's "
                "camera measures headings with its own noise ([physics] measurement_sigma_deg)"
            )
        if steps < 1:
            raise ValueError(f"steps must be at least 1, got {steps}")
        world = PhysicalWorld(
            scenario, observability=observability, seed=seed, random_starts=random_starts
        )
        for _ in range(steps - 1):
            world.step()
        cfg = world.cfg
        poses = MeasuredPoses(world.observed_tracks(), world.true_tracks(), cfg.control_hz)
        contacts = f"contacts: {world.contacts} between robots, {world.wall_contacts} with walls"
        notes = tuple(f"note: {n}" for n in world_notes(world))
        return Simulation(
            world.observations(), world.truth(), world.degree, conditions=_strengths(cfg),
            step_seconds=cfg.step_seconds, report=(contacts, *notes), poses=poses,
        )  # fmt: skip

    @staticmethod
    def read_section(scenario: Scenario) -> PhysicsConfig:
        """The scenario's ``[physics]`` table, validated.

        By :func:`~mirl.physics.config.physics_config`.

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        PhysicsConfig
            The physical parameters.

        Raises
        ------
        ValueError
            A bad table, naming the file and the field.
        """
        return scenario_physics(scenario)

    @staticmethod
    def apply_damage(scenario: Scenario, robot: str, feature: str, value: float) -> Scenario:
        """The scenario with ``robot``'s ``feature`` wheel motor at strength ``value``.

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
            :func:`~mirl.physics.config.with_motor_strength`'s copy.

        Raises
        ------
        ValueError
            An unknown robot, a part that is not a wheel, or a strength outside [0, 1].
        """
        return with_motor_strength(scenario, robot, feature, value)

    @staticmethod
    def healthy_value(scenario: Scenario, feature: str) -> float:
        """Full strength: the motor of a robot the scenario leaves alone.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        feature : str
            The part (a wheel).

        Returns
        -------
        float
            1.
        """
        return 1.0

    @staticmethod
    def modelled(scenario: Scenario) -> Scenario:
        """The scenario as L models this world.

        Its ξ with the wheels taken out of the turns, which a weak motor still drives in time
        (:func:`~mirl.physics.config.physical_feature_map`); failed steps that stay put
        (:data:`~mirl.physics.config.PHYSICAL_ERROR_MODEL`); and a weak wheel drifting its robot by
        the world's measured κ (``PhysicsConfig.drift_per_gap``) unless the scenario's ``[faults]``
        table states one. The patrollers' true policies are the scenario's, which they follow here.

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        Scenario
            The scenario as modelled.
        """
        faults = scenario.faults
        if faults.drift.per_gap is None:
            cfg = scenario_physics(scenario)
            drift = replace(faults.drift, per_gap=cfg.drift_per_gap, spread=cfg.drift_spread)
            faults = replace(faults, drift=drift)
        return scenario.modelled_with(
            physical_feature_map(scenario.feature_map), faults, PHYSICAL_ERROR_MODEL
        )

    @staticmethod
    def damaged_parts(scenario: Scenario) -> dict[str, tuple[str, ...]]:
        """Per robot, the wheels damaged by their effect, as on the grid.

        A wheel is damaged when its motor is weak enough that the wheel's success probability,
        measured in this world, lies below its healthy level by more than the margin
        (:func:`~mirl.physics.calibration.damaged_wheels`); a motor weaker than a full one that
        still drives the robot's steps is weakened, not damaged.

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        dict of str to tuple of str
            Robot name -> damaged wheels.
        """
        return damaged_wheels(scenario)

    @staticmethod
    def version() -> str:
        """Physics results depend on MuJoCo's release (the same seed gives other trajectories under
        another one).

        Returns
        -------
        str
            ``mujoco.`` and the release.
        """
        return f"mujoco.{mujoco_version()}"

    # ---- one run ----------------------------------------------------------------------------
    @property
    def t(self) -> int:
        """The current step."""
        return self.physics.t

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
            ``patroller_actions`` given: the physics world's patrollers drive by their true policies
            and the game.
        """
        if patroller_actions is not None:
            raise NotImplementedError(
                "the physics world's patrollers drive by their true policies and the game; it "
                "takes no `patroller_actions`"
            )
        self._sightings_before = len(self.physics.sightings)
        truth = self.physics.step(observer_action)
        if observer_action is not None:
            r, c, h = self.physics.observer_cell_heading(estimated=True)
            estimate = int(self.observer.domain.state_index(r, c, h))
            if estimate >= 0:
                self._observer_state = estimate
            else:  # off L's map: where it meant to be
                s = self._observer_state
                self._observer_state = int(self.observer.domain.intended[s, observer_action])
        return truth

    def observer_state(self) -> int:
        """L's state in its own model's domain, as L knows it (its plan acts on this).

        Returns
        -------
        int
            The state index.
        """
        return self._observer_state

    def detections(self) -> list[Detection]:
        """The patrollers that saw L during the last step.

        Returns
        -------
        list of Detection
            Empty: none did.
        """
        if len(self.physics.sightings) <= self._sightings_before:
            return []
        sighting = self.physics.sightings[self._sightings_before]
        lr, lc, _ = self.physics.observer_cell_heading(estimated=False)
        rr, rc, rh = map(int, self.domain.states[self.true[-1][sighting.robot]])
        return [Detection(self.t, self.names[sighting.robot], (rr, rc, rh), (int(lr), int(lc)))]

    def at_goal(self) -> bool:
        """Whether L has reached its goal.

        Returns
        -------
        bool
            True on the goal.
        """
        r, c, _ = self.physics.observer_cell_heading(estimated=False)
        return (int(r), int(c)) in self._goal_cells

    def extras(self) -> PhysicsExtras:
        """The MuJoCo world and release, for the run's record.

        Returns
        -------
        PhysicsExtras
            The extras.
        """
        return PhysicsExtras(self.physics, mujoco_version())


_CONTRACT: World = PhysicsRunWorld  # mypy checks the class (and its instances) against the contract
