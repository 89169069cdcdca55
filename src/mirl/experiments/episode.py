"""One penetration run end to end: observe → learn → plan → execute → outcome.

Protocol (:func:`run_episode`; its settings are a :class:`~mirl.experiments.options.RunProtocol`,
whose defaults are ``mirl run``'s):

1. **Observe.** The patrollers start at uniformly drawn states of their patrol cycles and move in
   the run's world for ``obs_steps`` steps (t = 0 … obs_steps − 1) while L records what it sees
   at the observability degree; with ``watch_until_seen`` L then keeps watching until it has
   seen every patroller on that many steps, or ``max_obs_steps`` have passed.
2. **Learn** the patrollers' models with :func:`mirl.learning.learn.learn` (the truth for
   ``oracle``; nothing for ``random``).
3. **Plan.** A :class:`~mirl.planning.belief.BeliefFilter` runs over everything L saw; its
   prediction feeds L's time-indexed MDP (:func:`~mirl.planning.go.solve_observer_mdp`), which
   scores every go time in the next ``window`` steps. L keeps watching from its room (the same
   world keeps running and new observations enter the filter; with ``relearn`` the models are
   re-learned as the record grows) and decides by its go rule
   (:data:`~mirl.experiments.options.GO_RULES`, :mod:`mirl.experiments.go_rules`) every
   ``replan_every`` steps while it has no go time, and also whenever a patroller leaves its
   view — the moment its belief about that robot is sharpest. A newer plan may move or cancel a
   go time (``commit`` keeps the first one). When ``max_wait`` steps have passed since the end
   of the observation phase without a go time the outcome is ``timeout``.
4. **Execute.** L follows its time-indexed policy; each of its actions fails (it stays put) with
   probability 2.5 %; the true patrollers move on in the world; after every step the true
   detection rule is checked. ``success``: L reaches its goal unseen; ``detected``: some
   patroller saw it. If L outlives its plan it re-plans from where it stands, with the filter
   propagated without evidence (L sees nothing once it has left its room).

``random`` waits ``obs_steps``, draws a go time uniformly in [0, window] and follows a shortest
path. Every random choice comes from ``seed`` through independent ``SeedSequence`` streams
(the world, L's action noise, learning, random baseline), so a run is a function of its
arguments. How the defaults were chosen: :class:`~mirl.experiments.options.RunProtocol`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np

from mirl._validation import SEED, Interval, check_argument
from mirl.experiments.execution import PlanFollower, execute, wait_for_go
from mirl.experiments.go_rules import GoRuleStrategy, Planning, Waiting
from mirl.experiments.options import GO_RULES, RunProtocol
from mirl.experiments.records import Detection, PlanAttempt, Relearn, RunResult
from mirl.learning.learn import learn
from mirl.learning.methods import Method, get_method
from mirl.learning.options import LearnOptions
from mirl.learning.results import LearnResult, behavior_accuracy, oracle_models
from mirl.observations.trajectories import Trajectories
from mirl.planning.belief import BeliefFilter
from mirl.planning.chance_calibration import calibration_protocols
from mirl.planning.go import ObserverPlan
from mirl.planning.observer import ObserverModel, observer_model, shortest_path_policy
from mirl.world.scenario import Scenario
from mirl.worlds import DEFAULT_WORLD, RunWorld, get_world, make_world

__all__ = ["run_episode"]

# a re-learn needs at least this many newly observed steps, whatever its growth factor (a short
# record grows by the factor within a few steps)
MIN_NEW_OBSERVED = 10
# L stops executing after this many times its planning horizon (it re-plans whenever it
# outlives a plan, so only a run that cannot end gets there)
EXECUTE_PATIENCE = 10
# the adaptive rule's picture of its chances: what going would have promised at the moments of
# L's record (the observation phase and its wait) when a patroller left its view, and every
# this many steps, from step CHANCE_FROM on (the filter has settled by then)
CHANCE_EVERY = 30
CHANCE_FROM = 60
# ... at most one moment per planning round (MOMENT_GAP steps) and of the observation phase the
# last CHANCE_SAMPLE: a moment's chance costs a prediction and an MDP solve (~1 s on the
# 60 × 60 office floor)
MOMENT_GAP = 10
CHANCE_SAMPLE = 16
# going at once needs L's path and some slack for its failed moves and for waiting out a
# patroller, not the whole travel horizon: the moments' plans cost in proportion to it
MOMENT_SLACK = 20

STATED_KEYS = (
    "predicted_success", "predicted_success_interval", "predicted_success_point",
    "predicted_success_averaged", "predicted_success_interval_averaged",
)  # fmt: skip
"""The stated chance's fields, alike in :class:`PlanAttempt` and :class:`RunResult`."""


@dataclass
class _Going:
    """L's decision: its absolute go time (None: never), step policy, re-planner and plans."""

    go_time: int | None
    policy: Callable[[int, int], int]
    replan: Callable[[], ObserverPlan] | None = None
    plan: ObserverPlan | None = None
    attempts: tuple[PlanAttempt, ...] = ()
    plan_value: float | None = None
    belief: BeliefFilter | None = None
    learned: LearnResult | None = None  # the models L went with (re-learned or not)
    relearns: tuple[Relearn, ...] | None = None
    filter_fallbacks: int | None = None  # the belief's fallbacks up to the go time

    def stated(self) -> dict[str, Any]:
        """The chance L stated on going, as :class:`RunResult`'s ``predicted_success*``: the
        round that named the go time stated it (the adaptive rule; None for the value rule and
        the random baseline, which plan no round)."""
        named = self.attempts[-1] if self.go_time is not None and self.attempts else None
        return {k: getattr(named, k, None) for k in STATED_KEYS}


def run_episode(
    scenario: Scenario,
    method: str = "mirl-t",
    *,
    seed: int = 0,
    observability: float | None = None,
    protocol: RunProtocol | Mapping[str, Any] | None = None,
    learn_options: LearnOptions | Mapping[str, Any] | None = None,
    learned: LearnResult | None = None,
    world: str = DEFAULT_WORLD,
) -> RunResult:
    """Run one penetration (module docstring).

    .. versionchanged:: 0.2.0
       The protocol's settings are one ``protocol`` argument and its defaults are the command
       line's: after 300 steps L watches until it has seen every patroller on 40 steps
       (``watch_until_seen=40``), decides by the adaptive rule and re-learns while it waits.
       ``protocol=RunProtocol.paper()`` is the paper's; ``p`` is a learning option.

    Parameters
    ----------
    scenario : Scenario
        The world's map, patrollers and L.
    method : str, default "mirl-t"
        How L comes by models of the patrollers (:data:`~mirl.learning.methods.METHODS`).
    seed : int in [0, 2^63 - 1], default 0
        Seeds every random choice of the run.
    observability : float in [0, 1], optional
        The share of the patrollers' cells L sees (default: the scenario's).
    protocol : RunProtocol or mapping, optional
        How the run goes (:class:`~mirl.experiments.options.RunProtocol`: observing, watching,
        waiting, the go rule, re-learning, planning), or a mapping of its option names to
        values; by default ``mirl run``'s. ``RunProtocol.paper()`` is the paper's (a fixed
        observation time, the value rule, learning once).
    learn_options : LearnOptions or mapping, optional
        How L learns (:class:`~mirl.learning.options.LearnOptions`); refused where they change
        nothing for ``method``.
    learned : LearnResult, optional
        Models to use instead of learning (tests, hand-made models).
    world : str, default "grid"
        The world of :data:`~mirl.worlds.WORLDS` the run happens in (``"physics"``:
        MuJoCo).

    Returns
    -------
    RunResult
        The outcome, L's path and planning rounds, what it saw and learned, and the protocol it
        ran.

    Raises
    ------
    mirl._validation.OptionError
        An option out of its range or unknown, a bad seed or observability (the message names
        it). A ValueError.
    """
    spec = get_method(method)
    check_argument("seed", seed, SEED)
    check_argument("observability", observability, Interval(float, 0.0, 1.0), None)
    run = RunProtocol.of(protocol)
    learning = LearnOptions.of(learn_options)
    learning.check_method(spec)
    rule: GoRuleStrategy = GO_RULES[run.go_rule].load()()
    degree = scenario.observability if observability is None else float(observability)
    # spawned streams are keyed by their index: a fifth leaves the first four as they were
    streams = np.random.SeedSequence(int(seed)).spawn(5)
    sim_seed, noise_seed, learn_seed, random_seed, stated = streams
    timings = dict.fromkeys(("observe", "learn", "plan", "execute"), 0.0)
    t_start, cpu_start = time.perf_counter(), time.process_time()

    clock = time.perf_counter()
    model = observer_model(scenario)
    # the oracle's models of the patrollers take the world's ξ (the learner weighs its own)
    modelled = get_world(world).load().modelled(scenario)
    run_world = make_world(
        world, scenario, model, observability=degree,
        seed=int(sim_seed.generate_state(1)[0]), noise=noise_seed,
    )  # fmt: skip
    _observe(run_world, run)
    t_obs = run_world.t  # last step of the observation phase
    timings["observe"] += time.perf_counter() - clock

    clock = time.perf_counter()
    learner: _Learner | None = None
    if learned is None and spec.plans and not spec.learns:
        learned = oracle_models(modelled)
    elif learned is None and spec.learns:
        # the run's observability (maybe not the scenario's) and the run's learning stream
        kwargs: dict[str, Any] = {
            "method": method,
            "options": learning,
            "visible": run_world.visible,
            "random_state": int(learn_seed.generate_state(1)[0]),
        }
        growth = run.relearn_growth if run.relearn else None
        # L learns with the scenario's motion model and lets the record decide whether another
        # fits it better; of the world's model it takes only how its robots drift
        # (docs/design.md, "Fault verdicts")
        learner_scenario = replace(scenario, faults=modelled.faults)
        learner = _Learner(learner_scenario, run_world, spec, kwargs, growth)
        learned = learner.learn_now()
    timings["learn"] += time.perf_counter() - clock

    planning = _planning(run, model, t_obs)
    if not spec.plans:
        going = _random_going(model, t_obs, run.window, np.random.default_rng(random_seed))
    else:
        assert learned is not None
        visible = run_world.visible if run.negative_evidence else None
        watcher = _Watcher(modelled, run_world, learned, learner, visible, run.joint, timings)
        k = int(stated.generate_state(1)[0])
        calibration = _calibration(run, learning, get_world(world).name, scenario.name)
        waiting = Waiting(run_world, watcher, model, planning, k, calibration)
        going = _planned_going(waiting, rule, timings)
        learned = going.learned

    outcome, plan = "timeout", going.plan
    path: list[tuple[int, ...]] = []
    detections: list[Detection] = []
    if going.go_time is not None:
        clock = time.perf_counter()
        while run_world.t < going.go_time:  # only the random baseline still has to wait here
            run_world.step()
        timings["observe"] += time.perf_counter() - clock
        clock = time.perf_counter()
        follower = PlanFollower(going.policy, going.plan, going.replan, run_world.t)
        outcome, path, detections = execute(
            run_world, model, follower, going.belief, EXECUTE_PATIENCE * (planning.travel + 1)
        )
        plan = follower.plan
        timings["execute"] += time.perf_counter() - clock
    timings["total"] = time.perf_counter() - t_start
    timings["cpu"] = time.process_time() - cpu_start  # this process's CPU time (busy machines)
    result = _run_result(
        scenario, method, int(seed), degree, t_obs + 1, run_world, t_obs, learned, going,
        (outcome, path, detections, plan), timings,
    )  # fmt: skip
    return replace(
        result,
        protocol=run,
        **going.stated(),
        relearns=going.relearns if learner is not None and learner.growth is not None else None,
        world=world,
    )


def _calibration(
    run: RunProtocol, learning: LearnOptions, world: str, scenario: str
) -> str | None:
    """The held-out calibration the stated chance goes through: the one fitted under this run's
    protocol, in its world and on its scenario, with the default learning options; None for any
    other run (docs/design.md, "The held-out calibration")."""
    if not learning.in_effect_default:
        return None
    for name, fitted in calibration_protocols().items():
        if run == RunProtocol(**fitted.options) and fitted.applies(world, scenario):
            return name
    return None


def _planning(run: RunProtocol, model: ObserverModel, t_obs: int) -> Planning:
    """How L plans in this run: the protocol's settings, its deadline after observing until
    ``t_obs``, and the horizons for L's shortest path."""
    path_len = int(model.distance_to_goal[model.start_state])
    travel = run.travel(path_len)
    return Planning(
        window=run.window,
        deadline=t_obs + run.max_wait,
        travel=travel,
        replan_every=run.replan_every,
        commit=run.commit,
        hazard=run.hazard,
        goal_reward=run.goal_reward,
        detection_penalty=run.detection_penalty,
        opportunity_steps=run.opportunity_steps,
        moment_travel=min(travel, path_len + MOMENT_SLACK),
    )


def _observe(world: RunWorld, protocol: RunProtocol) -> None:
    """The observation phase: ``obs_steps`` steps, then (``watch_until_seen``) on until every
    patroller was seen on that many steps or ``max_obs_steps`` steps have passed."""
    for _ in range(protocol.obs_steps - 1):
        world.step()
    until_seen = protocol.watch_until_seen
    if until_seen is None:
        return
    counts = (np.asarray(world.seen) >= 0).sum(axis=0)
    while counts.min() < until_seen and world.t + 1 < protocol.max_obs_steps:
        world.step()
        counts += world.seen[-1] >= 0


def _random_going(
    model: ObserverModel, t_obs: int, window: int, rng: np.random.Generator
) -> _Going:
    """The random baseline: L ignores what it saw, goes at a uniform time in 0 … ``window``
    steps after observing, and follows a shortest path to its goal."""
    fixed = shortest_path_policy(model)

    def policy(k: int, s: int) -> int:
        return int(fixed[s])

    return _Going(go_time=t_obs + int(rng.integers(0, window + 1)), policy=policy)


class _Learner:
    """L's learning from everything it has seen so far: once after observing, and again while it
    waits (``growth``: whenever its record holds that factor more observed steps — steps with
    both ends seen, summed over the patrollers — than at its last learning; None: never),
    warm-started from the last solution (its reward weights and, for a method that relabels,
    the labels its policies give the steps it learned from)."""

    def __init__(
        self,
        scenario: Scenario,
        world: RunWorld,
        spec: Method,
        kwargs: dict[str, Any],
        growth: float | None,
    ) -> None:
        self.scenario, self.world, self.spec, self.kwargs = scenario, world, spec, kwargs
        self.growth = growth
        self.learned: LearnResult | None = None
        self.learned_on = 0  # observed steps of the last learning
        self.observed = 0  # observed steps so far
        self.counted_to = 0  # the last step counted

    def _count(self) -> int:
        seen = self.world.seen
        while self.counted_to < len(seen) - 1:
            a, b = seen[self.counted_to], seen[self.counted_to + 1]
            self.observed += int(((a >= 0) & (b >= 0)).sum())
            self.counted_to += 1
        return self.observed

    def learn_now(self) -> LearnResult:
        observations = _observations(self.scenario, self.world, self.world.t)
        self.learned = learn(observations, self.scenario, warm_start=self.learned, **self.kwargs)
        self.learned_on = self._count()
        return self.learned

    def due(self) -> bool:
        """Whether the record has grown enough for a re-learn."""
        if self.growth is None:
            return False
        enough = max(self.growth * self.learned_on, self.learned_on + MIN_NEW_OBSERVED)
        return self._count() >= enough


class _Watcher:
    """L in its room: the belief filter over everything it has seen, under its current models,
    re-learned (and the filter re-run over the whole record) when its :class:`_Learner` is due.

    It also keeps the beliefs of the record's *moments* (every ``CHANCE_EVERY`` steps from
    ``CHANCE_FROM``) and, once asked, what going at each would have promised under the current
    models (:meth:`chances`): the adaptive rule's sample of its chances."""

    def __init__(
        self,
        scenario: Scenario,
        world: RunWorld,
        learned: LearnResult,
        learner: _Learner | None,
        visible: np.ndarray | None,
        joint: bool | None,
        timings: dict[str, float],
    ) -> None:
        self.scenario, self.world, self.learner = scenario, world, learner
        self.visible, self.joint, self.timings = visible, joint, timings
        self.relearns: list[Relearn] = []
        self.learned = learned
        self.moments: list[tuple[int, np.ndarray]] = []
        self._chances: list[float] = []  # of moments[: len(_chances)], under these models
        self.belief = self._filter(learned)

    def _keep_moment(self, belief: BeliefFilter, left_view: bool) -> None:
        t = belief.t
        if t < CHANCE_FROM or not (left_view or t % CHANCE_EVERY == 0) or belief.belief is None:
            return
        if self.moments and t - self.moments[-1][0] < MOMENT_GAP:
            return
        self.moments.append((t, belief.belief))  # update() replaces, never mutates, it

    def _filter(self, learned: LearnResult) -> BeliefFilter:
        clock = time.perf_counter()
        belief = BeliefFilter(self.scenario.domain, learned, visible=self.visible, joint=self.joint)
        self.moments, self._chances = [], []
        seen = self.world.seen
        for t, now in enumerate(seen):
            belief.update(now)
            self._keep_moment(belief, t > 0 and _left_view(seen[t - 1], now))
        self.moments = self.moments[-CHANCE_SAMPLE:]
        self.timings["plan"] += time.perf_counter() - clock
        return belief

    def chances(self, chance_at: Callable[[int, np.ndarray], float]) -> list[float]:
        """What going at each moment of the record promised, ``chance_at(t, belief)``, computed
        once per moment and models."""
        for t, b in self.moments[len(self._chances) :]:
            self._chances.append(chance_at(t, b))
        return self._chances

    def observe(self) -> bool:
        """Take in the newest step; re-learn if due. Returns whether the models changed."""
        if self.learner is not None and self.learner.due():
            clock = time.perf_counter()
            self.learned = self.learner.learn_now()
            seconds = time.perf_counter() - clock
            self.timings["learn"] += seconds
            self.relearns.append(_relearn_record(self.world.t, self.learner, seconds))
            self.belief = self._filter(self.learned)
            return True
        clock = time.perf_counter()
        seen = self.world.seen
        self.belief.update(seen[-1])
        self._keep_moment(self.belief, len(seen) > 1 and _left_view(seen[-2], seen[-1]))
        self.timings["plan"] += time.perf_counter() - clock
        return False


def _left_view(before: np.ndarray, now: np.ndarray) -> bool:
    """Whether a patroller L saw on the step before is out of its view now."""
    return bool(np.any((np.asarray(before) >= 0) & (np.asarray(now) < 0)))


def _relearn_record(t: int, learner: _Learner, seconds: float) -> Relearn:
    learned = learner.learned
    assert learned is not None
    probs = {
        r.name: {k: float(v) for k, v in r.feature_probabilities.items()} for r in learned.robots
    }
    verdicts = {r.name: r.verdict.sentence(r.name) for r in learned.robots if r.verdict}
    acc = [r.behavior_accuracy for r in learned.robots if r.behavior_accuracy is not None]
    return Relearn(
        t=t,
        observed_steps=learner.learned_on,
        feature_probabilities=probs,
        verdicts=verdicts,
        behavior_accuracy=float(np.mean(acc)) if acc else None,
        seconds=seconds,
    )


def _planned_going(
    waiting: Waiting, rule: GoRuleStrategy, timings: dict[str, float]
) -> _Going:
    """Wait in the room, deciding by the go rule until a go time (or the deadline); the plan's
    time-indexed policy is how L will go."""
    world, planning = waiting.world, waiting.planning
    watcher = cast(_Watcher, waiting.watcher)
    plan, go_time, attempts = wait_for_go(
        world,
        lambda: rule.decide(waiting),
        watcher.observe,
        planning.deadline,
        planning.commit,
        timings,
    )
    plan_value = None if go_time is None else float(plan.go_values[go_time - plan.t0])
    belief = watcher.belief

    def policy(k: int, s: int) -> int:
        return int(plan.policy[k, s])

    def replan() -> ObserverPlan:
        # L out in the hallway: the same MDP (its start-cell rule does not matter there)
        return waiting.solve(planning.travel, 0, rule.replan_penalty(planning))

    return _Going(
        go_time, policy, replan, plan, tuple(attempts), plan_value, belief,
        learned=watcher.learned,
        relearns=tuple(watcher.relearns),
        filter_fallbacks=belief.fallbacks,  # taken at the go time: L's belief updates on
    )  # fmt: skip


def _run_result(
    scenario: Scenario,
    method: str,
    seed: int,
    degree: float,
    obs_steps: int,
    world: RunWorld,
    t_obs: int,
    learned: LearnResult | None,
    going: _Going,
    ending: tuple[str, list, list[Detection], ObserverPlan | None],
    timings: dict[str, float],
) -> RunResult:
    """The run's record: outcome, scores of the learned models, L's path and what it saw."""
    outcome, path, detections, plan = ending
    names = scenario.robot_names
    accuracy: dict[str, float] = {}
    features: dict[str, dict[str, float]] = {}
    if learned is not None:
        for i, r in enumerate(learned.robots):
            acc = r.behavior_accuracy
            if acc is None:
                acc = behavior_accuracy(scenario, i, r.policy)
            accuracy[r.name] = float(acc)
            features[r.name] = {k: float(v) for k, v in r.feature_probabilities.items()}
    seen_arr = np.asarray(world.seen[: t_obs + 1])
    return RunResult(
        scenario=scenario.name,
        method=method,
        seed=seed,
        observability=degree,
        obs_steps=obs_steps,
        outcome=outcome,
        go_time=going.go_time,
        plan_value=going.plan_value,
        behavior_accuracy=float(np.mean(list(accuracy.values()))) if accuracy else None,
        behavior_accuracy_per_robot=accuracy,
        feature_probabilities=features,
        timings=timings,
        observer_path=np.asarray(path, dtype=int).reshape(-1, 4),
        detections=tuple(detections),
        true_states=np.asarray(world.true),
        observations=_observations(scenario, world, world.t),
        attempts=going.attempts,
        robot_names=names,
        end_time=world.t,
        learned=learned,
        plan=plan,
        seen_steps={n: int((seen_arr[:, i] >= 0).sum()) for i, n in enumerate(names)},
        extras=world.extras(),
        filter_fallbacks=going.filter_fallbacks,
    )


def _observations(scenario: Scenario, world: RunWorld, until: int) -> Trajectories:
    """Everything L saw from its room up to step ``until``."""
    seen = np.asarray(world.seen[: until + 1])
    lateral = None if world.seen_lateral is None else np.asarray(world.seen_lateral[: until + 1])
    return Trajectories.from_states(scenario.domain, scenario.robot_names, seen, lateral=lateral)
