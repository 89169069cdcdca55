"""The environments' first implementation, kept as the reference the environments built on the
world contract are compared against: a world of their own that stepped the grid simulator's
patrollers, drew L's failures, checked detection and the goal, and read L's view itself.

``penetration_episode`` and ``team_episode`` play one episode of ``PenetrationEnv`` and
``TeamEnv`` as that implementation did and return everything an agent got at every step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from gymnasium.utils import seeding

from mirl.planning.observer import ObserverModel, observer_model
from mirl.simulation.grid import PatrolSimulator
from mirl.world.scenario import Scenario


class PenetrationWorld:
    """Patrollers and L on one map, as the environments first stepped them."""

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

    def view(self) -> dict:
        patrollers = np.full((self.n, 3), -1, dtype=np.int64)
        if not self.out and len(self._seen):
            patrollers[self._seen[:, 0]] = self._seen[:, 1:]
        observer = self.model.domain.states[self.observer].astype(np.int64)
        return {"patrollers": patrollers, "observer": observer, "out": int(self.out)}


def penetration_episode(
    scenario: Scenario, seed: int, policy: Callable[[int, dict], int], max_steps: int = 1000
) -> list[tuple]:
    """(observation, reward, terminated, truncated, info) per step of ``PenetrationEnv``
    (unit goal reward and detection penalty), the reset's (observation, info) first, L acting
    by ``policy(t, observation)``, until the episode ends."""
    w = PenetrationWorld(scenario)
    np_random, _ = seeding.np_random(seed)  # what gymnasium's Env.reset(seed=...) sets
    w.reset(int(np_random.integers(2**63 - 1)))
    out: list[tuple] = [(w.view(), {"t": 0, "patroller_states": w.sim.states.copy()})]
    for t in range(1, max_steps + 1):
        w.move_observer(policy(t - 1, out[-1][0]))
        w.step_patrollers()
        reward, terminated, outcome = 0.0, False, None
        if w.detected():
            reward, terminated, outcome = -1.0, True, "detected"
        elif w.at_goal():
            reward, terminated, outcome = 1.0, True, "success"
        truncated = not terminated and t >= max_steps
        info = {"t": t, "outcome": outcome, "patroller_states": w.sim.states.copy()}
        out.append((w.view(), reward, terminated, truncated, info))
        if terminated or truncated:
            break
    return out


def team_episode(scenario: Scenario, seed: int, actions: list[dict], max_cycles: int = 500):
    """(observations, rewards, terminations, truncations, infos) per step of ``TeamEnv`` (unit
    rewards), the reset's observations first; it stops where the episode ends."""
    w = PenetrationWorld(scenario)
    w.reset(seed)
    names = scenario.robot_names
    rewards_of = [scenario.domain.rewards(list(r.weights)) for r in scenario.robots]

    def observations() -> dict:
        states = w.sim.domain.states[w.sim.states].astype(np.int64)
        return {**{n: states[i] for i, n in enumerate(names)}, "L": w.view()}

    out: list = [observations()]
    for t, joint in enumerate(actions, start=1):
        acts = np.array([int(joint[n]) for n in names])
        before = w.sim.states.copy()
        w.move_observer(int(joint["L"]))
        w.step_patrollers(acts)
        detected, arrived = w.detected(), (not w.detected()) and w.at_goal()
        rewards = {
            n: float(rewards_of[i][before[i], acts[i]]) + (1.0 if detected else 0.0)
            for i, n in enumerate(names)
        }
        rewards["L"] = -1.0 if detected else (1.0 if arrived else 0.0)
        done = detected or arrived
        truncated = not done and t >= max_cycles
        outcome = "detected" if detected else ("success" if arrived else None)
        agents = [*names, "L"]
        out.append((
            observations(), rewards, dict.fromkeys(agents, done), dict.fromkeys(agents, truncated),
            {a: {"t": t, "outcome": outcome} for a in agents},
        ))  # fmt: skip
        if done or truncated:
            break
    return out
