"""The pieces of :func:`mirl.learning.learn.learn`'s rounds: the set-up every step reads, the
trace it leaves, a clock per phase, and one function per step — perception labels, each robot's
T (learned, fixed or by DBN-EM), one IRL per robot, the greedy policies and the weighing of the
game's equilibria."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from mirl.learning.dbn_em import em_transition_model
from mirl.learning.equilibria import EquilibriumWeights, TeamEquilibria, weigh_team_equilibria
from mirl.learning.irl import OccludedMaxEntIRL
from mirl.learning.transitions import TransitionFeatureLearner, observed_steps, perception_labels
from mirl.mdp import TabularMDP, value_iteration
from mirl.world.motion import transition_matrix_from_success
from mirl.world.scenario import Scenario

__all__ = [
    "Clock",
    "LoopTrace",
    "RoundSetup",
    "perception",
    "count_changes",
    "learn_transitions",
    "fixed_transitions",
    "em_transitions",
    "irl_round",
    "policies_of",
    "weigh",
]


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
    """What happened in the learning rounds: labels used per round and per robot ((horizon,)
    arrays, -1 where unobserved or unlabelled), labels changed by each relabelling, and the
    IRL estimators and equilibrium weights of the last round."""

    labels: list[list[np.ndarray]] = field(default_factory=list)
    label_changes: list[int] = field(default_factory=list)
    irl: list[OccludedMaxEntIRL | None] = field(default_factory=list)
    equilibria: EquilibriumWeights | None = None
    team_equilibria: TeamEquilibria | None = None  # per pair L saw meet (N ≥ 2)
    policies: list[np.ndarray] = field(default_factory=list)
    converged: bool = False
    message: str = ""
    notes: set[str] = field(default_factory=set)


@dataclass
class RoundSetup:
    scenario: Scenario
    series: list[np.ndarray]
    visible: np.ndarray
    exclude: np.ndarray  # (horizon,) steps where the robots may be interacting
    clock: Clock
    irl_options: dict
    random_state: int | None
    em_init: str = "intended"

    @property
    def domain(self):
        return self.scenario.domain

    def robot_seed(self, robot: int, round_: int) -> int:
        ss = np.random.SeedSequence([self.random_state or 0, robot, round_])
        return int(ss.generate_state(1)[0])


def perception(setup: RoundSetup) -> list[np.ndarray]:
    """Per robot (horizon,) perception labels of the steps with both ends observed, else -1."""
    out = []
    for x in setup.series:
        lab = np.full(len(x), -1, dtype=int)
        t, s, s_next = observed_steps(x)
        lab[t] = perception_labels(setup.domain, s, s_next)
        out.append(lab)
    return out


def count_changes(series, old: list[np.ndarray], new: list[np.ndarray]) -> int:
    """Labels that differ on the steps T is learned from (both ends observed)."""
    total = 0
    for x, a, b in zip(series, old, new, strict=True):
        t = observed_steps(x)[0]
        total += int((a[t] != b[t]).sum())
    return total


def learn_transitions(setup: RoundSetup, labels: list[np.ndarray]):
    out_T, out_p = [], []
    with setup.clock("transitions"):
        for x, lab in zip(setup.series, labels, strict=True):
            t, s, s_next = observed_steps(x)
            m = TransitionFeatureLearner(setup.domain, setup.scenario.error_model).fit(
                s, lab[t], s_next
            )
            out_T.append(m.transition_model_)
            out_p.append({k: float(v) for k, v in m.feature_probabilities_.items()})
    return out_T, out_p


def fixed_transitions(setup: RoundSetup, p: float):
    with setup.clock("transitions"):
        T = transition_matrix_from_success(setup.domain, p, setup.scenario.error_model)
    return [T] * len(setup.series), [{} for _ in setup.series]


def em_transitions(setup: RoundSetup):
    with setup.clock("transitions"):
        T = [
            sp.csr_array(em_transition_model(setup.domain, [x], init=setup.em_init))
            for x in setup.series
        ]
    return T, [{} for _ in setup.series]


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
            irl = OccludedMaxEntIRL(
                d.reward_features,
                T,
                discount=setup.scenario.discount,
                visible=setup.visible,
                random_state=setup.robot_seed(i, round_),
                **options,
            ).fit(x, labels[i], exclude=setup.exclude, initial_weights=init)
            weights.append(irl.weights_)
            estimators.append(irl)
    # A robot L never saw gets the mean reward of those it saw — the patrollers are robots of
    # one kind on one route (SPEC §2); its T stays at the uninformed maximum-entropy solution.
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
        if e is not None and e.weights_ is w and e.transitions_source is T
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
