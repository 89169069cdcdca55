"""One penetration run end to end: observe → learn → plan → execute → outcome.

Protocol (:func:`run_episode`):

1. **Observe.** The patrollers start at uniformly drawn states of their patrol cycles and move in
   a :class:`~mirl.simulation.grid.PatrolSimulator` for ``obs_steps`` steps (t = 0 …
   obs_steps − 1) while L records what it sees at the observability degree.
2. **Learn** the patrollers' models with :func:`mirl.learning.learn.learn` (the truth for
   ``oracle``; nothing for ``random``).
3. **Plan.** A :class:`~mirl.planning.belief.BeliefFilter` runs over everything L saw; its
   prediction feeds L's time-indexed MDP (:func:`~mirl.planning.go.solve_observer_mdp`), which
   scores every go time in the next ``window`` steps. L keeps watching from its room (the same
   simulator keeps running and new observations enter the filter; with ``relearn`` the models
   are re-learned as the record grows) and re-plans
   every ``replan_every`` steps while it has no go time with a positive value, and also whenever
   a patroller leaves its view — the moment its belief about that robot is sharpest. A newer
   plan may move or cancel a go time (``commit=True`` keeps the first one; on boyd2 the two
   gave identical outcomes over 50 seeds, because the best go time is almost always "now").
   When ``max_wait`` steps have passed since the end of the observation phase without a go
   time the outcome is ``timeout``.
4. **Execute.** L follows its time-indexed policy; each of its actions fails (it stays put) with
   probability 2.5 %; the true patrollers move on in the simulator; after every step the true
   detection rule is checked. ``success``: L reaches its goal unseen; ``detected``: some
   patroller saw it. If L outlives its plan it re-plans from where it stands, with the filter
   propagated without evidence (L sees nothing once it has left its room).

``random`` waits ``obs_steps``, draws a go time uniformly in [0, window] and follows a shortest
path. Every random choice comes from ``seed`` through independent ``SeedSequence`` streams
(simulator, L's action noise, learning, random baseline), so a run is a function of its
arguments.

Defaults, measured with the true models (``oracle``) on boyd2 at 0.14, 50 seeds, while the
waiting time was 300 steps (success / detected / timeout): ``detection_penalty=0.5`` — go only
when the predicted
success beats half the predicted detection — 0.44 / 0.38 / 0.18, against 0.32 / 0.08 / 0.60
at 1.0 (too cautious: mostly timeouts) and 0.36 / 0.64 / 0.00 at 0.25; the joint filter 0.44
vs 0.38 with independent marginals; negative evidence 0.44 vs 0.32 without; the first-order
hazard 0.44 vs 0.28 with independent per-step detection. ``max_wait`` 450 instead of 300
(100 seeds): oracle 0.47 / 0.46 / 0.07 instead of 0.41 / 0.35 / 0.24 (200 seeds).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mirl.experiments.execution import Decision, PlanFollower, execute, wait_for_go
from mirl.experiments.records import (
    MAX_WAIT,
    WATCH_LIMIT,
    Detection,
    PlanAttempt,
    Relearn,
    RunResult,
)
from mirl.learning.learn import learn
from mirl.learning.methods import Method, get_method
from mirl.learning.results import LearnResult, behavior_accuracy, oracle_models
from mirl.observations.trajectories import Trajectories
from mirl.planning.belief import BeliefFilter
from mirl.planning.go import GO_RULES, ObserverPlan, solve_observer_mdp, waiting_value
from mirl.planning.observer import ObserverModel, observer_model, shortest_path_policy
from mirl.planning.success import success_probability
from mirl.world.scenario import Scenario
from mirl.worlds import DEFAULT_WORLD, RunWorld, get_world, make_world

__all__ = ["run_episode", "RELEARN_GROWTH", "OPPORTUNITY_STEPS"]

# L re-learns while it waits once its record holds this factor more observed steps than at its
# last learning (docs/design.md, "Learning while waiting")
RELEARN_GROWTH = 1.5
# the adaptive go rule counts one fresh chance to go per this many steps left after the window:
# one per planning round (docs/design.md, "The go rule")
OPPORTUNITY_STEPS = 10
# the adaptive rule's picture of its chances: what going would have promised at the moments of
# L's record (the observation phase and its wait) when a patroller left its view, and every
# this many steps, from step CHANCE_FROM on (the filter has settled by then)
CHANCE_EVERY = 30
CHANCE_FROM = 60
# ... at most one moment per planning round, and of the observation phase the last this many: a
# moment's chance costs a prediction and an MDP solve (~1 s on the 60 × 60 office floor)
CHANCE_SAMPLE = 16
MOMENT_SLACK = 20


@dataclass(frozen=True)
class _Planning:
    """How L plans: the go window, horizons and the MDP's settings (see :func:`run_episode`)."""

    window: int
    deadline: int  # last step at which L may still go (end of observing + max_wait)
    travel: int  # planning horizon after the last go time
    replan_every: int
    commit: bool
    hazard: str
    goal_reward: float
    detection_penalty: float
    go_rule: str = "value"
    opportunity_steps: int = OPPORTUNITY_STEPS
    moment_travel: int = 0  # horizon of the plans that score the record's moments


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
    predicted_success: float | None = None
    learned: LearnResult | None = None  # the models L went with (re-learned or not)
    relearns: tuple[Relearn, ...] | None = None


def run_episode(
    scenario: Scenario,
    method: str = "mirl-t",
    *,
    observability: float | None = None,
    obs_steps: int = 300,
    seed: int = 0,
    p: float = 0.9,
    max_wait: int = MAX_WAIT,
    window: int = 60,
    replan_every: int = 10,
    travel_steps: int | None = None,
    joint: bool | None = None,
    hazard: str = "markov",
    goal_reward: float = 1.0,
    detection_penalty: float = 0.5,
    commit: bool = False,
    negative_evidence: bool = True,
    learn_options: dict[str, Any] | None = None,
    learned: LearnResult | None = None,
    watch_until_seen: int | None = None,
    max_obs_steps: int = WATCH_LIMIT,
    world: str = DEFAULT_WORLD,
    go_rule: str = "adaptive",
    relearn: bool = True,
    relearn_growth: float = RELEARN_GROWTH,
    opportunity_steps: int = OPPORTUNITY_STEPS,
) -> RunResult:
    """Run one penetration (module doc). ``learned`` overrides learning (for tests and
    experiments with hand-made models). ``travel_steps`` is the part of the planning horizon
    after the last go time (default: 3 × L's shortest path, at least 20). ``world`` names the
    world of :data:`~mirl.worlds.WORLDS` the run happens in (``"physics"``: MuJoCo).

    ``watch_until_seen=K`` (``mirl run``'s default; None here, so experiments keep the paper's
    fixed observation time): L observes at least ``obs_steps`` steps and then keeps watching
    until it has seen every patroller on K steps, or ``max_obs_steps`` have passed.

    ``go_rule`` is one of :data:`~mirl.planning.go.GO_RULES`: ``"adaptive"`` (default) goes
    when the chance of going now beats the value of waiting (one fresh chance per
    ``opportunity_steps`` steps left after the window) and states the exact P(success) it goes
    with; ``"value"`` is the published rule (``detection_penalty`` applies to it alone). With
    ``relearn`` (default), a method that learns re-learns while L waits whenever its record
    holds ``relearn_growth`` times the observed steps of its last learning.
    ``go_rule="value", relearn=False`` is the paper's protocol.

    .. versionchanged:: 0.2.0
       The adaptive rule and re-learning are the default; the paper's protocol is
       ``go_rule="value", relearn=False`` (``--go-rule value --learn-once``).
    """
    spec = get_method(method)
    if obs_steps < 1:
        raise ValueError(f"obs_steps must be at least 1, got {obs_steps}")
    if watch_until_seen is not None and not 1 <= watch_until_seen <= max_obs_steps:
        raise ValueError(f"watch_until_seen must be in [1, {max_obs_steps}]")
    if max_wait < 0 or window < 0 or replan_every < 1:
        raise ValueError("max_wait and window must be >= 0 and replan_every >= 1")
    if go_rule not in GO_RULES:
        raise ValueError(f"`go_rule` must be one of {', '.join(GO_RULES)}, got '{go_rule}'")
    if not relearn_growth > 1.0:
        raise ValueError(f"`relearn_growth` must be above 1, got {relearn_growth}")
    if opportunity_steps < 1:
        raise ValueError(f"`opportunity_steps` must be at least 1, got {opportunity_steps}")
    degree = scenario.observability if observability is None else float(observability)
    sim_seed, noise_seed, learn_seed, random_seed = np.random.SeedSequence(int(seed)).spawn(4)
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
    _observe(run_world, obs_steps, watch_until_seen, max_obs_steps)
    t_obs = run_world.t  # last step of the observation phase
    timings["observe"] += time.perf_counter() - clock

    clock = time.perf_counter()
    learner: _Learner | None = None
    if learned is None and spec.plans and not spec.learns:
        learned = oracle_models(modelled)
    elif learned is None and spec.learns:
        learn_seed_int = int(learn_seed.generate_state(1)[0])
        kwargs: dict[str, Any] = {"method": method, "p": p, **(learn_options or {})}
        # the run's observability (maybe not the scenario's) and the run's learning stream
        kwargs.setdefault("visible", run_world.visible)
        kwargs.setdefault("random_state", learn_seed_int)
        # L learns with the scenario's motion model and lets the record decide whether another
        # fits it better; of the world's model it takes only how its robots drift
        # (docs/design.md, "Fault verdicts")
        learning = replace(scenario, faults=modelled.faults)
        learner = _Learner(learning, run_world, spec, kwargs, relearn_growth if relearn else None)
        learned = learner.learn_now()
    timings["learn"] += time.perf_counter() - clock

    path_len = int(model.distance_to_goal[model.start_state])
    travel = max(20, 3 * path_len) if travel_steps is None else int(travel_steps)
    planning = _Planning(
        window=window,
        deadline=t_obs + max_wait,
        travel=travel,
        replan_every=replan_every,
        commit=commit,
        hazard=hazard,
        goal_reward=goal_reward,
        detection_penalty=detection_penalty,
        go_rule=go_rule,
        opportunity_steps=opportunity_steps,
        # going at once needs L's path and some slack for its failed moves and for waiting
        # out a patroller, not the whole travel horizon (3× the path): the moments' plans
        # cost in proportion to it
        moment_travel=min(travel, path_len + MOMENT_SLACK),
    )
    if not spec.plans:
        going = _random_going(model, t_obs, window, np.random.default_rng(random_seed))
    else:
        assert learned is not None
        visible = run_world.visible if negative_evidence else None
        watcher = _Watcher(modelled, run_world, learned, learner, visible, joint, timings)
        going = _planned_going(run_world, watcher, model, planning, timings)
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
            run_world, model, follower, going.belief, 10 * (planning.travel + 1)
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
        watch_until_seen=watch_until_seen,
        predicted_success=going.predicted_success,
        relearns=going.relearns if learner is not None and learner.growth is not None else None,
        world=world,
    )


def _observe(world: RunWorld, obs_steps: int, until_seen: int | None, limit: int) -> None:
    """The observation phase: ``obs_steps`` steps, then (``until_seen``) on until every
    patroller was seen on ``until_seen`` steps or ``limit`` steps have passed."""
    for _ in range(obs_steps - 1):
        world.step()
    if until_seen is None:
        return
    counts = (np.asarray(world.seen) >= 0).sum(axis=0)
    while counts.min() < until_seen and world.t + 1 < limit:
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
        return self._count() >= max(self.growth * self.learned_on, self.learned_on + 10)


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
        if self.moments and t - self.moments[-1][0] < OPPORTUNITY_STEPS:
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
    world: RunWorld,
    watcher: _Watcher,
    model: ObserverModel,
    planning: _Planning,
    timings: dict[str, float],
) -> _Going:
    """Wait in the room, deciding by the go rule until a go time (or the deadline); the plan's
    time-indexed policy is how L will go."""

    def solve(steps: int, window: int, penalty: float, min_value: float = 0.0) -> ObserverPlan:
        return solve_observer_mdp(
            model,
            watcher.belief.predict(steps, model),
            window=window,
            goal_reward=planning.goal_reward,
            detection_penalty=penalty,
            min_value=min_value,
            hazard=planning.hazard,
        )

    def decide_value() -> Decision:
        """The published rule: the best go value in the window, if positive."""
        win = min(planning.window, planning.deadline - world.t)
        plan = solve(win + planning.travel, win, planning.detection_penalty)
        go_time = None if plan.go_time is None else world.t + plan.go_time
        attempt = PlanAttempt(world.t, float(plan.go_values.max()), go_time)
        next_round = world.t + planning.replan_every if go_time is None else planning.deadline + 1
        return Decision(plan, go_time, next_round, attempt)

    def chance_at(t: int, belief: np.ndarray) -> float:
        """The planner's P(success) of going at step t of the record with that step's belief,
        along the best plan for going then (window 0)."""
        prediction = watcher.belief.predict(planning.moment_travel, model, belief=belief, t=t)
        plan = solve_observer_mdp(
            model, prediction, window=0, goal_reward=planning.goal_reward,
            detection_penalty=0.0, min_value=-1.0, hazard=planning.hazard,
        )  # fmt: skip
        return float(plan.go_values[0])

    def decide_adaptive() -> Decision:
        """Go now when the window's best go time is now and its chance beats the value of the
        chances still to come before the deadline, drawn like those of the record's moments;
        on going, state the exact P(success) (docs/design.md, "The go rule")."""
        t = world.t
        win = min(planning.window, planning.deadline - t)
        plan = solve(win + planning.travel, win, 0.0, min_value=-1.0)  # P(success) objective
        best = plan.go_time if plan.go_time is not None else 0
        go = win == 0
        if not go and best == 0:  # a later go time in the window is better: wait for it
            later = (planning.deadline - t - win) // planning.opportunity_steps
            go = float(plan.go_values[0]) >= waiting_value(watcher.chances(chance_at), later)
        now = None
        if go:
            now = success_probability(watcher.belief, model, plan, extra=planning.travel).success
        go_time = t if go else None
        step = best if 0 < best < planning.replan_every else planning.replan_every
        attempt = PlanAttempt(t, float(plan.go_values.max()), go_time, now)
        return Decision(plan, go_time, t + step, attempt)

    decide = decide_adaptive if planning.go_rule == "adaptive" else decide_value
    plan, go_time, attempts = wait_for_go(
        world, decide, watcher.observe, planning.deadline, planning.commit, timings
    )
    plan_value = None if go_time is None else float(plan.go_values[go_time - plan.t0])
    belief = watcher.belief

    def policy(k: int, s: int) -> int:
        return int(plan.policy[k, s])

    def replan() -> ObserverPlan:
        # L out in the hallway: the same MDP (its start-cell rule does not matter there)
        penalty = planning.detection_penalty if planning.go_rule == "value" else 0.0
        return solve(planning.travel, 0, penalty)

    return _Going(
        go_time, policy, replan, plan, tuple(attempts), plan_value, belief,
        # the round that named the go time stated it (the adaptive rule; None for the value rule)
        predicted_success=None if go_time is None else attempts[-1].predicted_success,
        learned=watcher.learned,
        relearns=tuple(watcher.relearns),
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
    )


def _observations(scenario: Scenario, world: RunWorld, until: int) -> Trajectories:
    """Everything L saw from its room up to step ``until``."""
    seen = np.asarray(world.seen[: until + 1])
    lateral = None if world.seen_lateral is None else np.asarray(world.seen_lateral[: until + 1])
    return Trajectories.from_states(scenario.domain, scenario.robot_names, seen, lateral=lateral)
