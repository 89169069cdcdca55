"""L's penetration task as a ``gymnasium.Env`` (:class:`PenetrationEnv`).

* **Observation** (``Dict``): ``patrollers`` — (N, 3) (row, col, heading) of each patroller L
  sees from its room, −1 where it does not (and everywhere once L has left its room: it then
  sees nothing, as in mirl's runs); ``observer`` — L's own (row, col, heading); ``out`` — 1
  once L has left its start cell.
* **Actions** (``Discrete(4)``): L's moves ``forward``, ``turn_left``, ``turn_right`` and
  ``wait`` (L's stop action: it stays, and keeps watching while in its room). Each fails with
  probability 2.5 % (L stays put).
* **Reward**: ``goal_reward`` on reaching the goal unseen, ``−detection_penalty`` when a
  patroller sees L (both end the episode), 0 otherwise; truncated after ``max_steps``.
* The patrollers start at random states of their patrol cycles and follow their **true**
  policies, meetings resolved by the scenario's game (:class:`~mirl.simulation.grid.
  PatrolSimulator`). ``reset(seed=...)`` seeds ``np_random`` and through it the simulator and
  L's failures, so a seed fixes an episode.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from mirl.envs.core import PenetrationWorld
from mirl.world.scenario import Scenario, as_scenario

__all__ = ["PenetrationEnv", "observation_space", "OBSERVER_ACTIONS"]

OBSERVER_ACTIONS = ("forward", "turn_left", "turn_right", "wait")


def observation_space(world: PenetrationWorld) -> spaces.Dict:
    rows, cols = world.scenario.map.shape
    high = np.array([rows - 1, cols - 1, 3], dtype=np.int64)
    return spaces.Dict(
        {
            "patrollers": spaces.Box(-1, np.tile(high, (world.n, 1)), dtype=np.int64),
            "observer": spaces.Box(np.zeros(3, dtype=np.int64), high, dtype=np.int64),
            "out": spaces.Discrete(2),
        }
    )


class PenetrationEnv(gym.Env):
    """L's task on ``scenario`` (a :class:`~mirl.world.scenario.Scenario` or a shipped name)."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: Scenario | str = "boyd2",
        *,
        observability: float | None = None,
        max_steps: int = 1000,
        goal_reward: float = 1.0,
        detection_penalty: float = 1.0,
    ) -> None:
        if max_steps < 1:
            raise ValueError(f"max_steps must be at least 1, got {max_steps}")
        self.world = PenetrationWorld(as_scenario(scenario), observability)
        self.max_steps = int(max_steps)
        self.goal_reward = float(goal_reward)
        self.detection_penalty = float(detection_penalty)
        self.observation_space = observation_space(self.world)
        self.action_space = spaces.Discrete(len(OBSERVER_ACTIONS))
        self._t = 0
        self._reset_once = False  # step() before the first reset() has no episode to step

    def _obs(self) -> dict[str, Any]:
        w = self.world
        return {
            "patrollers": w.patrollers_seen(),
            "observer": w.observer_state(),
            "out": int(w.out),
        }

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.world.reset(int(self.np_random.integers(2**63 - 1)))
        self._t = 0
        self._reset_once = True
        return self._obs(), {"t": 0, "patroller_states": self.world.sim.states.copy()}

    def step(self, action):
        if not self._reset_once:
            raise ResetNeeded("call reset() before step()")
        if not self.action_space.contains(action):
            raise ValueError(f"action {action!r} is not in {self.action_space}")
        w = self.world
        w.move_observer(3 if int(action) == 3 else int(action))  # wait = L's stop action
        w.step_patrollers()
        self._t += 1
        reward, terminated, outcome = 0.0, False, None
        if w.detected():
            reward, terminated, outcome = -self.detection_penalty, True, "detected"
        elif w.at_goal():
            reward, terminated, outcome = self.goal_reward, True, "success"
        truncated = not terminated and self._t >= self.max_steps
        info = {"t": self._t, "outcome": outcome, "patroller_states": w.sim.states.copy()}
        return self._obs(), reward, terminated, truncated, info
