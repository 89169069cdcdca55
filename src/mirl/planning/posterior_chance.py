"""The chance of getting through averaged over model sets drawn from a posterior: one belief
filter per model set over the same record, and the chance of a plan under each.

The average over K equally weighted draws is a Monte Carlo estimate of the posterior predictive
probability of success, P(success | record) = E[P(success | models, record) | record]
(:mod:`mirl.learning.model_posterior`); its spread over the draws is how much the models' own
uncertainty moves the chance.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from mirl.learning.results import LearnResult
from mirl.planning.belief import BeliefFilter, Prediction
from mirl.planning.go import ObserverPlan, solve_observer_mdp
from mirl.planning.observer import ObserverModel
from mirl.planning.success import success_probability
from mirl.world.domain import PatrolDomain

__all__ = ["PosteriorBeliefs", "AveragedPrediction"]


class AveragedPrediction:
    """The draws' predictions averaged row by row (detection probabilities and first-order
    hazards), in the interface :func:`~mirl.planning.go.solve_observer_mdp` reads: one solve
    on the mixture's per-step hazards instead of one per draw. The planner's chance is itself
    the first-order hazard's approximation; averaging the hazards keeps each step's mixture
    marginal and drops only the draws' correlation across steps."""

    def __init__(self, predictions) -> None:
        self.predictions = list(predictions)
        first = self.predictions[0]
        self.t0, self.steps, self.pairs = first.t0, first.steps, first.pairs

    def hazard_rows(self, lo: int, hi: int) -> np.ndarray:
        return np.mean([p.hazard_rows(lo, hi) for p in self.predictions], axis=0)

    def detection_rows(self, lo: int, hi: int) -> np.ndarray:
        return np.mean([p.detection_rows(lo, hi) for p in self.predictions], axis=0)


class PosteriorBeliefs:
    """K belief filters, one per drawn model set, fed the same record.

    Parameters
    ----------
    domain : PatrolDomain
    draws : sequence of LearnResult
        Model sets drawn from the posterior (equally weighted).
    visible : ndarray of shape (S,) of bool, optional
        The states L sees (negative evidence), as for :class:`BeliefFilter`.
    joint : bool, optional
        As for :class:`BeliefFilter`.
    reference : LearnResult, optional
        The point models, filtered alongside the draws in the same form: :meth:`shifts` then
        gives each draw's chance less the reference's, so that the draws can be filtered in the
        cheap factored form and their change applied to the point models' exact chance.
    """

    def __init__(
        self,
        domain: PatrolDomain,
        draws: Sequence[LearnResult],
        *,
        visible: np.ndarray | None = None,
        joint: bool | None = None,
        reference: LearnResult | None = None,
    ) -> None:
        if not draws:
            raise ValueError("no draws: the posterior needs at least one model set")
        self.draws = tuple(draws)
        self.filters = [BeliefFilter(domain, m, visible=visible, joint=joint) for m in draws]
        self.reference = (
            None
            if reference is None
            else BeliefFilter(domain, reference, visible=visible, joint=joint)
        )
        self.kept: dict[int, list[np.ndarray]] = {}

    @property
    def t(self) -> int:
        return self.filters[0].t

    def update(self, observed) -> None:
        """One step of every filter (:meth:`BeliefFilter.update`)."""
        for f in self.filters:
            f.update(observed)
        if self.reference is not None:
            self.reference.update(observed)

    def run(self, record) -> None:
        """Feed the steps of ``record`` after the filters' current step."""
        for now in record[self.t + 1 :]:
            self.update(now)

    def keep(self) -> None:
        """Keep every filter's current belief, for :meth:`chances_at` its step."""
        assert self.filters[0].belief is not None
        self.kept[self.t] = [f.belief for f in self.filters]  # type: ignore[misc]

    def success(self, model: ObserverModel, plan: ObserverPlan, *, extra: int = 0) -> np.ndarray:
        """(K,) P(success) of going now along ``plan`` under each draw
        (:func:`~mirl.planning.success.success_probability`)."""
        return np.array(
            [success_probability(f, model, plan, extra=extra).success for f in self.filters]
        )

    def shifts(self, model: ObserverModel, plan: ObserverPlan, *, extra: int = 0) -> np.ndarray:
        """(K,) each draw's P(success) along ``plan`` less the reference models' (both in this
        object's filter form): added to the reference's exact chance, a control-variate
        estimate of each draw's exact chance."""
        assert self.reference is not None, "shifts() needs the reference models"
        base = success_probability(self.reference, model, plan, extra=extra).success
        return self.success(model, plan, extra=extra) - base

    def averaged_chance(
        self, model: ObserverModel, steps: int, window: int = 0, *, t: int | None = None
    ) -> float:
        """The planner's chance of going now (or at kept step ``t``) on the draws' averaged
        prediction (:class:`AveragedPrediction`): one solve for all draws."""
        if t is None:
            preds = [f.predict(steps, model) for f in self.filters]
        else:
            preds = [
                f.predict(steps, model, belief=b, t=t)
                for f, b in zip(self.filters, self.kept[t], strict=True)
            ]
        # the planner reads a prediction's steps, t0, pairs and rows only
        averaged = cast(Prediction, AveragedPrediction(preds))
        plan = solve_observer_mdp(
            model, averaged, window=window, goal_reward=1.0,
            detection_penalty=0.0, min_value=-1.0,
        )  # fmt: skip
        return float(plan.go_values[0])

    def chances_at(
        self, t: int, model: ObserverModel, steps: int, *, hazard: str = "markov"
    ) -> np.ndarray:
        """(K,) the planner's chance of going at kept step ``t`` under each draw (its go-now
        value with the success objective), as the go rule scores a moment."""
        out = []
        for f, b in zip(self.filters, self.kept[t], strict=True):
            prediction = f.predict(steps, model, belief=b, t=t)
            plan = solve_observer_mdp(
                model, prediction, window=0, goal_reward=1.0, detection_penalty=0.0,
                min_value=-1.0, hazard=hazard,
            )  # fmt: skip
            out.append(float(plan.go_values[0]))
        return np.array(out)

    def planner_now(
        self, model: ObserverModel, steps: int, window: int, *, hazard: str = "markov"
    ) -> np.ndarray:
        """(K,) the planner's chance of going now under each draw."""
        out = []
        for f in self.filters:
            prediction = f.predict(steps, model)
            plan = solve_observer_mdp(
                model, prediction, window=window, goal_reward=1.0, detection_penalty=0.0,
                min_value=-1.0, hazard=hazard,
            )  # fmt: skip
            out.append(float(plan.go_values[0]))
        return np.array(out)
