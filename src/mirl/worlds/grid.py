"""The grid world of the paper's simulations: the patrollers in a
:class:`~mirl.simulation.grid.PatrolSimulator`, L watching at an observability degree, and L
moving on its own grid once it goes — each of its actions fails (it stays put) with its model's
failure probability — seen by the scenario's detection rule."""

from __future__ import annotations

import numpy as np

from mirl.simulation.grid import PatrolSimulator, simulate
from mirl.world.faults import DEFAULT_HEALTHY
from mirl.world.scenario import Scenario
from mirl.worlds.contract import Detection, RunSetup, Simulation, World

__all__ = ["GridRunWorld"]


class GridRunWorld:
    """The grid simulator plus L's record of it and L's own moves; one instance per run.

    Parameters
    ----------
    setup : RunSetup
        The scenario, L's model, L's view, the patrollers' seed and L's failure stream.
    """

    takes_patroller_actions = True

    def __init__(self, setup: RunSetup) -> None:
        scenario, observer = setup.scenario, setup.observer
        self.sim = PatrolSimulator(scenario, observability=setup.observability)
        obs, info = self.sim.reset(seed=setup.seed, options={"random_starts": True})
        self.visible = self.sim.visible
        self.domain = scenario.domain
        self.names = scenario.robot_names
        self.observer = observer
        self._observer_state = observer.start_state
        self._noise = np.random.default_rng(setup.noise)
        self.true: list[np.ndarray] = [info["states"].copy()]
        self.seen: list[np.ndarray] = [self._seen(obs)]
        self.seen_lateral: list[np.ndarray] | None = None  # grid states only: no poses
        self._t = 0

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
        """The grid simulator's record (:func:`mirl.simulation.grid.simulate`) and how often two
        patrollers met.

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
            The observations and truth; its report counts the meetings.

        Raises
        ------
        ValueError
            Fewer than one step, or a heading noise outside [0, 1].
        """
        result = simulate(
            scenario,
            steps,
            seed=seed,
            observability=observability,
            heading_noise=heading_noise,
            random_starts=random_starts,
        )
        degree = scenario.observability if observability is None else float(observability)
        meetings = f"interactions: {result.interactions} ({result.interactions_seen} seen by L)"
        return Simulation(result.observations, result.truth, degree, report=(meetings,))

    @staticmethod
    def read_section(scenario: Scenario) -> None:
        """The grid world has no section of its own: the scenario's grid model is its world.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        """
        return None

    @staticmethod
    def apply_damage(scenario: Scenario, robot: str, feature: str, value: float) -> Scenario:
        """The scenario with ``robot``'s ``feature`` succeeding with probability ``value``.

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
            :meth:`~mirl.world.scenario.Scenario.with_damage`'s copy.

        Raises
        ------
        ValueError
            An unknown robot or feature, or a probability outside [0, 1].
        """
        return scenario.with_damage(robot, feature, value)

    @staticmethod
    def healthy_value(scenario: Scenario, feature: str) -> float:
        """The feature's healthy success probability (the scenario's ``[faults] healthy``).

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        feature : str
            The part.

        Returns
        -------
        float
            Its healthy level.
        """
        return float(scenario.faults.healthy.get(feature, DEFAULT_HEALTHY))

    @staticmethod
    def modelled(scenario: Scenario) -> Scenario:
        """The scenario as L models this world: the scenario itself (the grid runs its Eq. 5).

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        Scenario
            ``scenario``.
        """
        return scenario

    @staticmethod
    def damaged_parts(scenario: Scenario) -> dict[str, tuple[str, ...]]:
        """Per robot, the features whose true success probability is damaged by the scenario's
        definition (``scenario.faults``).

        Parameters
        ----------
        scenario : Scenario
            The scenario.

        Returns
        -------
        dict of str to tuple of str
            Robot name -> damaged features.
        """
        return {
            r.name: scenario.faults.damaged_parts(r.feature_probabilities) for r in scenario.robots
        }

    @staticmethod
    def version() -> str:
        """The grid world's results depend on mirl alone.

        Returns
        -------
        str
            "".
        """
        return ""

    # ---- one run ----------------------------------------------------------------------------
    @property
    def t(self) -> int:
        """The current step."""
        return self._t

    def _seen(self, obs: np.ndarray) -> np.ndarray:
        out = np.full(self.sim.n_robots, -1, dtype=int)
        out[obs[:, 0]] = self.domain.state_index(obs[:, 1], obs[:, 2], obs[:, 3])
        return out

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
        """
        # the patrollers first, so that actions the simulator refuses move nobody; L's failures
        # have a stream of their own, so the order changes no outcome
        if patroller_actions is None:
            obs, _, _, _, info = self.sim.step()
        else:
            obs, _, _, _, info = self.sim.step_actions(patroller_actions)
        if observer_action is not None:
            s, model = self._observer_state, self.observer
            fails = self._noise.random() < model.failure
            self._observer_state = s if fails else int(model.domain.intended[s, observer_action])
        self._t += 1
        self.true.append(info["states"].copy())
        self.seen.append(self._seen(obs))
        return self.true[-1]

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
        truth, s = self.true[-1], self._observer_state
        seen = self.observer.seen_by(truth, s)
        row, col = map(int, self.observer.domain.states[s][:2])
        return [
            Detection(self._t, self.names[i], (int(r), int(c), int(h)), (row, col))
            for i in np.flatnonzero(seen)
            for r, c, h in [self.domain.states[truth[i]]]
        ]

    def at_goal(self) -> bool:
        """Whether L has reached its goal.

        Returns
        -------
        bool
            True on the goal.
        """
        return bool(self.observer.goal[self._observer_state])

    def extras(self) -> None:
        """The grid world records nothing beyond the contract.

        Returns
        -------
        None
            Always.
        """
        return None


_CONTRACT: World = GridRunWorld  # mypy checks the class (and its instances) against the contract
