"""The world both environments step: the grid simulator's patrollers, L's MDP (its moves fail
with probability 2.5 %, it stays put), the true detection rule and what L sees from its room.
Seeding follows the simulator: one seed fixes the patrollers' starts and moves and L's failures
(independent streams spawned from it)."""

from __future__ import annotations

import numpy as np

from mirl.planning.observer import ObserverModel, observer_model
from mirl.simulation.grid import PatrolSimulator
from mirl.world.scenario import Scenario

__all__ = ["PenetrationWorld"]


class PenetrationWorld:
    """Patrollers and L on one map. ``observe()`` is L's view: the (row, col, heading) of each
    patroller L sees from its room (−1 rows for the rest, and for all once L is out) and L's
    own state."""

    def __init__(self, scenario: Scenario, observability: float | None = None) -> None:
        self.scenario = scenario
        self.sim = PatrolSimulator(scenario, observability=observability)
        self.model: ObserverModel = observer_model(scenario)
        self.n = len(scenario.robots)
        self.rng = np.random.default_rng()
        self.observer = self.model.start_state
        self.out = False
        self._seen = np.empty((0, 4), dtype=int)

    def reset(self, seed: int) -> None:
        sim_seq, l_seq = np.random.SeedSequence(seed).spawn(2)
        obs, _ = self.sim.reset(
            seed=int(sim_seq.generate_state(1)[0]), options={"random_starts": True}
        )
        self.rng = np.random.default_rng(l_seq)
        self.observer = self.model.start_state
        self.out = False
        self._seen = obs

    def step_patrollers(self, actions: np.ndarray | None = None) -> None:
        """Move the patrollers: by their true policies and the game (``None``), or by the
        given actions through their true transition functions."""
        if actions is None:
            obs, *_ = self.sim.step()
        else:
            T = [self.scenario.true_transitions(i) for i in range(self.n)]
            A = self.sim.domain.n_actions
            for i, a in enumerate(np.asarray(actions, dtype=int)):
                row = T[i][[int(self.sim.states[i]) * A + int(a)]].toarray().ravel()
                self.sim.states[i] = int(self.sim.np_random.choice(len(row), p=row / row.sum()))
            self.sim.t += 1
            obs = self.sim._observe()
        self._seen = obs

    def move_observer(self, action: int) -> None:
        if self.model.failure > 0 and self.rng.random() < self.model.failure:
            return
        nxt = int(self.model.domain.intended[self.observer, int(action)])
        start_cell = self.model.cell_of(self.model.start_state)
        self.out = self.out or int(self.model.cell_of(nxt)) != int(start_cell)
        self.observer = nxt

    def detected(self) -> bool:
        return bool(self.model.seen_by(self.sim.states, self.observer).any())

    def at_goal(self) -> bool:
        return bool(self.model.goal[self.observer])

    def patrollers_seen(self) -> np.ndarray:
        out = np.full((self.n, 3), -1, dtype=np.int64)
        if not self.out and len(self._seen):
            out[self._seen[:, 0]] = self._seen[:, 1:]
        return out

    def observer_state(self) -> np.ndarray:
        return self.model.domain.states[self.observer].astype(np.int64)
