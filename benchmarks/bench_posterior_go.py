"""The adaptive go rule acting on the chance averaged over a posterior of the patrollers' models,
run by run against today's rule on the same seeds.

    python benchmarks/bench_posterior_go.py --mode state --base 1000 --runs 40 --out s.jsonl
    python benchmarks/bench_posterior_go.py --mode go --draws 8 --base 1000 --runs 40

Modes (each run also runs today's rule on its seed, unless ``--no-pair``):

- ``state``: today's decisions; at the go L states the posterior-averaged chance;
- ``go``: when today's rule would go (the go-now chance beats the value of waiting), the
  go-now chance is scaled by the posterior-averaged exact chance over the point models' exact
  chance (both along the round's plan), and L goes only if that still beats the value of
  waiting; it states the posterior-averaged chance;
- ``both``: the go-now chance and the chances of the record's moments are all the planner's
  chances averaged over the draws (like with like), and L states the posterior-averaged chance.

The draws (``mirl.learning.model_posterior.draw_models``: T from the feature posterior, the
reward from a block bootstrap, the equilibrium by its weights) are made once per learning; one
filter per draw runs over the record (``mirl.planning.posterior_chance.PosteriorBeliefs``).
Run i is seeded ``run_seed(BASE, i)``; mirl-t, 300 observed steps, the default protocol
otherwise. The rule is swapped in through the episode module's internals (its
``_planned_going``), which is why this is a benchmark. Prints success, timeouts, the sign test
against today's rule, mean stated against realised where L went (with its standard error), per
decile, and the CPU per run of both.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.stats import binomtest  # noqa: E402

import mirl.experiments.episode as episode  # noqa: E402
from mirl.experiments.conditions import Condition, run_seed  # noqa: E402
from mirl.experiments.execution import Decision, wait_for_go  # noqa: E402
from mirl.experiments.records import WATCH_UNTIL_SEEN, PlanAttempt  # noqa: E402
from mirl.learning.model_posterior import draw_models  # noqa: E402
from mirl.learning.results import oracle_models  # noqa: E402
from mirl.planning.belief import BeliefFilter  # noqa: E402
from mirl.planning.go import solve_observer_mdp, waiting_value  # noqa: E402
from mirl.planning.posterior_chance import PosteriorBeliefs  # noqa: E402
from mirl.planning.success import success_probability  # noqa: E402

ORIGINAL = episode._planned_going
SETTINGS: dict = {}


class _Posterior:
    """The draws of the watcher's current models and their filters, synced on demand."""

    def __init__(self, watcher, n_draws: int, parts, reward: str) -> None:
        self.watcher, self.n_draws, self.what, self.reward = watcher, n_draws, parts, reward
        self.learned = None
        self.beliefs: PosteriorBeliefs | None = None
        self.cpu = 0.0
        self.parts = {"draws": 0.0, "filters": 0.0}
        self.successes: dict = {}  # (t, id(plan)) -> the draws' chances

    def sync(self) -> PosteriorBeliefs:
        clock = time.process_time()
        w = self.watcher
        drawing = 0.0
        if w.learned is not self.learned:
            self.successes = {}
            learned = w.learned
            seen = np.asarray(w.world.seen)
            horizon = learned.horizon or len(seen)
            draws = draw_models(
                learned, list(seen[:horizon].T), w.scenario, visible=w.world.visible,
                n_draws=self.n_draws, parts=self.what, reward=self.reward,
                shared=SETTINGS["shared"],
                random_state=SETTINGS["seed"] % 2**31,
            )  # fmt: skip
            if SETTINGS["factored"]:
                self.beliefs = PosteriorBeliefs(
                    w.scenario.domain, draws, visible=w.visible, joint=False, reference=learned
                )
            else:
                self.beliefs = PosteriorBeliefs(
                    w.scenario.domain, draws, visible=w.visible, joint=w.joint
                )
            self.learned = learned
            drawing = time.process_time() - clock
            self.parts["draws"] += drawing
        assert self.beliefs is not None
        moments = {t for t, _ in w.moments}
        for now in w.world.seen[self.beliefs.t + 1 :]:
            self.beliefs.update(now)
            if self.beliefs.t in moments:
                self.beliefs.keep()
        self.cpu += time.process_time() - clock
        self.parts["filters"] += time.process_time() - clock - drawing
        return self.beliefs

    def success(self, model, plan, travel):
        """The draws' chances of going now along ``plan`` (computed once per round)."""
        key = (self.watcher.world.t, id(plan))
        if key not in self.successes:
            beliefs = self.sync()
            clock = time.process_time()
            if SETTINGS["factored"]:
                exact = success_probability(self.watcher.belief, model, plan, extra=travel)
                self.successes[key] = exact.success + beliefs.shifts(model, plan, extra=travel)
            else:
                self.successes[key] = beliefs.success(model, plan, extra=travel)
            self.cpu += time.process_time() - clock
            self.parts["success"] = self.parts.get("success", 0.0) + time.process_time() - clock
        return self.successes[key]


def planned_going(world, watcher, model, planning, timings):
    """``episode._planned_going`` with the adaptive rule on the posterior (module doc)."""
    mode = SETTINGS["mode"]
    if mode == "point" or planning.go_rule != "adaptive":
        return ORIGINAL(world, watcher, model, planning, timings)
    post = _Posterior(watcher, SETTINGS["draws"], SETTINGS["parts"], SETTINGS["reward"])
    SETTINGS["posterior"] = post
    moment_chances: dict[int, float] = {}

    def solve(steps, window, penalty, min_value=0.0):
        return solve_observer_mdp(
            model, watcher.belief.predict(steps, model), window=window,
            goal_reward=planning.goal_reward, detection_penalty=penalty, min_value=min_value,
            hazard=planning.hazard,
        )  # fmt: skip

    def chance_at(t, belief):
        prediction = watcher.belief.predict(planning.moment_travel, model, belief=belief, t=t)
        plan = solve_observer_mdp(
            model, prediction, window=0, goal_reward=planning.goal_reward,
            detection_penalty=0.0, min_value=-1.0, hazard=planning.hazard,
        )  # fmt: skip
        return float(plan.go_values[0])

    def posterior_moments() -> list[float]:
        beliefs = post.sync()
        if post.learned is not SETTINGS.get("scored_for"):
            moment_chances.clear()
            SETTINGS["scored_for"] = post.learned
        out = []
        for t, _ in watcher.moments:
            if t not in moment_chances:
                clock = time.process_time()
                if t in beliefs.kept and SETTINGS["averaged"]:
                    moment_chances[t] = beliefs.averaged_chance(model, planning.moment_travel, t=t)
                elif t in beliefs.kept:
                    moment_chances[t] = float(
                        beliefs.chances_at(t, model, planning.moment_travel).mean()
                    )
                else:  # a moment before the draws' filters could keep it: the point chance
                    moment_chances[t] = chance_at(t, dict(watcher.moments)[t])
                post.cpu += time.process_time() - clock
            out.append(moment_chances[t])
        return out

    def decide() -> Decision:
        t = world.t
        win = min(planning.window, planning.deadline - t)
        plan = solve(win + planning.travel, win, 0.0, min_value=-1.0)
        best = plan.go_time if plan.go_time is not None else 0
        go = win == 0
        if not go and best == 0:
            later = (planning.deadline - t - win) // planning.opportunity_steps
            if mode == "both":
                beliefs = post.sync()
                clock = time.process_time()
                now_chance = float(beliefs.planner_now(model, win + planning.travel, win).mean())
                post.cpu += time.process_time() - clock
                go = now_chance >= waiting_value(posterior_moments(), later)
            else:
                value = waiting_value(watcher.chances(chance_at), later)
                go = float(plan.go_values[0]) >= value
                if go and mode == "go":
                    clock = time.process_time()
                    point = success_probability(
                        watcher.belief, model, plan, extra=planning.travel
                    ).success
                    post.cpu += time.process_time() - clock
                    mean = float(post.success(model, plan, planning.travel).mean())
                    go = float(plan.go_values[0]) * mean / max(point, 1e-9) >= value
        now = None
        if go:
            draws = post.success(model, plan, planning.travel)
            now = float(draws.mean())
            SETTINGS["stated_draws"] = draws.tolist()
            clock = time.process_time()
            SETTINGS["point_stated"] = success_probability(
                watcher.belief, model, plan, extra=planning.travel
            ).success
            truth = BeliefFilter(
                watcher.scenario.domain, SETTINGS["truth"], visible=watcher.visible,
                joint=watcher.joint,
            )  # fmt: skip
            for seen in world.seen:
                truth.update(seen)
            SETTINGS["true_stated"] = success_probability(
                truth, model, plan, extra=planning.travel
            ).success
            SETTINGS["measuring"] += time.process_time() - clock
        go_time = t if go else None
        step = best if 0 < best < planning.replan_every else planning.replan_every
        attempt = PlanAttempt(t, float(plan.go_values.max()), go_time, now)
        return Decision(plan, go_time, t + step, attempt)

    plan, go_time, attempts = wait_for_go(
        world, decide, watcher.observe, planning.deadline, planning.commit, timings
    )
    plan_value = None if go_time is None else float(plan.go_values[go_time - plan.t0])

    def policy(k, s):
        return int(plan.policy[k, s])

    def replan():
        return solve(planning.travel, 0, 0.0)

    return episode._Going(
        go_time, policy, replan, plan, tuple(attempts), plan_value, watcher.belief,
        predicted_success=None if go_time is None else attempts[-1].predicted_success,
        learned=watcher.learned, relearns=tuple(watcher.relearns),
    )  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mode", default="state", choices=("state", "go", "both"))
    ap.add_argument("--draws", type=int, default=8)
    ap.add_argument("--parts", default="transitions,rewards,equilibrium")
    ap.add_argument("--reward", default="bootstrap")
    ap.add_argument("--shared", action="store_true", help="the shared-kind reward mixture")
    ap.add_argument(
        "--averaged", action="store_true",
        help="mode both: one planner solve on the draws' averaged prediction",
    )  # fmt: skip
    ap.add_argument(
        "--factored", action="store_true",
        help="filter the draws factored; shift the point models' exact chance by their change",
    )  # fmt: skip
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--damage", default=None)
    ap.add_argument("--method", default="mirl-t")
    ap.add_argument("--observability", type=float, default=0.14)
    ap.add_argument("--base", type=int, default=1000)
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--world", default="grid")
    ap.add_argument("--watch", action="store_true", help="mirl run's watching protocol")
    ap.add_argument("--no-pair", action="store_true", help="skip today's rule")
    ap.add_argument("--out", default=None)
    ap.add_argument("--report", action="store_true", help="only report what --out holds")
    args = ap.parse_args()
    if args.report:
        with open(args.out) as f:
            report([json.loads(line) for line in f], args)
        return
    cond = Condition(args.method, args.scenario, args.observability, damage=args.damage)
    scenario = cond.scenario_object()
    SETTINGS.update(draws=args.draws, parts=tuple(args.parts.split(",")), reward=args.reward,
                    truth=oracle_models(scenario), shared=args.shared,
                    factored=args.factored, averaged=args.averaged)  # fmt: skip
    episode._planned_going = planned_going
    done = set()
    rows = []
    if args.out and os.path.exists(args.out):
        with open(args.out) as f:
            rows = [json.loads(line) for line in f]
        done = {r["run"] for r in rows}
    out = open(args.out, "a") if args.out else None
    kwargs = dict(
        observability=args.observability, obs_steps=300, world=args.world,
        watch_until_seen=WATCH_UNTIL_SEEN if args.watch else None,
    )  # fmt: skip
    for i in range(args.first, args.first + args.runs):
        if i in done:
            continue
        seed = run_seed(args.base, i)
        row = {"run": i, "seed": seed}
        if not args.no_pair:
            SETTINGS["mode"] = "point"
            r = episode.run_episode(scenario, args.method, seed=seed, **kwargs)
            row.update(base_outcome=r.outcome, base_stated=r.predicted_success,
                       base_cpu=r.timings["cpu"], base_go=r.go_time)  # fmt: skip
        SETTINGS.update(mode=args.mode, seed=seed, stated_draws=None, point_stated=None,
                        true_stated=None, measuring=0.0)  # fmt: skip
        r = episode.run_episode(scenario, args.method, seed=seed, **kwargs)
        post = SETTINGS.get("posterior")
        row.update(
            outcome=r.outcome, stated=r.predicted_success,
            cpu=r.timings["cpu"] - SETTINGS["measuring"], go=r.go_time,
            point_stated=SETTINGS["point_stated"], draws=SETTINGS["stated_draws"],
            true_stated=SETTINGS["true_stated"],
            posterior_cpu=post.cpu if post is not None else 0.0,
            posterior_parts=post.parts if post is not None else {},
            relearns=len(r.relearns or ()),
        )  # fmt: skip
        rows.append(row)
        if out is not None:
            print(json.dumps(row), file=out, flush=True)
    report(rows, args)


def report(rows, args) -> None:
    n = len(rows)
    y = np.array([r["outcome"] == "success" for r in rows], dtype=float)
    print(f"{args.scenario} {args.method} d={args.observability} mode={args.mode} "
          f"K={args.draws}: {n} runs")  # fmt: skip
    print(f"success {y.mean():.3f} ± {y.std() / np.sqrt(n):.3f}, timeouts "
          f"{np.mean([r['outcome'] == 'timeout' for r in rows]):.3f}")  # fmt: skip
    went = [r for r in rows if r["stated"] is not None]
    if went:
        s = np.array([r["stated"] for r in went])
        yw = np.array([r["outcome"] == "success" for r in went], dtype=float)
        pt = np.array([r["point_stated"] for r in went])
        print(f"where L went ({len(went)}): stated {s.mean():.3f} (point models' {pt.mean():.3f})"
              f" realised {yw.mean():.3f} ± {yw.std() / np.sqrt(len(yw)):.3f}; "
              f"difference {s.mean() - yw.mean():+.3f}")  # fmt: skip
        tr = np.array([r["true_stated"] for r in went])
        d = s - tr
        print(f"  against the true models' chance along the same plan {tr.mean():.3f}: "
              f"{d.mean():+.3f} ± {d.std() / np.sqrt(len(d)):.3f} (point models' "
              f"{(pt - tr).mean():+.3f})")  # fmt: skip
        draws = [r["draws"] for r in went if r["draws"]]
        if draws:
            lo_hi = np.array([np.quantile(x, [0.1, 0.9]) for x in draws])
            inside = (tr >= lo_hi[:, 0] - 1e-9) & (tr <= lo_hi[:, 1] + 1e-9)
            print(f"  the draws' 10–90 % range holds the true models' chance in "
                  f"{inside.mean():.2f} of the runs (mean width "
                  f"{(lo_hi[:, 1] - lo_hi[:, 0]).mean():.3f})")  # fmt: skip
        for lo in np.arange(0, 1, 0.1):
            sel = (s >= lo) & (s < lo + 0.1 + 1e-9 * (lo > 0.85))
            if sel.any():
                print(f"  {lo:.1f}-{lo + 0.1:.1f}: {sel.sum():3d} runs, stated "
                      f"{s[sel].mean():.3f}, realised {yw[sel].mean():.3f}")  # fmt: skip
    if "base_outcome" in rows[0]:
        b = np.array([r["base_outcome"] == "success" for r in rows], dtype=float)
        wins, losses = int(((y == 1) & (b == 0)).sum()), int(((y == 0) & (b == 1)).sum())
        p = binomtest(wins, wins + losses).pvalue if wins + losses else 1.0
        bs = [r for r in rows if r["base_stated"] is not None]
        sb = np.array([r["base_stated"] for r in bs])
        yb = np.array([r["base_outcome"] == "success" for r in bs], dtype=float)
        print(f"today's rule: success {b.mean():.3f}, stated {sb.mean():.3f} against realised "
              f"{yb.mean():.3f} ({sb.mean() - yb.mean():+.3f}); wins–losses {wins}–{losses} "
              f"(sign test p = {p:.2g})")  # fmt: skip
        c = np.array([r["cpu"] for r in rows])
        cb = np.array([r["base_cpu"] for r in rows])
        part = np.mean([r["posterior_cpu"] for r in rows])
        print(f"CPU per run {c.mean():.2f} s against {cb.mean():.2f} s: "
              f"{c.mean() / cb.mean():.2f}× (posterior part {part:.2f} s)")  # fmt: skip


if __name__ == "__main__":
    main()
