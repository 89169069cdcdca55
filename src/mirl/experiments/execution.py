"""The two halves of a run after learning: L waiting in its room and re-planning until its go
time (:func:`wait_for_go`), then L driving its plan while the patrollers move on
(:func:`execute`). The world they act in is :class:`RunWorld`: the grid simulator plus L's
record of what it saw."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from mirl.experiments.records import Detection, PlanAttempt
from mirl.observations.trajectories import Trajectories
from mirl.planning.belief import NOT_WATCHING, BeliefFilter
from mirl.planning.go import ObserverPlan
from mirl.planning.observer import ObserverModel
from mirl.simulation.grid import PatrolSimulator
from mirl.world.scenario import Scenario

__all__ = ["RunWorld", "wait_for_go", "execute", "PlanFollower", "propagate_blind"]


class RunWorld:
    """The simulator plus L's record of it; one instance per run."""

    def __init__(self, scenario: Scenario, observability: float, seed: int) -> None:
        self.sim = PatrolSimulator(scenario, observability=observability)
        obs, info = self.sim.reset(seed=seed, options={"random_starts": True})
        self.domain = scenario.domain
        self.true: list[np.ndarray] = [info["states"].copy()]
        self.seen: list[np.ndarray] = [self._seen(obs)]
        self.t = 0

    def _seen(self, obs: np.ndarray) -> np.ndarray:
        out = np.full(self.sim.n_robots, -1, dtype=int)
        out[obs[:, 0]] = self.domain.state_index(obs[:, 1], obs[:, 2], obs[:, 3])
        return out

    def step(self) -> np.ndarray:
        obs, _, _, _, info = self.sim.step()
        self.t += 1
        self.true.append(info["states"].copy())
        self.seen.append(self._seen(obs))
        return self.true[-1]

    def step_seen(self) -> np.ndarray:
        """Step, and return what L saw (state index per robot, -1 unseen)."""
        self.step()
        return self.seen[-1]

    def observations(self, names: tuple[str, ...], until: int) -> Trajectories:
        return Trajectories.from_states(self.domain, names, np.asarray(self.seen[: until + 1]))


def wait_for_go(
    world: RunWorld,
    belief: BeliefFilter,
    make_plan: Callable[[], ObserverPlan],
    deadline: int,
    replan_every: int,
    commit: bool,
    timings: dict[str, float],
) -> tuple[ObserverPlan, int | None, list[PlanAttempt]]:
    """L in its room: plan, then keep watching until the go time or the deadline.

    L re-plans every ``replan_every`` steps while it has no go time and — unless ``commit`` —
    also whenever a patroller leaves its view (the moment its belief about that robot is
    sharpest), so a newer plan can move or cancel the go time. Returns the plan to execute, the
    absolute go time (None: timed out) and every planning round.
    """
    attempts: list[PlanAttempt] = []
    plan: ObserverPlan | None = None
    go_time: int | None = None
    next_plan = world.t
    while True:
        left_view = world.t > 0 and np.any((world.seen[-2] >= 0) & (world.seen[-1] < 0))
        if world.t >= next_plan or (left_view and not (commit and go_time is not None)):
            clock = time.perf_counter()
            plan = make_plan()
            timings["plan"] += time.perf_counter() - clock
            go_time = None if plan.go_time is None else world.t + plan.go_time
            attempts.append(PlanAttempt(world.t, float(plan.go_values.max()), go_time))
            next_plan = world.t + replan_every if go_time is None else deadline + 1
        assert plan is not None
        if go_time is not None and world.t >= go_time:
            return plan, go_time, attempts
        if world.t >= deadline:
            return plan, None, attempts
        clock = time.perf_counter()
        world.step()
        timings["observe"] += time.perf_counter() - clock
        clock = time.perf_counter()
        belief.update(world.seen[-1])
        timings["plan"] += time.perf_counter() - clock


def execute(
    world: RunWorld,
    model: ObserverModel,
    policy: Callable[[int, int], int],
    plan: ObserverPlan | None,
    rng: np.random.Generator,
    belief: BeliefFilter | None,
    replan: Callable[[], ObserverPlan] | None,
    max_steps: int,
    names: tuple[str, ...],
):
    """L leaves its start cell now and follows ``policy(k, state)`` (re-planning with
    ``replan`` if it outlives ``plan``); returns the outcome, L's path (t, row, col, heading),
    the detections and the plan finally followed. More than ``max_steps`` steps: timeout."""
    dom = model.domain
    s = model.start_state
    follower = PlanFollower(policy, plan, replan, world.t)
    path = [(world.t, *map(int, dom.states[s]))]
    propagate_blind(belief, world.t)  # L stopped watching when it left its room
    for _ in range(max_steps):
        a = follower.action(s)
        nxt = s if rng.random() < model.failure else int(dom.intended[s, a])
        truth = world.step()
        propagate_blind(belief, world.t)
        s = nxt
        path.append((world.t, *map(int, dom.states[s])))
        seen = model.seen_by(truth, s)
        if seen.any():
            row, col = map(int, dom.states[s][:2])
            patrol_states = world.domain.states
            dets = [
                Detection(
                    world.t,
                    names[i],
                    (int(r), int(c), int(h)),
                    (row, col),
                )
                for i in np.flatnonzero(seen)
                for r, c, h in [patrol_states[truth[i]]]
            ]
            return "detected", path, dets, follower.plan
        if model.goal[s]:
            return "success", path, [], follower.plan
    return "timeout", path, [], follower.plan


class PlanFollower:
    """L's step policy along its time-indexed plan; when L outlives the plan it re-plans from
    where it stands (``replan``) and follows the new one. Shared by the grid and physical worlds."""

    def __init__(
        self,
        policy: Callable[[int, int], int],
        plan: ObserverPlan | None,
        replan: Callable[[], ObserverPlan] | None,
        t: int,
    ) -> None:
        self.policy, self.plan, self.replan = policy, plan, replan
        self.k = 0 if plan is None else t - plan.t0  # steps into the plan

    def action(self, state: int) -> int:
        if self.plan is not None and self.k >= self.plan.horizon:  # outlived it: re-plan
            assert self.replan is not None
            new_plan = self.replan()
            self.plan, self.k = new_plan, 0
            self.policy = lambda kk, ss: int(new_plan.policy[kk, ss])
        a = self.policy(self.k, state)
        self.k += 1
        return a


def propagate_blind(belief: BeliefFilter | None, t: int) -> None:
    """Advance the belief to step ``t`` without evidence (L no longer watches)."""
    if belief is not None:
        while belief.t < t:
            belief.update(np.full(belief.n_robots, NOT_WATCHING))
