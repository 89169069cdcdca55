"""A run in the physical world (``--world physics``): the same protocol as the grid's
(:mod:`mirl.experiments.episode`) with :class:`mirl.physics.patrol.PhysicalWorld` in place of
the grid simulator.

Only the world changes. L learns from what its camera saw (discretised pose measurements) and
plans on the grid with the unchanged code; then it *drives* its time-indexed plan with the same
controller as the patrollers: each decision step it discretises its own estimated pose, takes
the plan's action there and the controller drives. The patrollers' cameras watch for it at
10 Hz once it is out of its room. ``success``: L's centre inside the goal cell, unseen;
``detected``: a patroller's camera saw it; ``timeout``: as on the grid.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mirl.experiments.execution import PlanFollower, propagate_blind
from mirl.experiments.records import Detection
from mirl.observations.trajectories import Trajectories
from mirl.physics.patrol import PhysicalWorld
from mirl.planning.belief import BeliefFilter
from mirl.planning.go import ObserverPlan
from mirl.planning.observer import ObserverModel
from mirl.world.scenario import Scenario

__all__ = ["PhysicalRunWorld", "execute_physical"]


class PhysicalRunWorld:
    """The interface of :class:`mirl.experiments.execution.RunWorld` over the physics."""

    def __init__(
        self,
        scenario: Scenario,
        observability: float,
        seed: int,
        *,
        observer_heading: int | None = None,
        config=None,
    ) -> None:
        self.physics = PhysicalWorld(
            scenario,
            config=config,
            observability=observability,
            seed=seed,
            random_starts=True,
            observer_heading=observer_heading,
        )
        self.sim = self.physics  # .visible, like the grid simulator
        self.domain = scenario.domain
        self.true = self.physics.true
        self.seen = self.physics.seen

    @property
    def t(self) -> int:
        return self.physics.t

    def step(self, observer_action: int | None = None) -> np.ndarray:
        return self.physics.step(observer_action)

    def observations(self, names: tuple[str, ...], until: int) -> Trajectories:
        return Trajectories.from_states(self.domain, names, np.asarray(self.seen[: until + 1]))


def execute_physical(
    world: PhysicalRunWorld,
    model: ObserverModel,
    policy: Callable[[int, int], int],
    plan: ObserverPlan | None,
    rng: np.random.Generator,
    belief: BeliefFilter | None,
    replan: Callable[[], ObserverPlan] | None,
    max_steps: int,
    names: tuple[str, ...],
):
    """L drives ``policy(k, state)`` from its start cell now; the same contract as
    :func:`mirl.experiments.execution.execute` (``rng`` is unused: L's failures are physical)."""
    phys = world.physics
    dom = model.domain
    s = model.start_state
    follower = PlanFollower(policy, plan, replan, world.t)
    path = [(world.t, *map(int, dom.states[s]))]
    propagate_blind(belief, world.t)
    goal = {tuple(map(int, dom.states[g][:2])) for g in np.flatnonzero(model.goal)}
    for _ in range(max_steps):
        a = follower.action(s)
        n_seen = len(phys.sightings)
        world.step(observer_action=a)
        propagate_blind(belief, world.t)
        r, c, h = phys.observer_cell_heading(estimated=True)
        est = int(dom.state_index(r, c, h))
        s = est if est >= 0 else int(dom.intended[s, a])  # off L's map: where it meant to be
        path.append((world.t, *map(int, dom.states[s])))
        if len(phys.sightings) > n_seen:
            sg = phys.sightings[n_seen]
            truth = world.true[-1]
            lr, lc, _ = phys.observer_cell_heading(estimated=False)
            rr, rc, rh = map(int, world.domain.states[truth[sg.robot]])
            dets = [Detection(world.t, names[sg.robot], (rr, rc, rh), (int(lr), int(lc)))]
            return "detected", path, dets, follower.plan
        true_cell = phys.observer_cell_heading(estimated=False)[:2]
        if tuple(map(int, true_cell)) in goal:
            return "success", path, [], follower.plan
    return "timeout", path, [], follower.plan
