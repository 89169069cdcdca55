"""The go rules: how L, waiting in its room, decides when to go — one strategy per row of
:data:`~mirl.experiments.options.GO_RULES`.

A strategy is a class with ``decide(waiting)``, one planning round (:class:`Waiting`: the world's
clock, L's model, its current belief and the planning settings; it returns a
:class:`~mirl.experiments.execution.Decision`), and ``replan_penalty(planning)``, the detection
penalty of the plans L makes once it has left its room and outlives its plan. Adding a rule is a
class here and a row of the table (docs/design.md, "The go rule").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from mirl.experiments.execution import Decision
from mirl.experiments.records import PlanAttempt
from mirl.learning.results import LearnResult
from mirl.planning.belief import BeliefFilter
from mirl.planning.chance_calibration import MIRL_RUN
from mirl.planning.go import ObserverPlan, solve_observer_mdp, waiting_value
from mirl.planning.observer import ObserverModel
from mirl.planning.posterior_chance import PosteriorBeliefs, StatedChance, posterior_beliefs
from mirl.planning.success import success_probability
from mirl.world.scenario import Scenario
from mirl.worlds import RunWorld

__all__ = [
    "Planning",
    "Waiting",
    "Watching",
    "GoRuleStrategy",
    "ValueRule",
    "AdaptiveRule",
    "PosteriorAdaptiveRule",
]


@dataclass(frozen=True)
class Planning:
    """How L plans in a run, from the run's :class:`~mirl.experiments.options.RunProtocol`.

    Parameters
    ----------
    window : int
        Go times a round scores after now.
    deadline : int
        The last step at which L may still go (the end of observing + ``max_wait``).
    travel : int
        The planning horizon after the last go time.
    replan_every : int
        Steps between planning rounds while no go time is set.
    commit : bool
        Whether the first go time is kept.
    hazard : str
        The planner's detection hazard (:data:`mirl.planning.go.HAZARDS`).
    goal_reward : float
        The planner's reward for reaching the goal.
    detection_penalty : float
        The value rule's cost of being seen.
    opportunity_steps : int
        The adaptive rule's steps per fresh chance to go after the window.
    moment_travel : int
        The horizon of the plans that score the record's moments.
    """

    window: int
    deadline: int
    travel: int
    replan_every: int
    commit: bool
    hazard: str
    goal_reward: float
    detection_penalty: float
    opportunity_steps: int
    moment_travel: int


class Watching(Protocol):
    """L's view from its room as a go rule reads it: its current belief (``belief``) under its
    current models (``learned``, of ``scenario``'s patrollers; the filter's negative evidence
    ``visible``), and what going at each of the record's moments promised."""

    belief: BeliefFilter
    learned: LearnResult
    scenario: Scenario
    visible: np.ndarray | None

    def chances(self, chance_at: Callable[[int, np.ndarray], float]) -> list[float]:
        """What going at each of the record's moments promised, computed once per moment and
        models.

        Parameters
        ----------
        chance_at : callable
            ``chance_at(t, belief)``: the chance of going at step t with that step's belief.

        Returns
        -------
        list of float
            One chance per moment, in the record's order.
        """
        ...


@dataclass(frozen=True)
class Waiting:
    """What a planning round reads.

    Parameters
    ----------
    world : RunWorld
        The run's world (its step).
    watcher : Watching
        L's view from its room: its belief and the record's chances.
    model : ObserverModel
        L's model.
    planning : Planning
        The planning settings.
    random_state : int, default 0
        Seeds the stated chance's model draws (from the run's seed).
    calibration : str or None, default "mirl-run"
        The protocol whose held-out calibration the stated chance goes through
        (:func:`~mirl.planning.chance_calibration.calibration_protocols`); None: none, and L
        states its averaged chance. The maps were fitted under their protocol, in their worlds,
        with the default learning options, so a run under others has none.
    """

    world: RunWorld
    watcher: Watching
    model: ObserverModel
    planning: Planning
    random_state: int = 0
    calibration: str | None = MIRL_RUN

    def solve(
        self, steps: int, window: int, penalty: float, min_value: float = 0.0
    ) -> ObserverPlan:
        """L's time-indexed MDP over the next steps of its current prediction.

        Parameters
        ----------
        steps : int
            The prediction's steps (the plan's horizon).
        window : int
            Go times scored after now.
        penalty : float
            The cost of being seen.
        min_value : float, default 0.0
            A go time needs a value above this.

        Returns
        -------
        ObserverPlan
            The plan.
        """
        p = self.planning
        return solve_observer_mdp(
            self.model,
            self.watcher.belief.predict(steps, self.model),
            window=window,
            goal_reward=p.goal_reward,
            detection_penalty=penalty,
            min_value=min_value,
            hazard=p.hazard,
        )


class GoRuleStrategy:
    """A go rule (module docstring): the interface its strategies implement."""

    def decide(self, waiting: Waiting) -> Decision:
        """One planning round.

        Parameters
        ----------
        waiting : Waiting
            What the round reads.

        Returns
        -------
        Decision
            The plan, the go time (None: not yet), the next round's step and the round's
            record.
        """
        raise NotImplementedError

    def replan_penalty(self, planning: Planning) -> float:
        """The detection penalty of the plans L makes once it has left its room.

        Parameters
        ----------
        planning : Planning
            The run's planning settings.

        Returns
        -------
        float
            The penalty.
        """
        raise NotImplementedError


class ValueRule(GoRuleStrategy):
    """The published rule: the best go value in the window, if positive; the detection penalty
    weighs being seen against reaching the goal."""

    def decide(self, waiting: Waiting) -> Decision:
        t, p = waiting.world.t, waiting.planning
        win = min(p.window, p.deadline - t)
        plan = waiting.solve(win + p.travel, win, p.detection_penalty)
        go_time = None if plan.go_time is None else t + plan.go_time
        attempt = PlanAttempt(t, float(plan.go_values.max()), go_time)
        next_round = t + p.replan_every if go_time is None else p.deadline + 1
        return Decision(plan, go_time, next_round, attempt)

    def replan_penalty(self, planning: Planning) -> float:
        return planning.detection_penalty


class AdaptiveRule(GoRuleStrategy):
    """Go now when the window's best go time is now and its chance beats the value of the
    chances still to come before the deadline, drawn like those of the record's moments; on
    going, state P(success) averaged over model sets drawn from the posterior of L's models,
    with its spread (docs/design.md, "The go rule" and "The stated chance"). Plans maximise
    P(success): no detection penalty."""

    def __init__(self) -> None:
        self._posterior = _Posterior()

    def decide(self, waiting: Waiting) -> Decision:
        t, p = waiting.world.t, waiting.planning
        win = min(p.window, p.deadline - t)
        plan = waiting.solve(win + p.travel, win, 0.0, min_value=-1.0)  # P(success) objective
        best = plan.go_time if plan.go_time is not None else 0
        go = win == 0
        stated = None
        if not go and best == 0:  # a later go time in the window is better: wait for it
            later = (p.deadline - t - win) // p.opportunity_steps
            chances = waiting.watcher.chances(lambda tt, b: _chance_at(waiting, tt, b))
            value = waiting_value(chances, later)
            go, stated = self._goes(waiting, plan, value)
        if go and stated is None:
            stated = self._posterior.stated(waiting, plan)
        go_time = t if go else None
        step = best if 0 < best < p.replan_every else p.replan_every
        attempt = PlanAttempt(
            t, float(plan.go_values.max()), go_time,
            *(() if stated is None else (
                stated.mean, stated.interval, stated.point, stated.averaged,
                stated.averaged_interval)),
        )  # fmt: skip
        return Decision(plan, go_time, t + step, attempt)

    def _goes(
        self, waiting: Waiting, plan: ObserverPlan, value: float
    ) -> tuple[bool, StatedChance | None]:
        """Whether going now beats waiting (worth ``value``), and the stated chance if this
        round computed it: the planner's go-now chance against the value."""
        return float(plan.go_values[0]) >= value, None

    def replan_penalty(self, planning: Planning) -> float:
        return 0.0


class PosteriorAdaptiveRule(AdaptiveRule):
    """The adaptive rule acting on the posterior chance: where the adaptive rule would go, the
    planner's go-now chance is scaled by the stated (posterior-averaged) chance over the point
    models' exact chance along the same plan, and L goes only if that still beats the value of
    waiting (docs/design.md, "The go rule")."""

    def _goes(
        self, waiting: Waiting, plan: ObserverPlan, value: float
    ) -> tuple[bool, StatedChance | None]:
        now = float(plan.go_values[0])
        if now < value:
            return False, None
        stated = self._posterior.stated(waiting, plan)
        averaged = stated.mean if stated.averaged is None else stated.averaged
        return now * averaged / max(stated.point, 1e-9) >= value, stated


class _Posterior:
    """The stated chance's filters (:func:`~mirl.planning.posterior_chance.posterior_beliefs`)
    for L's current models: drawn when the models change, fed the record as it grows."""

    def __init__(self) -> None:
        self.learned: LearnResult | None = None
        self.beliefs: PosteriorBeliefs | None = None

    def stated(self, waiting: Waiting, plan: ObserverPlan) -> StatedChance:
        """The chance L states on going now along ``plan``."""
        watcher, travel = waiting.watcher, waiting.planning.travel
        point = success_probability(watcher.belief, waiting.model, plan, extra=travel).success
        record = waiting.world.seen
        if watcher.learned is not self.learned:
            self.learned = watcher.learned
            self.beliefs = posterior_beliefs(
                watcher.learned, record, watcher.scenario, visible=waiting.world.visible,
                filter_visible=watcher.visible, random_state=waiting.random_state,
            )  # fmt: skip
        if self.beliefs is None:
            return StatedChance(point, (point, point), point)
        self.beliefs.run(record)
        stated = self.beliefs.stated(point, waiting.model, plan, extra=travel)
        if waiting.calibration is None:
            return stated
        view = float(np.mean(waiting.world.visible))
        return stated.calibrated(watcher.learned.method, view, waiting.calibration)


def _chance_at(waiting: Waiting, t: int, belief: np.ndarray) -> float:
    """The planner's P(success) of going at step ``t`` of the record with that step's belief,
    along the best plan for going then (window 0)."""
    p = waiting.planning
    prediction = waiting.watcher.belief.predict(p.moment_travel, waiting.model, belief=belief, t=t)
    plan = solve_observer_mdp(
        waiting.model, prediction, window=0, goal_reward=p.goal_reward,
        detection_penalty=0.0, min_value=-1.0, hazard=p.hazard,
    )  # fmt: skip
    return float(plan.go_values[0])
