"""The grid world of the paper's simulations: the patrollers in a
:class:`~mirl.simulation.grid.PatrolSimulator`, L watching at an observability degree, and L
moving on its own grid once it goes — each of its actions fails (it stays put) with its model's
failure probability — seen by the scenario's detection rule."""

from __future__ import annotations

import numpy as np

from mirl.simulation.grid import PatrolSimulator, simulate
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
        """The grid simulator's record (:func:`mirl.simulation.grid.simulate`) and how often
        two patrollers met."""
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
        """The grid world has no section of its own: the scenario's grid model is its world."""
        return None

    @staticmethod
    def apply_damage(scenario: Scenario, robot: str, feature: str, value: float) -> Scenario:
        """The scenario with ``robot``'s ``feature`` succeeding with probability ``value``."""
        return scenario.with_damage(robot, feature, value)

    @staticmethod
    def modelled(scenario: Scenario) -> Scenario:
        """The scenario as L models this world: the scenario itself (the grid runs its Eq. 5)."""
        return scenario

    @staticmethod
    def damaged_parts(scenario: Scenario) -> dict[str, tuple[str, ...]]:
        """Per robot, the features whose true success probability is damaged by the scenario's
        definition (``scenario.faults``)."""
        return {
            r.name: scenario.faults.damaged_parts(r.feature_probabilities) for r in scenario.robots
        }

    @staticmethod
    def version() -> str:
        """The grid world's results depend on mirl alone."""
        return ""

    # ---- one run ----------------------------------------------------------------------------
    @property
    def t(self) -> int:
        return self._t

    def _seen(self, obs: np.ndarray) -> np.ndarray:
        out = np.full(self.sim.n_robots, -1, dtype=int)
        out[obs[:, 0]] = self.domain.state_index(obs[:, 1], obs[:, 2], obs[:, 3])
        return out

    def step(
        self, observer_action: int | None = None, *, patroller_actions: np.ndarray | None = None
    ) -> np.ndarray:
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
        return self._observer_state

    def detections(self) -> list[Detection]:
        truth, s = self.true[-1], self._observer_state
        seen = self.observer.seen_by(truth, s)
        row, col = map(int, self.observer.domain.states[s][:2])
        return [
            Detection(self._t, self.names[i], (int(r), int(c), int(h)), (row, col))
            for i in np.flatnonzero(seen)
            for r, c, h in [self.domain.states[truth[i]]]
        ]

    def at_goal(self) -> bool:
        return bool(self.observer.goal[self._observer_state])

    def extras(self) -> None:
        return None


_CONTRACT: World = GridRunWorld  # mypy checks the class (and its instances) against the contract
