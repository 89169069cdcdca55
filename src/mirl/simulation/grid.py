"""Grid simulator of N ≥ 2 patrollers with stochastic outcomes, interactions resolved by the
scenario's equilibrium, and L's occluded (optionally noisy) observations.

Follows gymnasium's conventions: ``reset(seed=...)`` seeds ``np_random`` and returns
``(observation, info)``; ``step()`` returns ``(observation, reward, terminated, truncated, info)``.
L is passive while it observes, so ``step`` takes no action.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirl.observations.trajectories import Trajectories
from mirl.world.game import meeting, meeting_actions
from mirl.world.scenario import Scenario, as_scenario

__all__ = ["PatrolSimulator", "SimulationResult", "simulate", "patrol_cycle"]


def patrol_cycle(scenario: Scenario, robot: int) -> np.ndarray:
    """States of the cycle the robot's true policy settles into under intended outcomes.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    robot : int
        The patroller's index.

    Returns
    -------
    ndarray of int, shape (k,)
        The cycle's states, in the order the patroller visits them.
    """
    d = scenario.domain
    pol = scenario.true_policy(robot)
    s = int(d.state_index(*scenario.robots[robot].start))
    for _ in range(2 * d.n_states):
        s = d.intended[s, pol[s]]
    cycle = [s]
    s = d.intended[s, pol[s]]
    while s != cycle[0]:
        cycle.append(int(s))
        s = d.intended[s, pol[s]]
    return np.asarray(cycle)


class PatrolSimulator:
    """Patrollers following their true policies; L watching at an observability degree.

    A Gymnasium-style loop (``reset``, ``step``) over the whole team.

    Parameters
    ----------
    scenario : Scenario or str
        The scenario, or a shipped name or path.
    observability : float, optional
        The fraction of the hallway L sees, in [0, 1]; the scenario's by default.
    heading_noise : float, default 0.0
        The probability, in [0, 1], that L misreads a seen robot's heading (as one of the other
        three, uniformly); it never changes the world.

    Raises
    ------
    ValueError
        A heading noise outside [0, 1].
    """

    def __init__(
        self,
        scenario: Scenario | str,
        *,
        observability: float | None = None,
        heading_noise: float = 0.0,
    ) -> None:
        if not 0.0 <= heading_noise <= 1.0:
            raise ValueError(f"heading_noise must be in [0, 1], got {heading_noise}")
        scenario = as_scenario(scenario)
        self.scenario = scenario
        self.domain = scenario.domain
        self.observability = scenario.observability if observability is None else observability
        self.visible = self.domain.visible_states(self.observability)
        self.heading_noise = heading_noise
        self.n_robots = len(scenario.robots)
        self.policies = np.stack([scenario.true_policy(i) for i in range(self.n_robots)])
        self._T = [scenario.true_transitions(i) for i in range(self.n_robots)]
        pairs = scenario.pairs
        self._pair_i = np.array([i for i, _ in pairs], dtype=int)
        self._pair_j = np.array([j for _, j in pairs], dtype=int)
        self._eq_cdf = []
        for i, j in pairs:
            eq = scenario.pair_equilibrium(i, j)
            self._eq_cdf.append((np.cumsum(eq.row), np.cumsum(eq.col)))
        self.np_random = np.random.default_rng()
        self._perception_rng = np.random.default_rng()
        self.states = np.zeros(self.n_robots, dtype=int)
        self.t = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start a new episode.

        Parameters
        ----------
        seed : int, optional
            Seeds the world's random stream (and, spawned from it, the perception noise's).
        options : dict, optional
            ``{"random_starts": True}`` starts each robot at a uniformly drawn state of its patrol
            cycle; ``{"starts": [(r, c, h), ...]}`` sets them.

        Returns
        -------
        observation : ndarray of int, shape (k, 4)
            (robot, row, col, heading) of the robots L sees.
        info : dict
            ``t``, the true ``states`` and ``interaction`` (False).

        Raises
        ------
        ValueError
            A start that is not a hallway state.
        """
        seq = np.random.SeedSequence(seed)
        self.np_random = np.random.default_rng(seq)  # the same stream as default_rng(seed)
        # perception noise has its own stream: misreading a heading never changes the world, so
        # runs with the same seed and different heading_noise have the same true trajectories
        self._perception_rng = np.random.default_rng(seq.spawn(1)[0])
        options = options or {}
        if "starts" in options:
            starts = [tuple(s) for s in options["starts"]]
        else:
            starts = [r.start for r in self.scenario.robots]
        self.states = np.array([self.domain.state_index(*s) for s in starts], dtype=int)
        if np.any(self.states < 0):
            raise ValueError(f"start {starts[int(np.argmin(self.states))]} is not a hallway state")
        if options.get("random_starts"):
            for i in range(self.n_robots):
                cyc = patrol_cycle(self.scenario, i)
                self.states[i] = cyc[self.np_random.integers(len(cyc))]
        self.t = 0
        return self._observe(), {"t": 0, "states": self.states.copy(), "interaction": False}

    def intended_actions(self) -> tuple[np.ndarray, bool]:
        """Each robot's action this step.

        Its policy's, overridden by the pair's equilibrium where two robots meet
        (:meth:`~mirl.world.scenario.Scenario.pair_equilibrium`, the lower index the row player).
        Meetings are found on the policies' own actions for every pair at once. When a robot meets
        two others in the same step (three in a corridor junction), the pairs are resolved in robot
        order ((0, 1), (0, 2), (1, 2), …) and the robot plays the game of its *first* meeting; every
        meeting pair still draws both of its game actions, so the random stream does not depend on
        which draws were used.

        Returns
        -------
        actions : ndarray of int, shape (N,)
            An action per robot.
        met : bool
            Whether some pair met.
        """
        idx = np.arange(self.n_robots)
        own = self.policies[idx, self.states]
        si, sj = self._pair_i, self._pair_j
        hits = np.flatnonzero(
            meeting(self.domain, self.states[si], self.states[sj], own[si], own[sj])
        )

        def draw(k: int) -> tuple[int, int]:
            cdf_i, cdf_j = self._eq_cdf[hits[k]]
            gi = int(np.searchsorted(cdf_i, self.np_random.random(), "right"))
            gj = int(np.searchsorted(cdf_j, self.np_random.random(), "right"))
            return min(gi, 2), min(gj, 2)

        pairs = [(int(si[k]), int(sj[k])) for k in hits]
        return meeting_actions(own, pairs, draw), bool(hits.size)

    def step(self, action=None):
        """Advance one step: every robot takes :meth:`intended_actions` through its true T.

        Parameters
        ----------
        action : None
            Ignored (the patrollers choose their own actions); Gymnasium's signature.

        Returns
        -------
        observation : ndarray of int, shape (k, 4)
            (robot, row, col, heading) of the robots L sees.
        reward : float
            0.0 (the patrollers' rewards are not L's).
        terminated : bool
            False: a patrol does not end.
        truncated : bool
            False.
        info : dict
            ``t``, the true ``states``, ``interaction`` (whether a pair met) and ``actions``.
        """
        acts, met = self.intended_actions()
        A = self.domain.n_actions
        for i in range(self.n_robots):
            T = self._T[i]
            row = self.states[i] * A + acts[i]
            lo, hi = T.indptr[row], T.indptr[row + 1]
            cdf = np.cumsum(T.data[lo:hi])
            k = min(
                int(np.searchsorted(cdf, self.np_random.random() * cdf[-1], "right")), hi - lo - 1
            )
            self.states[i] = T.indices[lo + k]
        self.t += 1
        info = {"t": self.t, "states": self.states.copy(), "interaction": met, "actions": acts}
        return self._observe(), 0.0, False, False, info

    def step_actions(self, actions: np.ndarray):
        """Advance one step with each robot taking the given action.

        The action goes through the robot's true transition function: no policy and no game at
        meetings, since whoever gave the actions chose them (the agents of
        :class:`mirl.envs.TeamEnv`).

        Parameters
        ----------
        actions : ndarray of int, shape (N,)
            An index into :data:`~mirl.world.domain.ACTIONS` per robot.

        Returns
        -------
        tuple
            As :meth:`step`.

        Raises
        ------
        ValueError
            Anything but one valid action per robot; nobody moves.
        """
        acts = np.asarray(actions)
        A = self.domain.n_actions
        if (
            acts.shape != (self.n_robots,)
            or not np.issubdtype(acts.dtype, np.integer)
            or ((acts < 0) | (acts >= A)).any()
        ):
            raise ValueError(
                f"`actions` must be {self.n_robots} integers in [0, {A}), one per robot, "
                f"got {actions!r}"
            )
        for i, a in enumerate(acts.astype(int)):
            row = self._T[i][[int(self.states[i]) * A + int(a)]].toarray().ravel()
            self.states[i] = int(self.np_random.choice(len(row), p=row / row.sum()))
        self.t += 1
        info = {"t": self.t, "states": self.states.copy(), "interaction": False, "actions": acts}
        return self._observe(), 0.0, False, False, info

    def _observe(self) -> np.ndarray:
        """(k, 4) rows (robot, row, col, heading) of the robots on visible cells."""
        seen = np.flatnonzero(self.visible[self.states])
        rch = self.domain.states[self.states[seen]].copy()
        if self.heading_noise > 0 and len(seen):
            flip = self._perception_rng.random(len(seen)) < self.heading_noise
            shift = self._perception_rng.integers(1, 4, size=len(seen))
            rch[flip, 2] = (rch[flip, 2] + shift[flip]) % 4
        return np.column_stack([seen, rch]).astype(int)


@dataclass(frozen=True)
class SimulationResult:
    """What :func:`simulate` recorded.

    Parameters
    ----------
    truth : Trajectories
        Every robot's true state at every step.
    observations : Trajectories
        What L saw.
    interactions : int
        Steps at which some pair of robots met.
    interactions_seen : int
        Of those, steps at which both meeting robots were visible.
    true_states : ndarray of int, shape (steps, N)
        The true state indices.
    """

    truth: Trajectories
    observations: Trajectories
    interactions: int  # steps at which some pair of robots met
    interactions_seen: int  # of those, steps at which both meeting robots were visible
    true_states: np.ndarray  # (steps, N) state indices

    def observed_share(self) -> np.ndarray:
        """Per robot, the share of time steps at which L saw it.

        Returns
        -------
        ndarray of shape (N,)
            Shares in [0, 1].
        """
        n = len(self.truth.robot_names)
        counts = np.bincount(self.observations.robot, minlength=n)
        return counts / max(self.truth.horizon, 1)


def simulate(
    scenario: Scenario | str,
    steps: int,
    *,
    seed: int | None = None,
    observability: float | None = None,
    heading_noise: float = 0.0,
    random_starts: bool = False,
) -> SimulationResult:
    """Run ``steps`` time steps (t = 0 … steps−1) and record truth and L's observations.

    Parameters
    ----------
    scenario : Scenario or str
        The scenario, or a shipped name or path.
    steps : int
        Time steps to record, at least 1.
    seed : int, optional
        Seeds the run; a fresh stream if None.
    observability : float, optional
        The fraction of the hallway L sees; the scenario's by default.
    heading_noise : float, default 0.0
        The probability that L misreads a seen robot's heading.
    random_starts : bool, default False
        Start each robot at a uniformly drawn state of its patrol cycle.

    Returns
    -------
    SimulationResult
        The truth, the observations and the meetings.

    Raises
    ------
    ValueError
        Fewer than one step, or a heading noise outside [0, 1].
    """
    if steps < 1:
        raise ValueError(f"steps must be at least 1, got {steps}")
    scenario = as_scenario(scenario)
    sim = PatrolSimulator(scenario, observability=observability, heading_noise=heading_noise)
    obs, info = sim.reset(seed=seed, options={"random_starts": random_starts})
    true_states = np.empty((steps, sim.n_robots), dtype=int)
    observed = np.full((steps, sim.n_robots, 3), -1, dtype=int)
    interactions = seen = 0
    for t in range(steps):
        true_states[t] = info["states"]
        observed[t, obs[:, 0]] = obs[:, 1:]
        if t == steps - 1:
            break
        obs, _, _, _, info = sim.step()
        if info["interaction"]:
            interactions += 1
            seen += int(sim.visible[true_states[t]].all())
    names = scenario.robot_names
    truth = Trajectories.from_states(sim.domain, names, true_states)
    tt, rr = np.nonzero(observed[:, :, 0] >= 0)
    o = observed[tt, rr]
    observations = Trajectories(names, tt, rr, o[:, 0], o[:, 1], o[:, 2], steps)
    return SimulationResult(truth, observations, interactions, seen, true_states)
