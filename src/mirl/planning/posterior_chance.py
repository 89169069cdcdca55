"""The chance of getting through averaged over model sets drawn from a posterior: one belief
filter per model set over the same record, and the chance of a plan under each.

The average over K equally weighted draws is a Monte Carlo estimate of the posterior predictive
probability of success, P(success | record) = E[P(success | models, record) | record]
(:mod:`mirl.learning.model_posterior`); its spread over the draws is how much the models' own
uncertainty moves the chance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import cast

import numpy as np

from mirl.learning.methods import get_method
from mirl.learning.model_posterior import draw_models
from mirl.learning.results import LearnResult
from mirl.planning.belief import BeliefFilter, FactoredFilterStack, Prediction
from mirl.planning.chance_calibration import MIRL_RUN, calibrate_chance
from mirl.planning.go import ObserverPlan, solve_observer_mdp
from mirl.planning.observer import ObserverModel
from mirl.planning.success import success_probability
from mirl.world.domain import PatrolDomain
from mirl.world.scenario import Scenario

__all__ = [
    "PosteriorBeliefs",
    "AveragedPrediction",
    "StatedChance",
    "posterior_beliefs",
    "STATED_DRAWS",
    "STATED_REWARD_DRAWS",
    "STATED_QUANTILES",
]

STATED_DRAWS = 8
"""Model sets the stated chance averages over (docs/design.md, "The stated chance")."""
STATED_REWARD_DRAWS = "laplace-sir"
"""How the stated chance's draws vary each robot's reward
(:data:`~mirl.learning.model_posterior.REWARD_DRAWS`)."""
STATED_QUANTILES = (0.05, 0.95)
"""The quantiles of the per-draw chances that ``predicted_success_interval`` gives."""


class AveragedPrediction:
    """The draws' predictions averaged row by row (detection probabilities and first-order
    hazards), in the interface :func:`~mirl.planning.go.solve_observer_mdp` reads: one solve
    on the mixture's per-step hazards instead of one per draw. The planner's chance is itself
    the first-order hazard's approximation; averaging the hazards keeps each step's mixture
    marginal and drops only the draws' correlation across steps.

    Parameters
    ----------
    predictions : sequence of Prediction
        The draws' predictions over the same steps.
    """

    def __init__(self, predictions) -> None:
        self.predictions = list(predictions)
        first = self.predictions[0]
        self.t0, self.steps, self.pairs = first.t0, first.steps, first.pairs

    def hazard_rows(self, lo: int, hi: int) -> np.ndarray:
        """The draws' first-order hazards of steps ``lo`` … ``hi`` − 1, averaged.

        Parameters
        ----------
        lo, hi : int
            The steps.

        Returns
        -------
        ndarray
            The rows, as :class:`~mirl.planning.belief.Prediction` gives them.
        """
        return np.mean([p.hazard_rows(lo, hi) for p in self.predictions], axis=0)

    def detection_rows(self, lo: int, hi: int) -> np.ndarray:
        """The draws' detection probabilities of steps ``lo`` … ``hi`` − 1, averaged.

        Parameters
        ----------
        lo, hi : int
            The steps.

        Returns
        -------
        ndarray
            The rows, as :class:`~mirl.planning.belief.Prediction` gives them.
        """
        return np.mean([p.detection_rows(lo, hi) for p in self.predictions], axis=0)


class PosteriorBeliefs:
    """K belief filters, one per drawn model set, fed the same record.

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain.
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
        every = self.filters + ([] if self.reference is None else [self.reference])
        # factored filters (the stated chance's) step together: one product for all of them
        self._stack = (
            FactoredFilterStack(every) if FactoredFilterStack.stackable(every) else None
        )

    @property
    def t(self) -> int:
        """The filters' current step (-1 before the first)."""
        return self.filters[0].t

    def update(self, observed) -> None:
        """One step of every filter (:meth:`BeliefFilter.update`).

        Parameters
        ----------
        observed : ndarray of shape (N,)
            What L saw of each patroller at the step (-1: unseen).
        """
        if self._stack is not None:
            self._stack.update(observed)
            return
        for f in self.filters:
            f.update(observed)
        if self.reference is not None:
            self.reference.update(observed)

    def run(self, record) -> None:
        """Feed the steps of ``record`` after the filters' current step.

        Parameters
        ----------
        record : sequence of ndarray of shape (N,)
            What L saw at every step from step 0.
        """
        for now in record[self.t + 1 :]:
            self.update(now)

    def keep(self) -> None:
        """Keep every filter's current belief, for :meth:`chances_at` its step."""
        assert self.filters[0].belief is not None
        self.kept[self.t] = [f.belief for f in self.filters]  # type: ignore[misc]

    def success(self, model: ObserverModel, plan: ObserverPlan, *, extra: int = 0) -> np.ndarray:
        """P(success) of going now along ``plan`` under each draw
        (:func:`~mirl.planning.success.success_probability`).

        Parameters
        ----------
        model : ObserverModel
            L's model.
        plan : ObserverPlan
            The plan L goes along.
        extra : int, default 0
            The plan's steps after its go time.

        Returns
        -------
        ndarray of shape (K,)
            One chance per draw.
        """
        return np.array(
            [success_probability(f, model, plan, extra=extra).success for f in self.filters]
        )

    def shifts(self, model: ObserverModel, plan: ObserverPlan, *, extra: int = 0) -> np.ndarray:
        """Each draw's P(success) along ``plan`` less the reference models' (both in this
        object's filter form): added to the reference's exact chance, a control-variate
        estimate of each draw's exact chance.

        Parameters
        ----------
        model : ObserverModel
            L's model.
        plan : ObserverPlan
            The plan L goes along.
        extra : int, default 0
            The plan's steps after its go time.

        Returns
        -------
        ndarray of shape (K,)
            One shift per draw.
        """
        assert self.reference is not None, "shifts() needs the reference models"
        base = success_probability(self.reference, model, plan, extra=extra).success
        return self.success(model, plan, extra=extra) - base

    def stated(
        self, point: float, model: ObserverModel, plan: ObserverPlan, *, extra: int = 0
    ) -> StatedChance:
        """The stated chance along ``plan``: each draw's chance the point models' exact
        ``point`` plus its :meth:`shifts` (a control variate: the exact filter's accuracy at
        the factored filter's cost), clipped to [0, 1]; their mean and quantiles.

        Parameters
        ----------
        point : float
            The point models' exact P(success) along ``plan``.
        model : ObserverModel
            L's model.
        plan : ObserverPlan
            The plan L goes along.
        extra : int, default 0
            The plan's steps after its go time.

        Returns
        -------
        StatedChance
            The mean of the per-draw chances, their :data:`STATED_QUANTILES`, ``point`` and the
            per-draw chances.
        """
        chances = np.clip(point + self.shifts(model, plan, extra=extra), 0.0, 1.0)
        lo, hi = np.quantile(chances, STATED_QUANTILES)
        return StatedChance(float(chances.mean()), (float(lo), float(hi)), point, tuple(chances))

    def averaged_chance(
        self, model: ObserverModel, steps: int, window: int = 0, *, t: int | None = None
    ) -> float:
        """The planner's chance of going now (or at kept step ``t``) on the draws' averaged
        prediction (:class:`AveragedPrediction`): one solve for all draws.

        Parameters
        ----------
        model : ObserverModel
            L's model.
        steps : int
            The prediction's steps.
        window : int, default 0
            Go times scored after now.
        t : int, optional
            A step kept by :meth:`keep` (default: now).

        Returns
        -------
        float
            The go-now value with the success objective.
        """
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
        """The planner's chance of going at kept step ``t`` under each draw (its go-now value
        with the success objective), as the go rule scores a moment.

        Parameters
        ----------
        t : int
            A step kept by :meth:`keep`.
        model : ObserverModel
            L's model.
        steps : int
            The prediction's steps.
        hazard : str, default "markov"
            The planner's detection hazard.

        Returns
        -------
        ndarray of shape (K,)
            One chance per draw.
        """
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
        """The planner's chance of going now under each draw.

        Parameters
        ----------
        model : ObserverModel
            L's model.
        steps : int
            The prediction's steps.
        window : int
            Go times scored after now.
        hazard : str, default "markov"
            The planner's detection hazard.

        Returns
        -------
        ndarray of shape (K,)
            One chance per draw.
        """
        out = []
        for f in self.filters:
            prediction = f.predict(steps, model)
            plan = solve_observer_mdp(
                model, prediction, window=window, goal_reward=1.0, detection_penalty=0.0,
                min_value=-1.0, hazard=hazard,
            )  # fmt: skip
            out.append(float(plan.go_values[0]))
        return np.array(out)


@dataclass(frozen=True)
class StatedChance:
    """The chance L states when it goes.

    Parameters
    ----------
    mean : float
        The chance averaged over the model draws (the posterior predictive P(success)); the
        point models' chance when nothing is drawn.
    interval : tuple of (float, float)
        The :data:`STATED_QUANTILES` of the per-draw chances (linear interpolation).
    point : float
        The point models' exact chance along the same plan.
    draws : tuple of float
        The per-draw chances (empty when nothing is drawn).
    averaged : float or None, default None
        The chance averaged over the draws before the method's held-out calibration
        (:mod:`mirl.planning.chance_calibration`) mapped it to ``mean``; None when uncalibrated.
    averaged_interval : tuple of (float, float) or None, default None
        The per-draw chances' quantiles before the calibration mapped them to ``interval``
        (None when uncalibrated): with ``averaged``, what a map is refitted from.
    """

    mean: float
    interval: tuple[float, float]
    point: float
    draws: tuple[float, ...] = ()
    averaged: float | None = None
    averaged_interval: tuple[float, float] | None = None

    def calibrated(self, method: str, view: float, protocol: str = MIRL_RUN) -> StatedChance:
        """This chance as ``method``'s held-out calibration states it.

        Parameters
        ----------
        method : str
            The method that learned the models.
        view : float
            The fraction of the patrollers' states L sees.
        protocol : str, default MIRL_RUN
            The run protocol whose maps apply
            (:func:`~mirl.planning.chance_calibration.calibration_protocols`).

        Returns
        -------
        StatedChance
            ``mean`` and ``interval`` mapped, ``averaged`` and ``averaged_interval`` what they
            were mapped from; this one unchanged when the method has no map or nothing was
            drawn.
        """
        if not self.draws or self.averaged is not None:
            return self
        mapped = calibrate_chance(method, self.mean, self.interval, view, protocol)
        if mapped is None:
            return self
        return replace(
            self, mean=mapped[0], interval=mapped[1], averaged=self.mean,
            averaged_interval=self.interval,
        )  # fmt: skip


def posterior_beliefs(
    learned: LearnResult,
    record: Sequence[np.ndarray],
    scenario: Scenario,
    *,
    visible: np.ndarray,
    filter_visible: np.ndarray | None = None,
    n_draws: int = STATED_DRAWS,
    random_state: int = 0,
) -> PosteriorBeliefs | None:
    """The filters of the stated chance (docs/design.md, "The stated chance"): ``n_draws``
    model sets drawn from the posterior of ``learned``'s models and the point models, each
    filtered factored; feed them the record with :meth:`PosteriorBeliefs.run` and read the
    chance with :meth:`PosteriorBeliefs.stated`.

    The draws (:func:`~mirl.learning.model_posterior.draw_models`) take T from the feature
    posterior, each robot's reward from a Laplace approximation at the IRL optimum corrected by
    importance resampling (:data:`STATED_REWARD_DRAWS`) and mixed with the team's shared-kind
    hypothesis, and the equilibrium by its weights.

    Parameters
    ----------
    learned : LearnResult
        The point models L plans with.
    record : sequence of ndarray of shape (N,)
        What L saw at every step so far (-1: unseen), the world's ``seen``; the draws are
        made from its first ``learned.horizon`` steps, the record the models were learned from.
    scenario : Scenario
        The scenario L models (its domain, discount, game and error model).
    visible : ndarray of shape (S,) of bool
        The states L sees (what the rewards were learned under).
    filter_visible : ndarray of shape (S,) of bool, optional
        The filters' negative evidence (as for :class:`BeliefFilter`; None: none).
    n_draws : int, default :data:`STATED_DRAWS`
        Model sets drawn.
    random_state : int, default 0
        Seeds the draws.

    Returns
    -------
    PosteriorBeliefs or None
        The filters (not yet fed), with the point models as their reference; None when the
        method learns nothing (the oracle) or ``n_draws`` is 0: the point chance is then the
        stated one.
    """
    if n_draws == 0 or not get_method(learned.method).learns:
        return None
    horizon = learned.horizon or len(record)
    series = list(np.asarray(record[:horizon]).T)
    draws = draw_models(
        learned, series, scenario, visible=visible, n_draws=n_draws,
        reward=STATED_REWARD_DRAWS, shared=True, random_state=random_state,
    )  # fmt: skip
    return PosteriorBeliefs(
        scenario.domain, draws, visible=filter_visible, joint=False, reference=learned
    )
