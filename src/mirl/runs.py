"""One penetration run end to end: observe → learn → plan → execute → outcome.

Protocol (:func:`run_episode`):

1. **Observe.** The patrollers start at uniformly drawn states of their patrol cycles and move in
   a :class:`~mirl.simulator.PatrolSimulator` for ``obs_steps`` steps (t = 0 … obs_steps − 1)
   while L records what it sees at the observability degree.
2. **Learn** the patrollers' models with :func:`mirl.learning.learn` (the truth for ``oracle``;
   nothing for ``random``).
3. **Plan.** A :class:`~mirl.planner.BeliefFilter` runs over everything L saw; its prediction
   feeds L's time-indexed MDP (:func:`~mirl.planner.solve_observer_mdp`), which scores every go
   time in the next ``window`` steps. L keeps watching from its room (the same simulator keeps
   running and new observations enter the filter; the models are not relearned) and re-plans
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

import inspect
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mirl.baselines import random_go
from mirl.models import LearnResult, behavior_accuracy, oracle_models
from mirl.observations import Trajectories
from mirl.planner import (
    NOT_WATCHING,
    BeliefFilter,
    ObserverModel,
    ObserverPlan,
    observer_model,
    shortest_path_policy,
    solve_observer_mdp,
)
from mirl.scenario import Scenario
from mirl.simulator import PatrolSimulator

__all__ = [
    "METHODS",
    "OUTCOMES",
    "Detection",
    "PlanAttempt",
    "RunResult",
    "run_episode",
]

METHODS = ("mirl-t", "mirl", "known-r-t", "known-r", "dbn-em", "random", "oracle")
LEARNED_METHODS = ("mirl-t", "mirl", "known-r-t", "known-r", "dbn-em")
OUTCOMES = ("success", "detected", "timeout")
# L may wait 450 steps (15 min) after observing: with the default 300 observation steps a run
# lasts at most 25 min of robot time, the paper's limit for its physical runs
MAX_WAIT = 450


@dataclass(frozen=True)
class Detection:
    """A patroller seeing L: time, robot, the robot's (row, col, heading) and L's cell."""

    t: int
    robot: str
    robot_state: tuple[int, int, int]
    observer_cell: tuple[int, int]


@dataclass(frozen=True)
class PlanAttempt:
    """One planning round: when, the best go value in the window and the chosen go time
    (absolute; None when no go value was positive)."""

    t: int
    best_value: float
    go_time: int | None


@dataclass(frozen=True, eq=False)
class RunResult:
    """Everything about one run; :meth:`to_dict` is its JSON form."""

    scenario: str
    method: str
    seed: int
    observability: float
    obs_steps: int
    outcome: str
    go_time: int | None  # absolute step at which L left its start cell
    plan_value: float | None  # go value of the executed plan
    behavior_accuracy: float | None  # mean over robots
    behavior_accuracy_per_robot: dict[str, float]
    feature_probabilities: dict[str, dict[str, float]]
    timings: dict[str, float]  # wall s per phase (observe, learn, plan, execute), total, cpu
    observer_path: np.ndarray  # (n, 4): t, row, col, heading of L from its go time
    detections: tuple[Detection, ...]
    true_states: np.ndarray  # (end_time + 1, N) patroller state indices
    observations: Trajectories  # everything L saw from its room
    attempts: tuple[PlanAttempt, ...]
    robot_names: tuple[str, ...]
    end_time: int
    learned: LearnResult | None = None
    plan: ObserverPlan | None = None  # the executed (or last) plan
    seen_steps: dict[str, int] = field(default_factory=dict)  # observation-phase sightings

    def to_dict(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "method": self.method,
            "seed": self.seed,
            "observability": self.observability,
            "obs_steps": self.obs_steps,
            "outcome": self.outcome,
            "go_time": self.go_time,
            "plan_value": self.plan_value,
            "behavior_accuracy": self.behavior_accuracy,
            "behavior_accuracy_per_robot": self.behavior_accuracy_per_robot,
            "feature_probabilities": self.feature_probabilities,
            "timings": self.timings,
            "seen_steps": self.seen_steps,
            "plan_attempts": [
                {"t": a.t, "best_value": a.best_value, "go_time": a.go_time} for a in self.attempts
            ],
            "detections": [
                {
                    "t": d.t,
                    "robot": d.robot,
                    "robot_state": list(d.robot_state),
                    "observer_cell": list(d.observer_cell),
                }
                for d in self.detections
            ],
            "observer_path": self.observer_path.tolist(),
            "end_time": self.end_time,
        }


# ---- learning adapter ------------------------------------------------------------------------
def _learn(
    observations: Trajectories,
    scenario: Scenario,
    method: str,
    p: float,
    visible: np.ndarray,
    seed: np.random.SeedSequence,
    options: dict[str, Any],
) -> LearnResult:
    try:
        from mirl.learning import learn
    except ImportError as exc:  # pragma: no cover - only while learning is being written
        raise RuntimeError(f"method '{method}' needs mirl.learning ({exc})") from None
    kwargs: dict[str, Any] = {"method": method, "p": p, **options}
    params = inspect.signature(learn).parameters
    if "visible" in params:  # the run's observability, not necessarily the scenario's
        kwargs.setdefault("visible", visible)
    for name in ("random_state", "seed"):  # the run's learning stream (IRL restarts)
        if name in params:
            kwargs.setdefault(name, int(seed.generate_state(1)[0]))
            break
    return learn(observations, scenario, **kwargs)


# ---- the run ---------------------------------------------------------------------------------
class _World:
    """The simulator plus L's record of it; one instance per run."""

    def __init__(self, scenario: Scenario, observability: float, seed: int) -> None:
        self.sim = PatrolSimulator(scenario, observability=observability)
        obs, info = self.sim.reset(seed=seed, options={"random_starts": True})
        self.domain = scenario.domain
        self.true: list[np.ndarray] = [info["states"].copy()]
        self.seen: list[np.ndarray] = [self._seen(obs)]
        self.t = 0

    def _seen(self, obs: np.ndarray) -> np.ndarray:
        out = np.full(self.sim.n_robots, -1, dtype=int)
        out[obs[:, 0]] = self.domain.state_index(obs[:, 1], obs[:, 2], obs[:, 3])
        return out

    def step(self) -> np.ndarray:
        obs, _, _, _, info = self.sim.step()
        self.t += 1
        self.true.append(info["states"].copy())
        self.seen.append(self._seen(obs))
        return self.true[-1]

    def observations(self, names: tuple[str, ...], until: int) -> Trajectories:
        return Trajectories.from_states(self.domain, names, np.asarray(self.seen[: until + 1]))


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
) -> RunResult:
    """Run one penetration (module doc). ``learned`` overrides learning (for tests and
    experiments with hand-made models). ``travel_steps`` is the part of the planning horizon
    after the last go time (default: 3 × L's shortest path, at least 20)."""
    if method not in METHODS:
        raise ValueError(f"unknown method '{method}' (known: {', '.join(METHODS)})")
    if obs_steps < 1:
        raise ValueError(f"obs_steps must be at least 1, got {obs_steps}")
    if max_wait < 0 or window < 0 or replan_every < 1:
        raise ValueError("max_wait and window must be >= 0 and replan_every >= 1")
    degree = scenario.observability if observability is None else float(observability)
    streams = np.random.SeedSequence(int(seed)).spawn(4)
    sim_seed, noise_seed, learn_seed, random_seed = streams
    timings = dict.fromkeys(("observe", "learn", "plan", "execute"), 0.0)
    t_start, cpu_start = time.perf_counter(), time.process_time()
    names = scenario.robot_names

    clock = time.perf_counter()
    world = _World(scenario, degree, int(sim_seed.generate_state(1)[0]))
    for _ in range(obs_steps - 1):
        world.step()
    t_obs = world.t  # last step of the observation phase
    observations = world.observations(names, t_obs)
    timings["observe"] += time.perf_counter() - clock

    clock = time.perf_counter()
    if learned is None and method == "oracle":
        learned = oracle_models(scenario)
    elif learned is None and method in LEARNED_METHODS:
        learned = _learn(
            observations, scenario, method, p, world.sim.visible, learn_seed, learn_options or {}
        )
    timings["learn"] += time.perf_counter() - clock

    model = observer_model(scenario)
    rng = np.random.default_rng(noise_seed)
    attempts: list[PlanAttempt] = []
    plan: ObserverPlan | None = None
    belief: BeliefFilter | None = None
    path_len = int(model.distance_to_goal[model.start_state])
    travel = max(20, 3 * path_len) if travel_steps is None else int(travel_steps)

    detections: list[Detection] = []
    path: list[tuple[int, int, int, int]] = []
    plan_value: float | None = None
    if method == "random":
        go_time: int | None = t_obs + random_go(np.random.default_rng(random_seed), window)
        fixed = shortest_path_policy(model)
        replan = None

        def policy(k: int, s: int) -> int:
            return int(fixed[s])

    else:
        assert learned is not None
        clock = time.perf_counter()
        visible = world.sim.visible if negative_evidence else None
        belief = BeliefFilter(scenario.domain, learned, visible=visible, joint=joint)
        for seen in world.seen:
            belief.update(seen)
        timings["plan"] += time.perf_counter() - clock

        def make_plan() -> ObserverPlan:
            win = min(window, t_obs + max_wait - world.t)
            pred = belief.predict(win + travel, model)
            return solve_observer_mdp(
                model,
                pred,
                window=win,
                goal_reward=goal_reward,
                detection_penalty=detection_penalty,
                hazard=hazard,
            )

        def replan() -> ObserverPlan:
            # L out in the hallway: the same MDP (its start-cell rule does not matter there)
            return solve_observer_mdp(
                model,
                belief.predict(travel, model),
                window=0,
                goal_reward=goal_reward,
                detection_penalty=detection_penalty,
                hazard=hazard,
            )

        plan, go_time, attempts = _wait_for_go(
            world, belief, make_plan, t_obs + max_wait, replan_every, commit, timings
        )
        if go_time is not None:
            plan_value = float(plan.go_values[go_time - plan.t0])
        executed = plan

        def policy(k: int, s: int) -> int:
            return int(executed.policy[k, s])

    if go_time is None:
        outcome = "timeout"
    else:
        clock = time.perf_counter()
        while world.t < go_time:  # only the random baseline still has to wait here
            world.step()
        timings["observe"] += time.perf_counter() - clock
        clock = time.perf_counter()
        outcome, path, detections, plan = _execute(
            world, model, policy, plan, rng, belief, replan, 10 * (travel + 1), names
        )
        timings["execute"] += time.perf_counter() - clock

    accuracy: dict[str, float] = {}
    features: dict[str, dict[str, float]] = {}
    if learned is not None:
        for i, r in enumerate(learned.robots):
            acc = r.behavior_accuracy
            if acc is None:
                acc = behavior_accuracy(scenario, i, r.policy)
            accuracy[r.name] = float(acc)
            features[r.name] = {k: float(v) for k, v in r.feature_probabilities.items()}
    timings["total"] = time.perf_counter() - t_start
    timings["cpu"] = time.process_time() - cpu_start  # this process's CPU time (busy machines)
    seen_arr = np.asarray(world.seen[: t_obs + 1])
    return RunResult(
        scenario=scenario.name,
        method=method,
        seed=int(seed),
        observability=degree,
        obs_steps=obs_steps,
        outcome=outcome,
        go_time=go_time,
        plan_value=plan_value,
        behavior_accuracy=float(np.mean(list(accuracy.values()))) if accuracy else None,
        behavior_accuracy_per_robot=accuracy,
        feature_probabilities=features,
        timings=timings,
        observer_path=np.asarray(path, dtype=int).reshape(-1, 4),
        detections=tuple(detections),
        true_states=np.asarray(world.true),
        observations=world.observations(names, world.t),
        attempts=tuple(attempts),
        robot_names=names,
        end_time=world.t,
        learned=learned,
        plan=plan,
        seen_steps={n: int((seen_arr[:, i] >= 0).sum()) for i, n in enumerate(names)},
    )


def _wait_for_go(
    world: _World,
    belief: BeliefFilter,
    make_plan: Callable[[], ObserverPlan],
    deadline: int,
    replan_every: int,
    commit: bool,
    timings: dict[str, float],
) -> tuple[ObserverPlan, int | None, list[PlanAttempt]]:
    """L in its room: plan, then keep watching until the go time or the deadline.

    L re-plans every ``replan_every`` steps while it has no go time and — unless ``commit`` —
    also whenever a patroller leaves its view (the moment its belief about that robot is
    sharpest), so a newer plan can move or cancel the go time. Returns the plan to execute, the
    absolute go time (None: timed out) and every planning round.
    """
    attempts: list[PlanAttempt] = []
    plan: ObserverPlan | None = None
    go_time: int | None = None
    next_plan = world.t
    while True:
        left_view = world.t > 0 and np.any((world.seen[-2] >= 0) & (world.seen[-1] < 0))
        if world.t >= next_plan or (left_view and not (commit and go_time is not None)):
            clock = time.perf_counter()
            plan = make_plan()
            timings["plan"] += time.perf_counter() - clock
            go_time = None if plan.go_time is None else world.t + plan.go_time
            attempts.append(PlanAttempt(world.t, float(plan.go_values.max()), go_time))
            next_plan = world.t + replan_every if go_time is None else deadline + 1
        assert plan is not None
        if go_time is not None and world.t >= go_time:
            return plan, go_time, attempts
        if world.t >= deadline:
            return plan, None, attempts
        clock = time.perf_counter()
        world.step()
        timings["observe"] += time.perf_counter() - clock
        clock = time.perf_counter()
        belief.update(world.seen[-1])
        timings["plan"] += time.perf_counter() - clock


def _execute(
    world: _World,
    model: ObserverModel,
    policy: Callable[[int, int], int],
    plan: ObserverPlan | None,
    rng: np.random.Generator,
    belief: BeliefFilter | None,
    replan: Callable[[], ObserverPlan] | None,
    max_steps: int,
    names: tuple[str, ...],
):
    """L leaves its start cell now and follows ``policy(k, state)`` (re-planning with
    ``replan`` if it outlives ``plan``); returns the outcome, L's path (t, row, col, heading),
    the detections and the plan finally followed. More than ``max_steps`` steps: timeout."""
    dom = model.domain
    s = model.start_state
    k = 0 if plan is None else world.t - plan.t0
    path = [(world.t, *map(int, dom.states[s]))]
    if belief is not None:  # L stopped watching when it left: propagate the belief blind
        while belief.t < world.t:
            belief.update(np.full(belief.n_robots, NOT_WATCHING))
    for _ in range(max_steps):
        if plan is not None and k >= plan.horizon:  # outlived the plan: re-plan from here
            assert replan is not None
            plan = replan()
            k = 0

            def policy(kk: int, ss: int, _p=plan) -> int:
                return int(_p.policy[kk, ss])

        a = policy(k, s)
        nxt = s if rng.random() < model.failure else int(dom.intended[s, a])
        truth = world.step()
        if belief is not None:
            belief.update(np.full(belief.n_robots, NOT_WATCHING))
        s, k = nxt, k + 1
        path.append((world.t, *map(int, dom.states[s])))
        seen = model.seen_by(truth, s)
        if seen.any():
            cell = tuple(map(int, dom.states[s][:2]))
            dets = [
                Detection(world.t, names[i], tuple(map(int, world.domain.states[truth[i]])), cell)
                for i in np.flatnonzero(seen)
            ]
            return "detected", path, dets, plan
        if model.goal[s]:
            return "success", path, [], plan
    return "timeout", path, [], plan


# ---- the readable report of `mirl run` -------------------------------------------------------
def policy_cycle(domain, policy: np.ndarray, start: int) -> np.ndarray:
    """States of the loop that ``policy`` settles into from ``start`` under intended outcomes."""
    s = int(start)
    for _ in range(domain.n_states):  # walk long enough to be on the loop
        s = int(domain.intended[s, policy[s]])
    cycle = [s]
    s = int(domain.intended[s, policy[s]])
    while s != cycle[0]:
        cycle.append(s)
        s = int(domain.intended[s, policy[s]])
    return np.asarray(cycle)


def _turn_cells(domain, cycle: np.ndarray) -> list[tuple[int, int]]:
    """Cells where the loop reverses direction (heading turned by 180° across a stay)."""
    rch = domain.states[cycle]
    out: list[tuple[int, int]] = []
    for i in range(len(cycle)):
        a, b = rch[i], rch[(i + 2) % len(cycle)]
        cell = (int(a[0]), int(a[1]))
        if (a[2] - b[2]) % 4 == 2 and (a[0], a[1]) == (b[0], b[1]) and cell not in out:
            out.append(cell)
    return out


def format_report(scenario: Scenario, result: RunResult) -> str:
    """The short readable report printed by ``mirl run``."""
    dom = scenario.domain
    n_vis = int(scenario.map.visible_mask(result.observability).sum())
    damaged = [
        f"{r.name}:{f}={p:g}"
        for r in scenario.robots
        for f, p in r.feature_probabilities.items()
        if p < 0.9
    ]
    lines = [
        f"mirl run: scenario {scenario.name} (truth: {', '.join(damaged) or 'no damage'}), "
        f"method {result.method}, observability {result.observability:g} "
        f"({n_vis}/{scenario.map.n_patroller_cells} cells), seed {result.seed}",
        "",
        f"observed  {result.obs_steps} steps ({result.obs_steps * 2 / 60:.0f} min of robot time):"
        + "".join(f" saw {n} on {k} steps;" for n, k in result.seen_steps.items()).rstrip(";"),
    ]
    learned = result.learned
    has_features = any(result.feature_probabilities.values())
    if learned is not None and not has_features:
        lines.append(f"learned   no feature probabilities: {learned.message or learned.method}")
    if learned is not None and has_features:
        feats = list(scenario.feature_map.features)
        lines.append(f"learned   transition-feature probabilities ({learned.method}):")
        lines.append("            robot" + "".join(f"{f:>13}" for f in feats))
        probs = result.feature_probabilities
        ranked = sorted((probs[n][f], n, f) for n in probs for f in feats if f in probs[n])
        low = ranked[0][1:] if ranked[1][0] - ranked[0][0] > 1e-6 else None  # a unique lowest
        for name, fp in probs.items():
            cells = "".join(
                f"{fp[f]:>12.3f}{'*' if (name, f) == low else ' '}" for f in feats if f in fp
            )
            unseen = " (never seen: maximum entropy)" if result.seen_steps.get(name) == 0 else ""
            lines.append(f"            {name:<5}{cells}{unseen}")
        if low is not None:
            lines.append(
                f"            * lowest: {low[0]}'s {low[1]} — L's guess of the damaged part"
            )
        else:
            lines.append(f"            no single lowest feature ({ranked[0][0]:.3f} is shared)")
    if learned is not None:
        acc = ", ".join(f"{n} {a:.2f}" for n, a in result.behavior_accuracy_per_robot.items())
        lines.append(f"          behaviour accuracy: {acc} (mean {result.behavior_accuracy:.2f})")
        for i, r in enumerate(learned.robots):
            start = dom.state_index(*scenario.robots[i].start)
            cyc = policy_cycle(dom, r.policy, int(start))
            true = set(policy_cycle(dom, scenario.true_policy(i), int(start)).tolist())
            same = "the true patrol" if set(cyc.tolist()) == true else "differs from the truth"
            ends = " and ".join(str(c) for c in _turn_cells(dom, cyc)) or "nowhere"
            lines.append(
                f"          patrol of {r.name}: a {len(cyc)}-step loop turning at {ends} ({same})"
            )
        lines.append(f"          interaction equilibrium (I/J): {learned.equilibrium.label()}")
    if result.go_time is None:
        lines.append(
            f"planned   {len(result.attempts)} rounds, no go time with a positive value "
            f"(best {max(a.best_value for a in result.attempts):.2f})"
            if result.attempts
            else "planned   -"
        )
    elif result.plan_value is None:
        lines.append(f"went      at t={result.go_time} (a random time)")
    else:
        lines.append(
            f"went      at t={result.go_time}, {result.go_time - (result.obs_steps - 1)} steps "
            f"after observing, value {result.plan_value:.2f} ({len(result.attempts)} planning "
            "rounds)"
        )
    outcome = {
        "success": f"success — reached the goal {scenario.goal} unseen at t={result.end_time}",
        "detected": "detected — "
        + "; ".join(
            f"{d.robot} at {d.robot_state} saw L on {d.observer_cell} at t={d.t}"
            for d in result.detections
        ),
        "timeout": f"timeout — no safe go time before t={result.end_time}",
    }[result.outcome]
    lines.append(f"outcome   {outcome}")
    tm = result.timings
    lines.append(
        "time      "
        + ", ".join(f"{k} {tm[k]:.2f} s" for k in ("observe", "learn", "plan", "execute"))
        + f"; total {tm['total']:.2f} s"
    )
    return "\n".join(lines)
