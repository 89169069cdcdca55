"""The whole team as a PettingZoo ``ParallelEnv`` (:class:`TeamEnv`): every patroller and L is
an agent acting at the same time.

* **Patroller** agents (named as in the scenario): observe their own (row, col, heading), act
  with the four patroller actions (``forward``, ``turn_left``, ``turn_right``, ``stop``), which
  succeed or fail by their **true** transition functions; their reward is their true reward
  r(s, a) (the scenario's features and that robot's weights) plus ``detection_reward`` when
  some patroller sees L. Meetings are not arbitrated: the agents choose for themselves.
* **L** (agent ``"L"``): observation, actions and reward as in
  :class:`~mirl.envs.penetration.PenetrationEnv`.

The episode ends for every agent when L is seen or reaches its goal, and is truncated after
``max_cycles`` steps. ``reset(seed=...)`` fixes the patrollers' starts and every outcome. The
world (``world="grid"`` by default, a name in :data:`mirl.worlds.WORLDS`) is stepped through the
world contract with the patrollers' actions; a world whose patrollers cannot take given actions
(the physics world's drive by their policies) is refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from mirl._validation import SEED, check_argument
from mirl.envs.core import Episode, check_episode_settings
from mirl.envs.penetration import OBSERVER_ACTIONS, observation_space
from mirl.planning.observer import observer_model
from mirl.world.domain import ACTIONS
from mirl.world.scenario import Scenario, as_scenario
from mirl.world.scenario_sections import OBSERVER_NAME
from mirl.worlds import DEFAULT_WORLD, get_world

__all__ = ["TeamEnv", "OBSERVER"]

OBSERVER = OBSERVER_NAME


class TeamEnv(ParallelEnv):
    """Patrollers and L of ``scenario`` as parallel agents, in ``world`` (module doc).

    Parameters
    ----------
    scenario : Scenario or str, default "boyd2"
        A Scenario, or a shipped name or path; no patroller may be named ``L``.
    world : str, default "grid"
        A name in :data:`mirl.worlds.WORLDS` whose patrollers take given actions.
    observability : float, optional
        The fraction of the hallway L sees from its room; the scenario's by default.
    max_cycles : int, default 500
        Steps after which an episode is truncated, an integer of at least 1.
    goal_reward : float, default 1.0
        L's reward for reaching the goal unseen, a finite number.
    detection_penalty : float, default 1.0
        L's penalty for being seen, a finite number.
    detection_reward : float, default 1.0
        Every patroller's bonus when some patroller sees L, a finite number.

    Raises
    ------
    ValueError
        ``max_cycles`` not an integer of at least 1, an ``observability`` that is not a number
        in [0, 1], a reward that is not a finite number, a patroller named ``L``, an unknown
        world, or one whose patrollers cannot take actions.
    """

    metadata = {"render_modes": [], "name": "mirl_team_v0"}
    render_mode = None  # nothing to render; PettingZoo's API test reads the attribute

    def __init__(
        self,
        scenario: Scenario | str = "boyd2",
        *,
        world: str = DEFAULT_WORLD,
        observability: float | None = None,
        max_cycles: int = 500,
        goal_reward: float = 1.0,
        detection_penalty: float = 1.0,
        detection_reward: float = 1.0,
    ) -> None:
        check_episode_settings(
            "max_cycles", max_cycles, observability, goal_reward=goal_reward,
            detection_penalty=detection_penalty, detection_reward=detection_reward,
        )  # fmt: skip
        sc = as_scenario(scenario)
        if OBSERVER in sc.robot_names:
            raise ValueError(f"a patroller may not be named '{OBSERVER}' (L's agent name)")
        self.world_class = get_world(world).load()
        if not self.world_class.takes_patroller_actions:
            raise ValueError(
                f"world '{world}': its patrollers drive by their own policies and take no "
                "actions, so they cannot be agents"
            )
        self.scenario, self.model = sc, observer_model(sc)
        self.observability = sc.observability if observability is None else float(observability)
        self.episode: Episode | None = None
        self.max_cycles = int(max_cycles)
        self.rewards_for = (float(goal_reward), float(detection_penalty), float(detection_reward))
        self.possible_agents = [*sc.robot_names, OBSERVER]
        self.agents: list[str] = []
        rows, cols = sc.map.shape
        own = spaces.Box(
            np.zeros(3, dtype=np.int64), np.array([rows - 1, cols - 1, 3]), dtype=np.int64
        )
        self._obs_spaces: dict[str, spaces.Space] = {n: own for n in sc.robot_names}
        self._obs_spaces[OBSERVER] = observation_space(sc)
        self._act_spaces: dict[str, spaces.Space] = {
            n: spaces.Discrete(len(ACTIONS)) for n in sc.robot_names
        }
        self._act_spaces[OBSERVER] = spaces.Discrete(len(OBSERVER_ACTIONS))
        self._rewards = [sc.domain.rewards(list(r.weights)) for r in sc.robots]

    def observation_space(self, agent: str) -> spaces.Space:
        """An agent's observation space.

        Parameters
        ----------
        agent : str
            A patroller's name or ``"L"``.

        Returns
        -------
        gymnasium.spaces.Space
            A patroller's own (row, col, heading) box, or L's ``Dict``.
        """
        return self._obs_spaces[_known(agent, self._obs_spaces)]

    def action_space(self, agent: str) -> spaces.Space:
        """An agent's action space.

        Parameters
        ----------
        agent : str
            A patroller's name or ``"L"``.

        Returns
        -------
        gymnasium.spaces.Discrete
            The four patroller actions, or L's four moves.
        """
        return self._act_spaces[_known(agent, self._act_spaces)]

    def _observations(self, episode: Episode) -> dict[str, Any]:
        states = self.scenario.domain.states[episode.patroller_states].astype(np.int64)
        obs: dict[str, Any] = {n: states[i] for i, n in enumerate(self.scenario.robot_names)}
        obs[OBSERVER] = episode.observer_view()
        return obs

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode.

        Parameters
        ----------
        seed : int in [0, 2^63 - 1], optional
            Fixes the patrollers' starts and every outcome; a fresh one if None.
        options : dict, optional
            Accepted and unused: the environment has no reset options, and PettingZoo's API
            test resets with ``{"options": 1}``, which an environment must take.

        Returns
        -------
        observations : dict of str to object
            Per agent.
        infos : dict of str to dict
            Per agent, empty.

        Raises
        ------
        OptionError
            A seed that is not an integer in [0, 2^63 - 1] (a ValueError): it would be cut
            (``1.5``), parsed (``"3"``) or fail inside numpy (``-1``).
        """
        check_argument("seed", seed, SEED, None)
        if seed is None:
            seed = int(np.random.SeedSequence().generate_state(1)[0])
        self.episode = Episode(
            self.world_class, self.scenario, self.model, self.observability, int(seed)
        )
        self.agents = list(self.possible_agents)
        return self._observations(self.episode), {a: {} for a in self.agents}

    def _check_actions(self, actions: dict[str, Any]) -> None:
        """One action per live agent, each in its space (PettingZoo's contract), or a
        ValueError naming the agent: nothing is defaulted or dropped."""
        if not self.agents:
            raise ValueError(
                "no live agents: call reset() before step() (and after an episode ends)"
            )
        if not isinstance(actions, Mapping):
            raise TypeError(
                f"actions must be a dict of agent to action ({', '.join(self.agents)}), "
                f"not {type(actions).__name__}"
            )
        unknown = sorted(set(actions) - set(self.agents), key=str)
        missing = [a for a in self.agents if a not in actions]
        problems = [f"unknown {unknown}"] * bool(unknown) + [f"missing {missing}"] * bool(missing)
        if problems:
            raise ValueError(
                f"actions must name every live agent ({', '.join(self.agents)}): "
                + "; ".join(problems)
            )
        for agent in self.agents:
            if not self._act_spaces[agent].contains(actions[agent]):
                raise ValueError(
                    f"agent {agent}: action {actions[agent]!r} is not in {self._act_spaces[agent]}"
                )

    def step(self, actions: dict[str, Any]):
        """Every live agent acts at once.

        Parameters
        ----------
        actions : dict of str to int
            One action per live agent, each in its space.

        Returns
        -------
        observations : dict
            Per live agent.
        rewards : dict
            Per live agent: a patroller's true r(s, a) (plus ``detection_reward`` when L is seen);
            L's as in :class:`~mirl.envs.penetration.PenetrationEnv`.
        terminations : dict
            Per live agent: whether L was seen or arrived.
        truncations : dict
            Per live agent: whether ``max_cycles`` were reached first.
        infos : dict
            Per live agent: ``t`` and the ``outcome``.

        Raises
        ------
        ValueError
            An agent missing or unknown, an action outside its space, or no live agents.
        """
        self._check_actions(actions)
        episode = self.episode
        assert episode is not None  # live agents exist only after reset()
        names = self.scenario.robot_names
        acts = np.array([int(actions[n]) for n in names])
        before = episode.patroller_states
        episode.step(int(actions[OBSERVER]), acts)
        t = episode.world.t
        goal_reward, penalty, bonus = self.rewards_for
        detected, arrived = episode.detected, episode.arrived
        rewards = {
            n: float(self._rewards[i][before[i], acts[i]]) + (bonus if detected else 0.0)
            for i, n in enumerate(names)
        }
        rewards[OBSERVER] = -penalty if detected else (goal_reward if arrived else 0.0)
        done = detected or arrived
        truncated = not done and t >= self.max_cycles
        agents = self.agents
        obs = self._observations(episode)
        result = (
            {a: obs[a] for a in agents},
            {a: rewards[a] for a in agents},
            {a: done for a in agents},
            {a: truncated for a in agents},
            {a: {"t": t, "outcome": episode.outcome} for a in agents},
        )
        if done or truncated:
            self.agents = []
        return result


def _known(agent: str, spaces_of: dict) -> str:
    """``agent`` if it is one of the environment's, else a KeyError naming the agents."""
    if agent not in spaces_of:
        raise KeyError(f"no agent {agent!r}: the agents are {', '.join(spaces_of)}")
    return agent
