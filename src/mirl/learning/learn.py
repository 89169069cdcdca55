"""What L learns from its observations: the methods of SPEC §5 behind one entry point, `learn`.

``mirl-t`` is mIRL*/T+Int with the relabelling loop of Sec. 3.6:

1. label every observed step (s_t, s_{t+1}) by perception — the action whose intended state is
   s_{t+1} (:func:`mirl.learning.transitions.perception_labels`);
2. learn each robot's transition-feature probabilities and T from the labelled steps (mIRL*/T,
   :class:`mirl.learning.transitions.TransitionFeatureLearner`);
3. learn each robot's reward by occluded max-ent IRL with that T
   (:class:`mirl.learning.irl.OccludedMaxEntIRL`), leaving out the observed steps where the two
   robots could be interacting, and weigh the game's candidate equilibria against everything L saw
   (:func:`mirl.learning.equilibria.weigh_equilibria`);
4. relabel every observed step with the learned policy's action, or the best equilibrium's at an
   evident meeting (:func:`mirl.learning.transitions.policy_labels`) — a perceived turn where the
   policy says forward becomes a *failed* forward — and go back to 2, until at most
   ``label_tol`` of the labelled steps change (default 1 %; 0: none may change) or
   ``max_iterations`` rounds have run. Rounds after the first start the IRL from the previous
   weights (one start instead of ``n_restarts``).

The other methods reuse the same code paths with parts switched off: ``mirl`` fixes T from one
success probability ``p`` (no T learning, one round: the relabelled labels could only change T);
``known-r-t`` uses the true reward and played equilibrium and learns T from labels given by the
true policies (no IRL); ``known-r`` is the true reward and equilibrium with T from ``p``;
``dbn-em`` takes T from :func:`mirl.learning.dbn_em.em_transition_model` and learns the reward like
``mirl``; ``oracle`` is the truth (:func:`mirl.learning.results.oracle_models`).

Fixed-T methods (``mirl``, ``known-r``, ``dbn-em``) report ``feature_probabilities = {}``: they have
no per-feature probabilities; the success probability ``p`` is in the result's ``message``.

Every learned policy is the greedy policy of hard value iteration with the learned weights and
that robot's T. ``behavior_accuracy`` (SPEC §6) is filled in from the scenario's truth when
``score=True``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import scipy.sparse as sp

from mirl.learning.dbn_em import EM_INITS
from mirl.learning.equilibria import meeting_log_likelihood, potential_meetings
from mirl.learning.results import LearnResult, RobotModel, behavior_accuracy, oracle_models
from mirl.learning.rounds import (
    Clock,
    LoopTrace,
    RoundSetup,
    count_changes,
    em_transitions,
    fixed_transitions,
    irl_round,
    learn_transitions,
    perception,
    policies_of,
    weigh,
)
from mirl.learning.transitions import observed_steps, policy_labels
from mirl.observations.trajectories import Trajectories
from mirl.world.game import Equilibrium
from mirl.world.scenario import Scenario, as_scenario

__all__ = ["METHODS", "LoopTrace", "learn", "relabel_loop"]

METHODS = ("mirl-t", "mirl", "known-r-t", "known-r", "dbn-em", "oracle")


def learn(
    observations: Trajectories,
    scenario: Scenario | str,
    method: str = "mirl-t",
    *,
    p: float = 0.9,
    visible: np.ndarray | None = None,
    observability: float | None = None,
    max_iterations: int = 5,
    label_tol: float = 0.01,
    objective: str = "sequence",
    optimizer: str = "lbfgs",
    n_restarts: int | None = None,
    irl_options: Mapping[str, Any] | None = None,
    random_state: int | None = 0,
    score: bool = True,
    trace: LoopTrace | None = None,
    em_init: str = "intended",
) -> LearnResult:
    """Learn models of the scenario's patrollers from L's ``observations`` with ``method``.

    ``scenario``: a :class:`~mirl.world.scenario.Scenario`, or the name or path
    :func:`~mirl.world.scenario.load_scenario` takes.

    ``visible``: (S,) bool states L can see; by default those of ``observability`` (or the
    scenario's degree). ``p``: success probability of every action for the fixed-T methods.
    ``objective``, ``optimizer``, ``n_restarts``: passed to
    :class:`mirl.learning.irl.OccludedMaxEntIRL` (the paper's choice is ``objective="counts",
    optimizer="nelder-mead"``; the defaults were picked by measured behaviour accuracy and
    speed, see the :mod:`mirl.learning.irl` docstring).
    ``n_restarts`` defaults to 1 for L-BFGS (its restarts were measured to land on the same
    optimum) and 3 for Nelder–Mead. ``irl_options``: further keyword arguments of the
    estimator (e.g. ``anchor``, ``l2``, ``max_evaluations``).
    ``label_tol``: ``mirl-t``'s relabelling has converged when a round changes at most this
    share of the labelled steps (those T is learned from); on long records a few labels can
    flip back and forth for rounds, each a full refit (docs/design.md, "A looser stopping
    rule"). ``trace``: an empty :class:`LoopTrace` to receive the labels of every round.
    ``em_init``: DBN-EM's initial T (``intended`` or ``uniform``, see :mod:`mirl.learning.dbn_em`).
    ``random_state`` seeds every random choice (IRL restarts); ``None`` counts as 0, so learning
    is deterministic.

    Long because the signature and the validation of every option come first; the recipes
    themselves are :func:`_method_models` and :mod:`mirl.learning.rounds`.
    """
    scenario = _check_arguments(
        observations, scenario, method, p, em_init, max_iterations, label_tol, random_state
    )
    if visible is not None:
        visible = _checked_visible(visible, scenario.domain.n_states)
    clock = Clock()
    start = time.perf_counter()
    if method == "oracle":
        res = oracle_models(scenario, method="oracle")
        res.timings["total"] = time.perf_counter() - start
        return res
    domain = scenario.domain
    n = len(scenario.robots)
    with clock("labels"):
        series = [observations.state_series(domain, i) for i in range(n)]
        if visible is None:
            degree = scenario.observability if observability is None else observability
            visible = domain.visible_states(degree)
        exclude = np.zeros(observations.horizon, dtype=bool)
        for i in range(n):
            for j in range(i + 1, n):
                exclude |= potential_meetings(domain, series[i], series[j])
    setup = RoundSetup(
        scenario,
        series,
        np.asarray(visible, dtype=bool),
        exclude,
        clock,
        {
            "objective": objective,
            "optimizer": optimizer,
            "n_restarts": n_restarts or (1 if optimizer == "lbfgs" else 3),
            **(irl_options or {}),
        },
        random_state,
        em_init,
    )
    trace = LoopTrace() if trace is None else trace
    weights, transitions, probs, eq, message = _method_models(
        setup, method, p, max_iterations, trace, label_tol
    )
    if method == "mirl-t":
        policies = trace.policies
    else:
        with clock("policies"):
            policies = policies_of(setup, transitions, weights, trace)
    if eq is None:
        with clock("equilibria"):
            trace.equilibria = weigh(setup, policies, transitions, trace)
        eq = trace.equilibria.equilibrium
    message = "; ".join(m for m in (message, *sorted(trace.notes)) if m)
    robots = []
    for i, r in enumerate(scenario.robots):
        acc = behavior_accuracy(scenario, i, policies[i]) if score else None
        robots.append(RobotModel(r.name, weights[i], probs[i], transitions[i], policies[i], acc))
    clock.timings["total"] = time.perf_counter() - start
    eq_w = trace.equilibria
    team = trace.team_equilibria
    return LearnResult(
        method=method,
        robots=tuple(robots),
        equilibrium=eq,
        equilibrium_weights=tuple(float(w) for w in eq_w.weights) if eq_w is not None else (),
        iterations=max(len(trace.labels), 1),
        label_changes=tuple(trace.label_changes),
        timings=clock.timings,
        success=bool(trace.converged),
        message=message,
        pair_equilibria=team.best_per_pair() if team is not None else {},
    )


def _method_models(
    setup: RoundSetup,
    method: str,
    p: float,
    max_iterations: int,
    trace: LoopTrace,
    label_tol: float,
):
    """Weights, transition matrices, feature probabilities, equilibrium (None: to be weighed)
    and a message, by ``method``'s recipe (SPEC §5)."""
    scenario = setup.scenario
    message = ""
    if method == "mirl-t":
        weights, transitions, probs, eq = relabel_loop(setup, max_iterations, trace, label_tol)
        message = trace.message
    elif method in ("known-r-t", "known-r"):
        weights = [np.asarray(r.weights, dtype=float) for r in scenario.robots]
        eq = scenario.played_equilibrium
        if method == "known-r-t":
            with setup.clock("labels"):
                policies = [scenario.true_policy(i) for i in range(len(scenario.robots))]
                labels = policy_labels(setup.domain, setup.series, policies, eq)
            transitions, probs = learn_transitions(setup, labels)
            trace.labels.append(labels)
        else:
            transitions, probs = fixed_transitions(setup, p)
            message = f"fixed success probability p={p:g} for every action"
        trace.converged = True
    else:  # mirl, dbn-em: reward learned once against a given T
        with setup.clock("labels"):
            labels = perception(setup)
        trace.labels.append(labels)
        if method == "mirl":
            transitions, probs = fixed_transitions(setup, p)
            message = f"fixed success probability p={p:g} for every action"
        else:
            transitions, probs = em_transitions(setup)
            message = "tabular T from DBN-EM"
        weights = irl_round(setup, transitions, labels, None, 1, trace)
        eq = None
        trace.converged = True
    return weights, transitions, probs, eq, message


def _check_arguments(
    observations, scenario, method, p, em_init, max_iterations, label_tol, random_state
) -> Scenario:
    """The arguments :func:`learn` cannot work with, refused before any work with a message
    naming the argument; a scenario given by name (``"boyd2"``) is loaded."""
    scenario = as_scenario(scenario)
    if not isinstance(observations, Trajectories):
        raise TypeError(
            f"observations must be mirl.observations.Trajectories, got {type(observations)}"
        )
    if method not in METHODS:
        raise ValueError(f"unknown method '{method}' (known: {', '.join(METHODS)})")
    if not 0.0 <= p <= 1.0:
        raise ValueError(f"p must be in [0, 1], got {p}")
    if em_init not in EM_INITS:
        raise ValueError(f"unknown EM initialisation '{em_init}' (known: {', '.join(EM_INITS)})")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be at least 1, got {max_iterations}")
    if not 0.0 <= label_tol <= 1.0:
        raise ValueError(f"label_tol must be in [0, 1], got {label_tol}")
    integer = isinstance(random_state, int | np.integer) and not isinstance(random_state, bool)
    if random_state is not None and not (integer and random_state >= 0):
        raise ValueError(f"random_state must be a non-negative int or None, got {random_state!r}")
    if tuple(observations.robot_names) != tuple(scenario.robot_names):
        raise ValueError(
            f"observations are of robots {list(observations.robot_names)}, "
            f"the scenario has {list(scenario.robot_names)}"
        )
    return scenario


def _checked_visible(visible, n_states: int) -> np.ndarray:
    """``visible`` as an (S,) bool array; any other shape, or values other than 0/1, refused."""
    v = np.asarray(visible)
    if v.shape != (n_states,):
        raise ValueError(f"visible must have shape ({n_states},), one per state, got {v.shape}")
    if v.dtype != bool and not np.isin(v, (0, 1)).all():
        raise ValueError("visible must be booleans (or 0/1), one per state")
    return v.astype(bool)


def relabel_loop(
    setup: RoundSetup, max_iterations: int, trace: LoopTrace, label_tol: float
) -> tuple[list[np.ndarray], list[sp.csr_array], list[dict[str, float]], Equilibrium]:
    """The mirl-t rounds (module docstring, steps 1–4); returns weights, T, feature
    probabilities and the best equilibrium of the last round.

    The loop ends when a relabelling changes at most ``label_tol`` of the labelled steps
    (converged), when it reproduces the labels of an earlier round (a cycle: the labels will
    never fixate), or after ``max_iterations``."""
    clock = setup.clock
    with clock("labels"):
        labels = perception(setup)
    n_labelled = sum(len(observed_steps(x)[0]) for x in setup.series)
    weights: list[np.ndarray] | None = None  # previous round's, for warm starts
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
