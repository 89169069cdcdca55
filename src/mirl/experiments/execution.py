"""The two halves of a run after learning: L waiting in its room and re-planning until its go
time (:func:`wait_for_go`), then L following its plan while the patrollers move on
(:func:`execute`), in any :class:`~mirl.worlds.contract.RunWorld`."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mirl.experiments.records import Detection, PlanAttempt
from mirl.planning.belief import NOT_WATCHING, BeliefFilter
from mirl.planning.go import ObserverPlan
from mirl.planning.observer import ObserverModel
from mirl.worlds import RunWorld

__all__ = ["Decision", "wait_for_go", "execute", "PlanFollower", "propagate_blind"]


@dataclass(frozen=True)
class Decision:
    """One planning round's outcome, as a go rule's strategy returns it.

    Parameters
    ----------
    plan : ObserverPlan
        The round's plan.
    go_time : int or None
        The absolute step to go at (None: not yet).
    next_round : int
        The step of the next round, unless something happens first (a re-learn, a patroller
        leaving L's view).
    attempt : PlanAttempt
        The round's record.
    """

    plan: ObserverPlan
    go_time: int | None
    next_round: int
    attempt: PlanAttempt


def wait_for_go(
    world: RunWorld,
    decide: Callable[[], Decision],
    observe: Callable[[], bool],
    deadline: int,
    commit: bool,
    timings: dict[str, float],
) -> tuple[ObserverPlan, int | None, list[PlanAttempt]]:
    """L in its room: decide, then keep watching until the go time or the deadline.

    ``decide`` is one planning round (the go rule); ``observe`` takes in the newest step's
    sightings and says whether L's models changed (a re-learn), which calls a new round. A
    round also comes at the step the last one named and — unless ``commit`` holds a go time —
    whenever a patroller leaves L's view (the moment its belief about that robot is sharpest),
    so a newer plan can move or cancel the go time.

    Parameters
    ----------
    world : RunWorld
        The run's world, stepped one step at a time while L waits.
    decide : callable
        ``decide()``: one planning round, a :class:`Decision`.
    observe : callable
        ``observe()``: takes in the newest step's sightings; True if L's models changed.
    deadline : int
        The last step L may wait until (an absolute step).
    commit : bool
        Whether a go time, once chosen, holds when a patroller leaves L's view (the value
        rule's paper protocol) or a new round may move it.
    timings : dict of str to float
        Wall seconds per phase; ``"plan"`` and ``"observe"`` are added to.

    Returns
    -------
    plan : ObserverPlan
        The plan to execute (the last round's).
    go_time : int or None
        The absolute go time (None: the deadline passed without one).
    attempts : list of PlanAttempt
        Every planning round, in order.
    """
    attempts: list[PlanAttempt] = []
    plan: ObserverPlan | None = None
    go_time: int | None = None
    next_plan = world.t
    changed = False
    while True:
        left_view = world.t > 0 and np.any((world.seen[-2] >= 0) & (world.seen[-1] < 0))
        if (
            world.t >= next_plan
            or (left_view and not (commit and go_time is not None))
            or (changed and go_time is None)
        ):
            clock = time.perf_counter()
            decision = decide()
            timings["plan"] += time.perf_counter() - clock
            plan, go_time, next_plan = decision.plan, decision.go_time, decision.next_round
            attempts.append(decision.attempt)
        assert plan is not None
        if go_time is not None and world.t >= go_time:
            return plan, go_time, attempts
        if world.t >= deadline:
            return plan, None, attempts
        clock = time.perf_counter()
        world.step()
        timings["observe"] += time.perf_counter() - clock
        changed = observe()


def execute(
    world: RunWorld,
    model: ObserverModel,
    follower: PlanFollower,
    belief: BeliefFilter | None,
    max_steps: int,
) -> tuple[str, list[tuple[int, ...]], list[Detection]]:
    """L leaves its start cell now and follows its plan (``follower``) until a patroller sees
    it, it reaches its goal, or ``max_steps`` steps have passed.

    Parameters
    ----------
    world : RunWorld
        The run's world; L's moves are its ``step(observer_action=...)``.
    model : ObserverModel
        L's MDP (its domain and start state).
    follower : PlanFollower
        L's step policy.
    belief : BeliefFilter or None
        L's belief about the patrollers, advanced without evidence (None: none kept).
    max_steps : int
        Steps L may take at most.

    Returns
    -------
    outcome : {"detected", "success", "timeout"}
        How the run ended.
    path : list of tuple (t, row, col, heading)
        L's states from its go time on, as L knew them.
    detections : list of Detection
        The sightings that ended the run (empty unless detected).
    """
    dom = model.domain
    s = model.start_state
    path = [(world.t, *map(int, dom.states[s]))]
    propagate_blind(belief, world.t)  # L stopped watching when it left its room
    for _ in range(max_steps):
        world.step(observer_action=follower.action(s))
        propagate_blind(belief, world.t)
        s = world.observer_state()
        path.append((world.t, *map(int, dom.states[s])))
        detections = world.detections()
        if detections:
            return "detected", path, detections
        if world.at_goal():
            return "success", path, []
    return "timeout", path, []


class PlanFollower:
    """L's step policy along its time-indexed plan; when L outlives the plan it re-plans from
    where it stands (``replan``) and follows the new one.

    Parameters
    ----------
    policy : callable
        ``policy(k, state)``: L's action ``k`` steps into the plan, in ``state``.
    plan : ObserverPlan or None
        The plan ``policy`` follows (None: a policy without a horizon, the random baseline's).
    replan : callable or None
        ``replan()``: a new plan from where L stands (needed only with a ``plan``).
    t : int
        The step L starts following it at.
    """

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
        """L's next action, re-planning first if L has outlived its plan.

        Parameters
        ----------
        state : int
            L's state index, as L knows it.

        Returns
        -------
        int
            The action's index.
        """
        if self.plan is not None and self.k >= self.plan.horizon:  # outlived it: re-plan
            assert self.replan is not None
            new_plan = self.replan()
            self.plan, self.k = new_plan, 0
            self.policy = lambda kk, ss: int(new_plan.policy[kk, ss])
        a = self.policy(self.k, state)
        self.k += 1
        return a


def propagate_blind(belief: BeliefFilter | None, t: int) -> None:
    """Advance the belief to step ``t`` without evidence (L no longer watches).

    Parameters
    ----------
    belief : BeliefFilter or None
        The belief (nothing happens if None).
    t : int
        The step to advance it to.
    """
    if belief is not None:
        while belief.t < t:
            belief.update(np.full(belief.n_robots, NOT_WATCHING))
