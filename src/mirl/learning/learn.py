"""What L learns from its observations: every method of :mod:`mirl.learning.methods` behind one
entry point, :func:`learn`, with the steps of its rounds.

A method is a row of :data:`~mirl.learning.methods.METHODS` naming where its models come from,
and :func:`learn` builds them from those sources:

* the reward and interaction equilibrium: learned (occluded max-ent IRL,
  :class:`mirl.learning.irl.OccludedMaxEntIRL`, leaving out the observed steps where two robots
  could be interacting, then the game's candidate equilibria weighed against everything L saw,
  :func:`mirl.learning.equilibria.weigh_team_equilibria`), or the scenario's truth;
* each robot's T: learned from labelled steps (mIRL*/T, its transition-feature probabilities,
  :class:`mirl.learning.transitions.TransitionFeatureLearner`), one success probability ``p``
  for every action (no per-feature probabilities: ``feature_probabilities = {}``, ``p`` in the
  result's ``message``), DBN-EM (:func:`mirl.learning.dbn_em.em_transitions`), or the
  truth (:func:`mirl.learning.results.oracle_models`).

Steps are labelled with actions by perception (the action whose intended state is s_{t+1},
:func:`mirl.learning.transitions.perception_labels`), or, where the reward is the truth, by the
true policies. A method that relabels (``mirl-t``, mIRL*/T+Int, Sec. 3.6) runs rounds:

1. label every observed step (s_t, s_{t+1}) by perception — or, warm-started from an earlier
   solution (``warm_start``: a re-learn on a grown record), the steps that solution learned
   from with the labels its policies and equilibrium give them (the fixed point its own rounds
   reached) and only the new steps by perception;
2. learn each robot's transition-feature probabilities and T from the labelled steps;
3. learn each robot's reward by occluded max-ent IRL with that T, and pick the equilibrium
   under which the evident meetings are most likely;
4. relabel every observed step with the learned policy's action, or that equilibrium's at an
   evident meeting (:func:`mirl.learning.transitions.policy_labels`) — a perceived turn where the
   policy says forward becomes a *failed* forward — and go back to 2, until at most
   ``label_tol`` of the labelled steps change (default 1 %; 0: none may change) or
   ``max_iterations`` rounds have run. Rounds after the first start the IRL from the previous
   weights (one start instead of ``n_restarts``), and so does a warm start's first round, from
   the earlier solution's.

A warm start saves rounds, not the work of a round: every round, and the final weighing of the
equilibria, runs on the whole grown record, and none of the earlier solution's T, IRL or
weighing is exact for it.

A method that does not relabel learns its T from the first labels (its labels could only change
T) and its reward once (from a warm start's weights, when given). The equilibria are weighed by
the joint filter once, for the final models.

A method with feature probabilities learns each robot's T under a motion model (ξ and where
failed steps end): the scenario's, unless the robot's record rejects it — its verdict's motion
models (:mod:`mirl.learning.motion_models`) make another :data:`SWITCH_ODDS` times more probable,
or L's policy does not predict its moves — and then once more under the model its record favours
(docs/design.md, "Fault verdicts", "What L learns and plans with").

Every learned policy is the greedy policy of hard value iteration with the learned weights and that
robot's T. ``behavior_accuracy`` (docs/design.md, "Behaviour accuracy") is filled in from the
scenario's truth when ``score=True``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from mirl._registry import Registry
from mirl._validation import SEED, Boolean, Interval, check_argument
from mirl.learning.dbn_em import em_transitions
from mirl.learning.equilibria import (
    EquilibriumWeights,
    TeamEquilibria,
    meeting_log_likelihood,
    potential_meetings,
    weigh_team_equilibria,
)
from mirl.learning.irl import IRLProblem, OccludedMaxEntIRL
from mirl.learning.methods import (
    LEARNING_METHODS,
    REWARD_SOURCES,
    TRANSITION_SOURCES,
    Method,
    get_method,
)
from mirl.learning.motion_models import (
    MotionModel,
    candidate_models,
    fold_mirrors,
    model_domain,
    unexplained_steps,
)
from mirl.learning.options import LearnOptions
from mirl.learning.results import LearnResult, RobotModel, behavior_accuracy, oracle_models
from mirl.learning.transitions import (
    TransitionFeatureLearner,
    observed_steps,
    perceived_labels,
    policy_labels,
    true_policy_labels,
)
from mirl.learning.verdicts import (
    FeatureUncertainty,
    compared_with_team,
    record_off_pace,
    robot_record,
    robot_uncertainty,
)
from mirl.mdp import TabularMDP, value_iteration
from mirl.observations.trajectories import Trajectories
from mirl.world.game import Equilibrium
from mirl.world.motion import transition_matrix_from_success
from mirl.world.scenario import Scenario, as_scenario

__all__ = [
    "learn",
    "LoopTrace",
    "relabel_loop",
    "RewardBuilder",
    "TransitionBuilder",
    "REWARD_BUILDERS",
    "TRANSITION_BUILDERS",
]


def learn(
    observations: Trajectories,
    scenario: Scenario | str,
    method: str = "mirl-t",
    *,
    options: LearnOptions | Mapping[str, Any] | None = None,
    visible: np.ndarray | None = None,
    observability: float | None = None,
    random_state: int | None = 0,
    score: bool = True,
    trace: LoopTrace | None = None,
    warm_start: LearnResult | None = None,
) -> LearnResult:
    """Learn models of the scenario's patrollers from L's ``observations`` with ``method``.

    .. versionchanged:: 0.2.0
       The options (``p``, ``max_iterations``, ``label_tol``, ``objective``, ``optimizer``,
       ``n_restarts``, ``irl_options``, ``em_init``) are one ``options`` argument.

    Parameters
    ----------
    observations : Trajectories
        What L saw of the patrollers (their names those of the scenario's robots).
    scenario : Scenario or str
        The world and robots, or the name or path :func:`~mirl.world.scenario.load_scenario`
        takes.
    method : str, default "mirl-t"
        One of :data:`~mirl.learning.methods.LEARNING_METHODS` (the rows of
        :data:`~mirl.learning.methods.METHODS` with models to build).
    options : LearnOptions or mapping, optional
        How to learn (:class:`~mirl.learning.options.LearnOptions`: the fixed ``p``, the
        relabelling rounds, the IRL's objective and optimiser, DBN-EM's initialisation), or a
        mapping of its option names to values; by default its defaults. An option that changes
        nothing for ``method`` (``p`` for a method that learns T) is refused.
    visible : ndarray of shape (S,) of bool, optional
        The states L can see; by default those of ``observability``.
    observability : float, optional
        Share of the map L sees, when ``visible`` is not given (default: the scenario's).
    random_state : int or None, default 0
        Seeds every random choice (the IRL's restarts); None counts as 0, so learning is
        deterministic.
    score : bool, default True
        Fill in each model's ``behavior_accuracy`` (docs/design.md, "Behaviour accuracy") from the
        scenario's truth.
    trace : LoopTrace, optional
        An empty trace to receive the labels, estimators and weighings of every round.
    warm_start : LearnResult, optional
        An earlier solution for the same robots, typically learned on a shorter record (a
        re-learn while L waits). The first IRL starts from its reward weights, once, instead of
        ``n_restarts`` times from zero, as the relabelling rounds after the first do; a method
        that relabels starts its rounds, on the steps the earlier solution learned from (this
        record is taken to extend that one), from the labels its policies and equilibrium give
        them — the fixed point the earlier rounds reached — and on the new steps from
        perception, so the labels settle in fewer rounds (docs/design.md, "Learning while
        waiting").

        .. versionchanged:: 0.2.0
           Replaces ``initial_weights``, which started the IRL from an earlier solution's
           weights and left the labels to perception.

    Returns
    -------
    LearnResult
        One :class:`~mirl.learning.results.RobotModel` per patroller, the equilibrium they
        were learned to play, and diagnostics.

    Raises
    ------
    mirl._validation.OptionError
        An unknown method, an option out of its range or one that does not apply to the method,
        an unknown option, a bad ``random_state`` (the message names it). A ValueError.
    ValueError
        Observations of other robots than the scenario's; a ``warm_start`` of other robots or
        another map; a ``visible`` of the wrong shape.
    TypeError
        ``observations`` that are not :class:`~mirl.observations.trajectories.Trajectories`;
        a ``warm_start`` that is not a :class:`~mirl.learning.results.LearnResult`.
    """
    scenario, row, opts = _check_arguments(
        observations, scenario, method, options, random_state, observability, score
    )
    if warm_start is not None:
        _check_warm_start(warm_start, scenario)
    if visible is not None:
        visible = _checked_visible(visible, scenario.domain.n_states)
    start = time.perf_counter()
    if not row.learns:  # the scenario's truth: nothing to learn
        res = oracle_models(scenario, method=row.name)
        res.timings["total"] = time.perf_counter() - start
        return res
    irl_options = {
        "objective": opts.objective,
        "optimizer": opts.optimizer,
        "n_restarts": opts.restarts,
        **(opts.irl_options or {}),
    }
    setup = _round_setup(
        observations, scenario, visible, observability, irl_options, random_state,
        opts.initial_transitions,
    )  # fmt: skip
    setup.warm_start = warm_start
    clock = setup.clock
    if trace is None:
        trace = LoopTrace()
    elif not isinstance(trace, LoopTrace) or trace.labels:  # filled in as the rounds go
        raise TypeError(f"trace must be an empty mirl.learning.learn.LoopTrace, got {trace!r}")
    setup.models = initial_models(scenario, warm_start)
    fitted = _fit(setup, row, opts, trace)
    # L learns with the scenario's motion model unless a robot's record rejects it; then once
    # more with the models the records favour, and keeps that learning unless its labels
    # explain the records decisively worse (docs/design.md, "Fault verdicts")
    switched = None
    if row.has_feature_probabilities:
        candidates = candidate_models(scenario.feature_map)
        switched = switched_models(setup.models, fitted[-1], candidates, declared_model(scenario))
    if switched is not None:
        first, setup.models = setup.models, switched
        again = LoopTrace()
        refit = _fit(setup, row, opts, again)
        if log_evidence(refit[-1]) >= log_evidence(fitted[-1]) - np.log(SWITCH_ODDS):
            fitted = refit
            vars(trace).update(vars(again))
        else:
            setup.models = first
    weights, transitions, probs, eq, policies, message, sure = fitted
    robots = []
    for i, r in enumerate(scenario.robots):
        acc = behavior_accuracy(scenario, i, policies[i]) if score else None
        u = sure[i]
        robots.append(
            RobotModel(
                r.name, weights[i], probs[i], transitions[i], policies[i], acc,
                feature_intervals=u.intervals if u is not None else {},
                verdict=u.verdict if u is not None else None,
                lateral_drift=u.drift if u is not None else None,
                uncertainty=u,
                motion_model=setup.models[i].name if row.has_feature_probabilities else "",
            )
        )  # fmt: skip
    clock.timings["total"] = time.perf_counter() - start
    eq_w = trace.equilibria
    team = trace.team_equilibria
    return LearnResult(
        method=row.name,
        robots=tuple(robots),
        equilibrium=eq,
        equilibrium_weights=tuple(float(w) for w in eq_w.weights) if eq_w is not None else (),
        iterations=max(len(trace.labels), 1),
        label_changes=tuple(trace.label_changes),
        timings=clock.timings,
        success=bool(trace.converged),
        message=message,
        pair_equilibria=team.best_per_pair() if team is not None else {},
        horizon=observations.horizon,
    )


def _fit(setup: RoundSetup, row: Method, opts: LearnOptions, trace: LoopTrace):
    """One learning under ``setup.models``: weights, T, feature probabilities, equilibrium,
    policies, message and each robot's verdict."""
    clock = setup.clock
    weights, transitions, probs, eq, message = _method_models(setup, row, opts, trace)
    if row.relabels:  # the last round's policies
        policies = trace.policies
    else:
        with clock("policies"):
            policies = policies_of(setup, transitions, weights, trace)
    if eq is None:
        with clock("equilibria"):
            trace.equilibria = weigh(setup, policies, transitions, trace)
        eq = trace.equilibria.equilibrium
    message = "; ".join(m for m in (message, *sorted(trace.notes)) if m)
    with clock("verdicts"):
        sure = _uncertainties(setup, row, trace, probs, policies)
    return weights, transitions, probs, eq, policies, message, sure


def _round_setup(
    observations, scenario, visible, observability, irl_options, random_state, em_init
) -> RoundSetup:
    """What every step reads: each robot's state series, the states L sees, the steps where two
    robots could be interacting (left out of the IRL), and a fresh clock."""
    clock = Clock()
    domain = scenario.domain
    n = len(scenario.robots)
    with clock("labels"):
        series = [observations.state_series(domain, i) for i in range(n)]
        lateral = [observations.lateral_series(i) for i in range(n)]
        if visible is None:
            degree = scenario.observability if observability is None else observability
            visible = domain.visible_states(degree)
        exclude = np.zeros(observations.horizon, dtype=bool)
        for i in range(n):
            for j in range(i + 1, n):
                exclude |= potential_meetings(domain, series[i], series[j])
    return RoundSetup(
        scenario,
        series,
        np.asarray(visible, dtype=bool),
        exclude,
        clock,
        irl_options,
        random_state,
        em_init,
        lateral=lateral,
        off_pace=record_off_pace(domain, observations, series),
        step_given=observations.step_given is not None,
    )


def _method_models(setup: RoundSetup, row: Method, options: LearnOptions, trace: LoopTrace):
    """Weights, transition matrices, feature probabilities, equilibrium (None: to be weighed)
    and a message, built from the sources ``row`` names (:data:`REWARD_BUILDERS`,
    :data:`TRANSITION_BUILDERS`)."""
    if row.relabels:
        return (
            *relabel_loop(setup, options.max_iterations, trace, options.label_tol),
            trace.message,
        )
    reward, motion = REWARD_BUILDERS[row.reward], TRANSITION_BUILDERS[row.transitions]
    labels = None
    if reward.labelled or motion.labelled:
        with setup.clock("labels"):
            labels = reward.first_labels(setup)
        trace.labels.append(labels)
    transitions, probs, message = motion.build(setup, labels, options)
    weights, eq = reward.build(setup, transitions, labels, trace)
    trace.converged = True
    return weights, transitions, probs, eq, message


def _uncertainties(
    setup: RoundSetup, row: Method, trace: LoopTrace, probs, policies
) -> list[FeatureUncertainty | None]:
    """Per robot the intervals and verdict of its feature probabilities (None for a method
    without them), from the labels its final models give — a relabelling method's last
    relabelling, another method's labels (:mod:`mirl.learning.verdicts`)."""
    if not row.has_feature_probabilities or not trace.labels:
        return [None] * len(setup.series)
    # The verdict takes a label that differs from the greedy policy for the meeting rule's and
    # keeps it, so the labels must be the final policies' own: those the last round learned
    # from lag a round where the loop stopped unsettled (a patrol's end turned left or right,
    # the two nearly tied), and would count the robot's successful turns as failed ones.
    labels = trace.final_labels if row.relabels and trace.final_labels else trace.labels[-1]
    irl = trace.irl + [None] * (len(setup.series) - len(trace.irl))
    out: list[FeatureUncertainty | None] = []
    lateral = setup.lateral or [None] * len(setup.series)
    domain = setup.domain
    soft = [e.soft_policy_ if row.relabels and e is not None else None for e in irl]
    for i in range(len(setup.series)):
        # a robot reacts to another as far as it sees it: the patrollers' detection distance
        record = robot_record(
            domain, setup.series, labels, i, lateral=lateral[i],
            reach=setup.scenario.detect_distance, off_pace=setup.off_pace,
            step_given=setup.step_given,
        )  # fmt: skip
        out.append(
            robot_uncertainty(
                domain, record, probs[i], setup.scenario.faults,
                learned_with=setup.models[i] if setup.models else None,
                soft_policy=soft[i], own_policy=policies[i] if soft[i] is not None else None,
                models=candidate_models(setup.scenario.feature_map),
                random_state=setup.robot_seed(i, 0),
            )
        )  # fmt: skip
    forward = setup.scenario.feature_map.action_subsets["forward"]
    return compared_with_team(out, setup.scenario.robot_names, setup.scenario.faults, forward)


def _check_arguments(
    observations, scenario, method, options, random_state, observability=None, score=True
) -> tuple[Scenario, Method, LearnOptions]:
    """The arguments :func:`learn` cannot work with, refused before any work with a message
    naming the argument; the scenario (one given by name, ``"boyd2"``, is loaded), the
    method's row and the options."""
    scenario = as_scenario(scenario)
    if not isinstance(observations, Trajectories):
        raise TypeError(
            f"observations must be mirl.observations.Trajectories, got {type(observations)}"
        )
    row = get_method(method, LEARNING_METHODS)
    opts = LearnOptions.of(options)
    opts.check_method(row)
    check_argument("random_state", random_state, SEED, None)
    # a string degree failed as a bare comparison inside the map, and score="no" was true
    check_argument("observability", observability, Interval(float, 0.0, 1.0), None)
    check_argument("score", score, Boolean())
    if tuple(observations.robot_names) != tuple(scenario.robot_names):
        raise ValueError(
            f"observations are of robots {list(observations.robot_names)}, "
            f"the scenario has {list(scenario.robot_names)}"
        )
    return scenario, row, opts


def _check_warm_start(warm: LearnResult, scenario: Scenario) -> None:
    """A warm start must model the scenario's robots, in its order, on its map."""
    if not isinstance(warm, LearnResult):
        raise TypeError(f"warm_start must be a mirl.learning.LearnResult, got {type(warm)}")
    names = tuple(r.name for r in warm.robots)
    if names != tuple(scenario.robot_names):
        raise ValueError(
            f"warm_start models robots {list(names)}, the scenario has {list(scenario.robot_names)}"
        )
    policy, weights = (scenario.domain.n_states,), (len(scenario.domain.reward_feature_names),)
    for r in warm.robots:
        if np.shape(r.policy) != policy or np.shape(r.weights) != weights:
            raise ValueError(
                f"warm_start's model of {r.name} is not of this map: a policy of shape "
                f"{np.shape(r.policy)} and weights of shape {np.shape(r.weights)}, expected "
                f"{policy} and {weights}"
            )


def _checked_visible(visible, n_states: int) -> np.ndarray:
    """``visible`` as an (S,) bool array; any other shape, or values other than 0/1, refused."""
    v = np.asarray(visible)
    if v.shape != (n_states,):
        raise ValueError(f"visible must have shape ({n_states},), one per state, got {v.shape}")
    if v.dtype != bool and not np.isin(v, (0, 1)).all():
        raise ValueError("visible must be booleans (or 0/1), one per state")
    return v.astype(bool)


# ---- the rounds ----------------------------------------------------------------------------------
def relabel_loop(
    setup: RoundSetup, max_iterations: int, trace: LoopTrace, label_tol: float
) -> tuple[list[np.ndarray], list[sp.csr_array], list[dict[str, float]], Equilibrium]:
    """The relabelling rounds (module docstring, steps 1–4).

    The loop ends when a relabelling changes at most ``label_tol`` of the labelled steps
    (converged), when it reproduces the labels of an earlier round (a cycle: the labels will
    never fixate), or after ``max_iterations``.

    Parameters
    ----------
    setup : RoundSetup
        What every round reads: the scenario, the robots' series, L's view, the IRL's options.
    max_iterations : int
        Rounds at most.
    trace : LoopTrace
        Filled in with each round's labels and changes, the last round's estimators and
        policies, and why the loop ended.
    label_tol : float
        The share of the labelled steps a relabelling may change and still count as settled.

    Returns
    -------
    weights : list of ndarray
        Per robot the reward weights θ, (K,).
    transitions : list of sparse array
        Per robot T, (S·A, S) CSR.
    feature_probabilities : list of dict of str to float
        Per robot, per feature, the learned success probability.
    equilibrium : Equilibrium
        The best equilibrium of the last round.
    """
    clock = setup.clock
    with clock("labels"):
        labels = perception(setup) if setup.warm_start is None else warm_labels(setup)
    n_labelled = sum(len(observed_steps(x)[0]) for x in setup.series)
    weights = setup.initial_weights()  # previous round's (or solution's), for warm starts
    trace.message = "stopped at max_iterations"
    for round_ in range(1, max_iterations + 1):
        trace.labels.append(labels)
        transitions, probs = learn_transitions(setup, labels)
        weights = irl_round(setup, transitions, labels, weights, round_, trace)
        with clock("policies"):
            policies = policies_of(setup, transitions, weights, trace)
        trace.policies = policies
        with clock("equilibria"):
            eq = _equilibrium_for_labels(setup, policies, transitions)
        with clock("labels"):
            new = policy_labels(setup.domain, setup.series, policies, eq)
            changes = count_changes(setup.series, labels, new)
        trace.label_changes.append(changes)
        trace.final_labels = new
        if changes <= label_tol * n_labelled:
            trace.converged = True
            trace.message = "labels converged" + (
                f" ({changes} of {n_labelled} changed, within label_tol)" if changes else ""
            )
            break
        if any(count_changes(setup.series, old, new) == 0 for old in trace.labels[:-1]):
            trace.message = "labels cycle between rounds; stopped"
            break
        if round_ < max_iterations:
            labels = new
    with clock("equilibria"):
        trace.equilibria = weigh(setup, trace.policies, transitions, trace)
    return weights, transitions, probs, trace.equilibria.equilibrium  # type: ignore[return-value]


def _equilibrium_for_labels(setup: RoundSetup, policies, transitions) -> Equilibrium:
    """The equilibrium that relabels evident meetings in a round: the candidate under which the
    evident meetings (both robots seen at t and t+1) are most likely. Only those steps' labels
    depend on it; the full joint-filter weighing is done once, for the final models."""
    candidates = setup.scenario.game.equilibria()
    ll = np.zeros(len(candidates))
    for pair in setup.scenario.pairs:  # summed over every pair (one game for the team)
        sub = [(setup.series[k], policies[k], transitions[k]) for k in pair]
        x, pol, T = (list(v) for v in zip(*sub, strict=True))
        ll += [meeting_log_likelihood(setup.domain, x, pol, T, e)[0] for e in candidates]
    return candidates[int(np.flatnonzero(ll >= ll.max() - 1e-9)[0])]


class Clock:
    """Accumulates wall time per phase."""

    def __init__(self) -> None:
        self.timings: dict[str, float] = {}

    @contextmanager
    def __call__(self, phase: str) -> Iterator[None]:
        start = time.perf_counter()
        yield  # a phase that raises ends learning: its time is not needed
        self.timings[phase] = self.timings.get(phase, 0.0) + time.perf_counter() - start


@dataclass
class LoopTrace:
    """What happened in the learning rounds, filled in by :func:`learn` when given one.

    Parameters
    ----------
    labels : list of list of ndarray, default []
        Per round, per robot the action labels used, (horizon,) arrays of int, -1 where
        unobserved or unlabelled.
    label_changes : list of int, default []
        Labels changed by each relabelling.
    irl : list of OccludedMaxEntIRL or None, default []
        The last round's IRL estimator per robot (None: a robot L never saw).
    equilibria : EquilibriumWeights, optional
        The last round's equilibrium weights.
    team_equilibria : TeamEquilibria, optional
        The last round's weights per pair L saw meet (N ≥ 2).
    policies : list of ndarray, default []
        The last round's policy per robot, (S,) arrays of int.
    final_labels : list of ndarray, default []
        Per robot the labels the last round's policies give (the relabelling that ended the
        loop, kept or not), (horizon,) arrays of int; empty for a method that does not relabel.
    converged : bool, default False
        Whether the labels settled.
    message : str, default ""
        Why the rounds ended.
    notes : set of str, default set()
        Remarks for the report (a robot never observed, …).
    """

    labels: list[list[np.ndarray]] = field(default_factory=list)
    label_changes: list[int] = field(default_factory=list)
    irl: list[OccludedMaxEntIRL | None] = field(default_factory=list)
    equilibria: EquilibriumWeights | None = None
    team_equilibria: TeamEquilibria | None = None  # per pair L saw meet (N ≥ 2)
    policies: list[np.ndarray] = field(default_factory=list)
    final_labels: list[np.ndarray] = field(default_factory=list)
    converged: bool = False
    message: str = ""
    notes: set[str] = field(default_factory=set)


@dataclass
class RoundSetup:
    """What every step of :func:`learn` reads: the scenario, each robot's (horizon,) state
    series (-1 where occluded), the (S,) states L sees, the steps left out of the IRL, the
    clock, the estimator's options, the seed and DBN-EM's initial T."""

    scenario: Scenario
    series: list[np.ndarray]
    visible: np.ndarray
    exclude: np.ndarray  # (horizon,) steps where the robots may be interacting
    clock: Clock
    irl_options: dict
    random_state: int | None
    em_init: str = "intended"
    lateral: list[np.ndarray | None] | None = None  # per robot (horizon,) offsets, or None
    off_pace: str | None = None  # why its step may be no healthy pace (poses; None: grid)
    step_given: bool = False  # whether the user gave the record's step (poses)
    warm_start: LearnResult | None = None  # an earlier solution to start from
    models: list[MotionModel] | None = None  # per robot, the motion model T is learned under

    @property
    def domain(self):
        return self.scenario.domain

    def initial_weights(self) -> list[np.ndarray] | None:
        """The first IRL's start per robot: the warm start's weights, or None (from zero)."""
        if self.warm_start is None:
            return None
        return [np.asarray(r.weights, dtype=float) for r in self.warm_start.robots]

    def robot_seed(self, robot: int, round_: int) -> int:
        """The seed of ``robot``'s IRL in round ``round_`` (and of its verdict's sampler, round
        0), drawn from ``random_state`` and the robot's place among the team's names in sorted
        order: the scenario's listing of its robots does not change what L learns of one
        (the team's listed order is in every shipped scenario the sorted one)."""
        names = self.scenario.robot_names
        rank = sorted(names).index(names[robot])
        ss = np.random.SeedSequence([self.random_state or 0, rank, round_])
        return int(ss.generate_state(1)[0])


# ---- which motion model L learns with ------------------------------------------------------
SWITCH_ODDS = 1000.0  # motion_models.motion_sentence says so in words
"""L leaves the scenario's motion model for another when a robot's record makes that one this
many times more probable: a bound on how often it leaves a true model (the data would make a
wrong model this much more probable than the true one with probability at most 1/1000, by
Markov's inequality on the Bayes factor; at 1/100, one of 40 grid runs of `mirl run` left it
on one relearn of a healthy robot seen on 53 steps, and kept the wrong model after)."""


def initial_models(scenario: Scenario, warm_start: LearnResult | None = None) -> list[MotionModel]:
    """Per robot the motion model learning starts with: the warm start's, else the scenario's
    ξ and error model."""
    candidates = {m.name: m for m in candidate_models(scenario.feature_map)}
    declared = declared_model(scenario)
    if warm_start is None:
        return [declared] * len(scenario.robots)
    return [candidates.get(r.motion_model, declared) for r in warm_start.robots]


def declared_model(scenario: Scenario) -> MotionModel:
    """The scenario's own ξ and error model, as a candidate."""
    candidates = {m.name: m for m in candidate_models(scenario.feature_map)}
    return candidates[f"paper/{scenario.error_model}"]


def switched_models(
    models: list[MotionModel],
    sure: list[FeatureUncertainty | None],
    candidates: tuple[MotionModel, ...],
    declared: MotionModel,
) -> list[MotionModel] | None:
    """Per robot the model to learn with again, or None when every robot keeps its own. A
    record whose most probable model is :data:`SWITCH_ODDS` times as probable as the
    scenario's (``declared``) takes that one, any other the scenario's — on the whole record,
    so that a model a shorter record chose (a warm start's) is left when the grown one no
    longer rejects the scenario's; a record whose moves L's policy does not explain (the
    check's ``moves``) takes its most probable model, or, when that is the one it was learned
    with, the most probable with the other error model, since the error model is what teaches
    the IRL whether a robot that stood still meant to."""
    out, changed = list(models), False
    by_name = {m.name: m for m in candidates}
    for i, (model, u) in enumerate(zip(models, sure, strict=True)):
        if u is None or not u.motion_models:
            continue
        weights = fold_mirrors(u.motion_models)  # L never learns under a mirror (its twin's)
        best = max(weights, key=weights.__getitem__)
        fit = u.verdict.fit
        target = declared
        if weights[best] >= SWITCH_ODDS * weights.get(declared.name, 0.0):
            target = by_name[best]
        if fit is not None and any(c.name == "moves" and not c.ok for c in fit.checks):
            others = [m for m in weights if by_name[m].errors != model.errors]
            if best != model.name:
                target = by_name[best]
            elif others:
                target = by_name[max(others, key=weights.__getitem__)]
        if target.name != model.name:
            out[i], changed = target, True
    return out if changed else None


def log_evidence(sure: list[FeatureUncertainty | None]) -> float:
    """The records' log marginal likelihood under a learning's policies, averaged over the
    motion models (the robots' records are independent given their policies)."""
    return float(sum(u.log_evidence for u in sure if u is not None and u.motion_models))


def perception(setup: RoundSetup) -> list[np.ndarray]:
    """Per robot (horizon,) perception labels of the steps with both ends observed, else -1."""
    return perceived_labels(setup.scenario, setup.series)


def warm_labels(setup: RoundSetup) -> list[np.ndarray]:
    """Per robot (horizon,) labels to start a warm start's rounds from: on the steps of the
    record the warm start learned from (t below its ``horizon``; this record is taken to extend
    that one), those its policies and equilibrium give them — where its rounds ended; on the
    steps after, perception's, as in a cold start.

    The new steps are not labelled by the earlier policies: a model learned on few or no steps
    of a robot (never seen: the others' reward) would label them its own way, and the rounds,
    fitting the IRL to those labels, can settle there (docs/design.md, "Learning while
    waiting")."""
    warm = setup.warm_start
    assert warm is not None
    labels = perception(setup)
    kept = min(warm.horizon or 0, len(labels[0]) if labels else 0)
    if kept:
        policies = [r.policy for r in warm.robots]
        seen = [x[:kept] for x in setup.series]  # a step's label depends on that step only
        earlier = policy_labels(setup.domain, seen, policies, warm.equilibrium)
        for lab, old in zip(labels, earlier, strict=True):
            lab[:kept] = old
    return labels


def count_changes(series, old: list[np.ndarray], new: list[np.ndarray]) -> int:
    """Labels that differ on the steps T is learned from (both ends observed)."""
    total = 0
    for x, a, b in zip(series, old, new, strict=True):
        t = observed_steps(x)[0]
        total += int((a[t] != b[t]).sum())
    return total


def learn_transitions(setup: RoundSetup, labels: list[np.ndarray]):
    """Per robot T and feature probabilities learned from the labelled steps (mIRL*/T), under
    the robot's motion model (``setup.models``). A step no action explains is no trial of any
    feature (:mod:`mirl.learning.model_check`)."""
    out_T, out_p = [], []
    with setup.clock("transitions"):
        for i, (x, lab) in enumerate(zip(setup.series, labels, strict=True)):
            t, s, s_next = observed_steps(x)
            lab = np.where(unexplained_steps(setup.domain, s, s_next), -1, lab[t])
            model = setup.models[i] if setup.models else initial_models(setup.scenario)[i]
            m = TransitionFeatureLearner(model_domain(setup.domain, model), model.errors).fit(
                s, lab, s_next
            )
            out_T.append(m.transition_model_)
            out_p.append({k: float(v) for k, v in m.feature_probabilities_.items()})
    return out_T, out_p


def irl_round(setup, transitions, labels, previous, round_, trace) -> list[np.ndarray]:
    """One IRL per robot; rounds after the first warm-start from the previous weights."""
    d = setup.domain
    weights: list[np.ndarray | None] = []
    estimators: list[OccludedMaxEntIRL | None] = []
    with setup.clock("irl"):
        for i, (x, T) in enumerate(zip(setup.series, transitions, strict=True)):
            if not (x >= 0).any():  # never seen: filled in below
                weights.append(None)
                estimators.append(None)
                continue
            init = None if previous is None else previous[i]
            options = dict(setup.irl_options)
            if init is not None:
                options["n_restarts"] = 1
            problem = IRLProblem(
                d.reward_features, T, discount=setup.scenario.discount, visible=setup.visible
            )
            irl = OccludedMaxEntIRL(random_state=setup.robot_seed(i, round_), **options).fit(
                problem, x, labels[i], exclude=setup.exclude, initial_weights=init
            )
            weights.append(irl.weights_)
            estimators.append(irl)
    # A robot L never saw gets the mean reward of those it saw — the patrollers are robots of one
    # kind on one route (docs/design.md, "A robot L never saw"); its T stays at the uninformed
    # maximum-entropy solution.
    seen = [w for w in weights if w is not None]
    fill = np.mean(seen, axis=0) if seen else np.zeros(len(d.reward_feature_names))
    unseen = [setup.scenario.robot_names[i] for i, w in enumerate(weights) if w is None]
    if unseen:
        trace.notes.add(f"never observed: {', '.join(unseen)} (reward of the others)")
    trace.irl = estimators
    return [fill.copy() if w is None else w for w in weights]


def policies_of(setup: RoundSetup, transitions, weights, trace: LoopTrace) -> list[np.ndarray]:
    """Greedy policies of hard value iteration with each robot's weights and T: the IRL's own
    where it fits (its last step is this very value iteration), else solved here."""
    irl = trace.irl + [None] * (len(weights) - len(trace.irl))  # none before the first IRL
    return [
        e.policy_
        if e is not None and e.weights_ is w and e.problem_.transitions is T
        else value_iteration(TabularMDP(T, setup.domain.rewards(w), setup.scenario.discount)).policy
        for e, T, w in zip(irl, transitions, weights, strict=True)
    ]


def weigh(setup: RoundSetup, policies, transitions, trace: LoopTrace) -> EquilibriumWeights:
    """Equilibria weighed on every pair L has seen meet (one game for the team: the pairs'
    log-likelihoods add up; each pair's own best is kept as well)."""
    team = weigh_team_equilibria(
        setup.domain,
        setup.series,
        policies,
        transitions,
        setup.scenario.game.equilibria(),
        setup.visible,
    )
    trace.team_equilibria = team
    return team.shared


# ---- the sources of models ------------------------------------------------------------------
# A method's row names where its reward and its T come from, rows of the tables of sources
# (mirl.learning.methods); how learn() builds each is a row below, by the same name, so a new
# source is its row there and a builder here (docs/design.md, "The table of methods").
@dataclass(frozen=True)
class RewardBuilder:
    """How :func:`learn` builds a method's rewards and interaction equilibrium from the source
    its ``reward`` names (a row of :data:`~mirl.learning.methods.REWARD_SOURCES`).

    Parameters
    ----------
    name : str
        The source's name.
    labelled : bool
        Whether the rewards are learned from labelled steps.
    first_labels : callable
        ``first_labels(setup)``: per robot the labels of the observed steps before anything is
        learned.
    build : callable
        ``build(setup, transitions, labels, trace)``: per robot the reward weights, and the
        equilibrium (None: to be weighed against the observations).
    """

    name: str
    labelled: bool
    first_labels: Callable[[RoundSetup], list[np.ndarray]]
    build: Callable[..., tuple[list[np.ndarray], Equilibrium | None]]


@dataclass(frozen=True)
class TransitionBuilder:
    """How :func:`learn` builds a method's transition models from the source its
    ``transitions`` names (a row of :data:`~mirl.learning.methods.TRANSITION_SOURCES`).

    Parameters
    ----------
    name : str
        The source's name.
    labelled : bool
        Whether T is learned from labelled steps.
    build : callable
        ``build(setup, labels, options)``: per robot T and the feature probabilities, and what
        the result's message says of them.
    """

    name: str
    labelled: bool
    build: Callable[..., tuple[list[sp.csr_array], list[dict[str, float]], str]]


def _learned_rewards(setup: RoundSetup, transitions, labels, trace: LoopTrace):
    """Occluded max-ent IRL once, against the T just found; the equilibrium is weighed."""
    return irl_round(setup, transitions, labels, setup.initial_weights(), 1, trace), None


def _true_rewards(setup: RoundSetup, transitions, labels, trace: LoopTrace):
    """The scenario's reward weights and played equilibrium."""
    weights = [np.asarray(r.weights, dtype=float) for r in setup.scenario.robots]
    return weights, setup.scenario.played_equilibrium


def _true_policy_labels(setup: RoundSetup) -> list[np.ndarray]:
    """Per robot (horizon,) labels by the true policies and each pair's played equilibrium."""
    return true_policy_labels(setup.scenario, setup.series)


def _feature_transitions(setup: RoundSetup, labels, options: LearnOptions):
    """mIRL*/T: each robot's transition-feature probabilities from its labelled steps."""
    return (*learn_transitions(setup, labels), "")


def _fixed_p_transitions(setup: RoundSetup, labels, options: LearnOptions):
    """One success probability ``p`` for every action and robot."""
    n, p = len(setup.series), options.fixed_p
    with setup.clock("transitions"):
        T = transition_matrix_from_success(setup.domain, p, setup.scenario.error_model)
    return [T] * n, [{} for _ in range(n)], f"fixed success probability p={p:g} for every action"


def _em_transitions(setup: RoundSetup, labels, options: LearnOptions):
    """A tabular T per robot by EM over a two-slice DBN."""
    n = len(setup.series)
    with setup.clock("transitions"):
        fits = [em_transitions(setup.domain, [x], init=setup.em_init) for x in setup.series]
    dropped = sum(d for _, d in fits)
    message = "tabular T from DBN-EM" + (
        f" ({dropped} observations no sequence of moves reaches left out as unseen)"
        if dropped
        else ""
    )
    return [sp.csr_array(T) for T, _ in fits], [{} for _ in range(n)], message


def _builds_a_reward_source(row: RewardBuilder) -> None:
    REWARD_SOURCES.lookup(row.name)  # a builder of no source: refused here, at import


def _builds_a_transition_source(row: TransitionBuilder) -> None:
    TRANSITION_SOURCES.lookup(row.name)


REWARD_BUILDERS: Registry[RewardBuilder] = Registry(
    "reward source",
    (
        RewardBuilder("learned", True, perception, _learned_rewards),
        RewardBuilder("true", False, _true_policy_labels, _true_rewards),
    ),
    check=_builds_a_reward_source,
)
"""How :func:`learn` builds the rewards of each source a learning method may name."""

TRANSITION_BUILDERS: Registry[TransitionBuilder] = Registry(
    "transition source",
    (
        TransitionBuilder("features", True, _feature_transitions),
        TransitionBuilder("fixed-p", False, _fixed_p_transitions),
        TransitionBuilder("em", False, _em_transitions),
    ),
    check=_builds_a_transition_source,
)
"""How :func:`learn` builds the transition models of each source it builds (a source it does
not build, the truth, gives the scenario's models whole: :func:`learn` returns them)."""
