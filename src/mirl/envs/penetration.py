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
  policies, meetings resolved by the scenario's game, in a world of :data:`mirl.worlds.WORLDS`
  (``world="grid"`` by default: :class:`~mirl.simulation.grid.PatrolSimulator`), stepped
  through the world contract as a run steps it. ``reset(seed=...)`` seeds ``np_random`` and
  through it the world and L's failures, so a seed fixes an episode.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from mirl.envs.core import Episode, check_episode_settings
from mirl.planning.observer import observer_model
from mirl.world.scenario import Scenario, as_scenario
from mirl.worlds import DEFAULT_WORLD, get_world

__all__ = ["PenetrationEnv", "observation_space", "OBSERVER_ACTIONS"]

OBSERVER_ACTIONS = ("forward", "turn_left", "turn_right", "wait")


def observation_space(scenario: Scenario) -> spaces.Dict:
    """L's observation space on ``scenario`` (the module doc's ``Dict``).

    Parameters
    ----------
    scenario : Scenario
        The scenario: its map's shape and number of patrollers.

    Returns
    -------
    gymnasium.spaces.Dict
        ``patrollers``, ``observer`` and ``out``.
    """
    rows, cols = scenario.map.shape
    high = np.array([rows - 1, cols - 1, 3], dtype=np.int64)
    n = len(scenario.robots)
    return spaces.Dict(
        {
            "patrollers": spaces.Box(-1, np.tile(high, (n, 1)), dtype=np.int64),
            "observer": spaces.Box(np.zeros(3, dtype=np.int64), high, dtype=np.int64),
            "out": spaces.Discrete(2),
        }
    )


class PenetrationEnv(gym.Env):
    """L's task on ``scenario`` in ``world`` (module doc).

    Parameters
    ----------
    scenario : Scenario or str, default "boyd2"
        A :class:`~mirl.world.scenario.Scenario`, or a shipped name or path.
    world : str, default "grid"
        A name in :data:`mirl.worlds.WORLDS`.
    observability : float, optional
        The fraction of the hallway L sees from its room; the scenario's by default.
    max_steps : int, default 1000
        Steps after which an episode is truncated, an integer of at least 1.
    goal_reward : float, default 1.0
        The reward for reaching the goal unseen, a finite number.
    detection_penalty : float, default 1.0
        The penalty (a reward of minus it) for being seen, a finite number.

    Raises
    ------
    ValueError
        ``max_steps`` not an integer of at least 1, an ``observability`` that is not a number
        in [0, 1], a reward that is not a finite number, or an unknown world.
    ImportError
        A world that cannot run on this installation.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: Scenario | str = "boyd2",
        *,
        world: str = DEFAULT_WORLD,
        observability: float | None = None,
        max_steps: int = 1000,
        goal_reward: float = 1.0,
        detection_penalty: float = 1.0,
    ) -> None:
        check_episode_settings(
            "max_steps", max_steps, observability,
            goal_reward=goal_reward, detection_penalty=detection_penalty,
        )  # fmt: skip
        self.scenario = as_scenario(scenario)
        self.world_class = get_world(world).load()
        self.model = observer_model(self.scenario)
        self.observability = (
            self.scenario.observability if observability is None else float(observability)
        )
        self.max_steps = int(max_steps)
        self.goal_reward = float(goal_reward)
        self.detection_penalty = float(detection_penalty)
        self.observation_space = observation_space(self.scenario)
        self.action_space = spaces.Discrete(len(OBSERVER_ACTIONS))
        self.episode: Episode | None = None  # step() before the first reset() has none

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode: patrollers at random states of their patrol cycles, L in its room.

        Parameters
        ----------
        seed : int, optional
            Seeds ``np_random`` and through it the world and L's failures.
        options : dict, optional
            Accepted and unused: the environment has no reset options, and Gymnasium's
            convention (and its wrappers) pass options through to every environment.

        Returns
        -------
        observation : dict
            L's view (:meth:`~mirl.envs.core.Episode.observer_view`).
        info : dict
            ``t`` (0) and the patrollers' true states.
        """
        super().reset(seed=seed)
        self.episode = Episode(
            self.world_class, self.scenario, self.model, self.observability,
            int(self.np_random.integers(2**63 - 1)),
        )  # fmt: skip
        return self.episode.observer_view(), {
            "t": 0,
            "patroller_states": self.episode.patroller_states,
        }

    def step(self, action):
        """L takes ``action``; the world steps.

        Parameters
        ----------
        action : int
            An index into :data:`OBSERVER_ACTIONS`.

        Returns
        -------
        observation : dict
            L's view.
        reward : float
            ``goal_reward`` on reaching the goal, ``-detection_penalty`` when seen, else 0.
        terminated : bool
            Whether L was seen or arrived.
        truncated : bool
            Whether ``max_steps`` were reached first.
        info : dict
            ``t``, the ``outcome`` (None while running) and the patrollers' true states.

        Raises
        ------
        gymnasium.error.ResetNeeded
            :meth:`reset` was never called, or not since the episode ended (terminated or
            truncated).
        ValueError
            An action outside the action space.
        """
        episode = self.episode
        if episode is None:
            raise ResetNeeded("call reset() before step()")
        # an ended episode's world would step on, and L's outcome would be recomputed
        if episode.outcome is not None or episode.world.t >= self.max_steps:
            raise ResetNeeded("the episode has ended (terminated or truncated): call reset()")
        if not self.action_space.contains(action):
            raise ValueError(f"action {action!r} is not in {self.action_space}")
        episode.step(int(action))  # OBSERVER_ACTIONS index ACTIONS: wait is L's stop action
        reward = -self.detection_penalty if episode.detected else 0.0
        reward = self.goal_reward if episode.arrived else reward
        terminated = episode.outcome is not None
        t = episode.world.t
        truncated = not terminated and t >= self.max_steps
        info = {"t": t, "outcome": episode.outcome, "patroller_states": episode.patroller_states}
        return episode.observer_view(), reward, terminated, truncated, info
