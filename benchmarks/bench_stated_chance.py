"""Where the stated P(success) of a learning L goes wrong: each run's go-time chance recomputed
with parts of L's learned models replaced by the truth, on the same record and the same plan.

    python benchmarks/bench_stated_chance.py --scenario boyd2 --seeds 60
    python benchmarks/bench_stated_chance.py --scenario boyd2-healthy --damage I:left_wheel

Run i uses ``run_seed(0, i)`` (the sweeps' seed of run i), method mirl-t, the default protocol
and 300 observed steps. At L's go the benchmark re-runs the belief filter over L's whole record
under each variant of the models and evaluates the success probability of the plan L went
with (``mirl.planning.success``, exact with the joint filter):

- ``learned``: L's models (the chance it stated);
- ``truth``: the scenario's true models;
- ``<robot> true``: that robot's learned model replaced by its true one;
- ``<robot> policy``: that robot's learned policy with its true T (everyone else true);
- ``<robot> T``: that robot's learned T with its true policy (everyone else true);
- ``<robot> reward``: the policy optimal for that robot's learned reward under its true T
  (everyone else true): whether its policy errs through the reward or through the T it was
  solved under.

Prints, per variant, the mean chance, its correlation with the outcome and the Brier score,
beside the realised success rate; then the same split by how many steps L saw each robot. The
go-time state is read through the episode module's internals (its watcher and its call of
``success_probability``), which is why this is a benchmark and not a library function.
"""

from __future__ import annotations

import argparse
import contextlib
import json
from dataclasses import replace

import numpy as np

import mirl.experiments.episode as episode
import mirl.experiments.go_rules as go_rules
from mirl.experiments.conditions import Condition, run_seed
from mirl.learning.results import LearnResult, oracle_models
from mirl.mdp import TabularMDP, value_iteration
from mirl.planning.belief import BeliefFilter


def variants(learned: LearnResult, truth: LearnResult, scenario) -> dict[str, LearnResult]:
    out = {"learned": learned, "truth": truth}
    for k, (mine, true) in enumerate(zip(learned.robots, truth.robots, strict=True)):

        def team(robot, k=k):
            robots = list(truth.robots)
            robots[k] = robot
            return replace(learned, robots=tuple(robots))

        others = list(learned.robots)
        others[k] = true
        out[f"{true.name} true"] = replace(learned, robots=tuple(others))
        out[f"{true.name} policy"] = team(replace(mine, transitions=true.transitions))
        out[f"{true.name} T"] = team(replace(true, transitions=mine.transitions))
        rewards = scenario.domain.rewards(mine.weights)
        solved = value_iteration(TabularMDP(true.transitions, rewards, scenario.discount))
        out[f"{true.name} reward"] = team(replace(true, policy=solved.policy))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--damage", default=None, help="ROBOT:FEATURE, as in the verdict sweep")
    ap.add_argument("--observability", type=float, default=0.14)
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--jsonl", default=None, help="also write one line per run here")
    args = ap.parse_args()
    cond = Condition("mirl-t", args.scenario, args.observability, damage=args.damage)
    scenario = cond.scenario_object()
    truth = oracle_models(scenario)

    watcher_init = episode._Watcher.__init__
    evaluate = go_rules.success_probability
    state: dict = {}

    def keep_watcher(self, *a, **k):
        state["watcher"] = self
        watcher_init(self, *a, **k)

    def at_go(belief_filter, model, plan, **kwargs):
        stated = evaluate(belief_filter, model, plan, **kwargs)
        watcher = state["watcher"]
        chances = {}
        for name, models in variants(watcher.learned, truth, scenario).items():
            f = BeliefFilter(scenario.domain, models, visible=watcher.visible, joint=watcher.joint)
            for now in watcher.world.seen:
                f.update(now)
            chances[name] = evaluate(f, model, plan, **kwargs).success
        state["chances"] = chances
        return stated

    episode._Watcher.__init__ = keep_watcher
    go_rules.success_probability = at_go
    rows = []
    with open(args.jsonl, "w") if args.jsonl else contextlib.nullcontext() as out:
        for i in range(args.seeds):
            state.pop("chances", None)
            r = episode.run_episode(
                scenario, "mirl-t", observability=args.observability, seed=run_seed(0, i),
                protocol={"obs_steps": 300, "watch_until_seen": None},
            )  # fmt: skip
            if "chances" not in state:
                continue
            row = {"run": i, "success": r.outcome == "success", "seen": r.seen_steps}
            row.update(state["chances"])
            rows.append(row)
            if out is not None:
                print(json.dumps(row), file=out, flush=True)
    y = np.array([r["success"] for r in rows], dtype=float)
    name = args.scenario + (f" with {args.damage} damaged" if args.damage else "")
    print(f"{name}, d = {args.observability}: {len(rows)} runs where L went, "
          f"realised success {y.mean():.3f}\n")  # fmt: skip
    print("| models | mean chance | correlation with success | Brier |")
    print("| --- | --- | --- | --- |")
    for key in rows[0]:
        if key in ("run", "success", "seen"):
            continue
        v = np.array([r[key] for r in rows])
        corr = np.corrcoef(v, y)[0, 1] if v.std() > 0 and y.std() > 0 else float("nan")
        print(f"| {key} | {v.mean():.3f} | {corr:.2f} | {np.mean((v - y) ** 2):.3f} |")
    for robot in truth.robots:
        seen = np.array([r["seen"][robot.name] for r in rows])
        for label, sel in (("never", seen == 0), ("1–20 steps", (seen > 0) & (seen <= 20)),
                           ("> 20 steps", seen > 20)):  # fmt: skip
            if sel.any():
                stated = np.array([r["learned"] for r in rows])[sel].mean()
                true = np.array([r["truth"] for r in rows])[sel].mean()
                print(f"L saw {robot.name} {label}: {sel.sum()} runs, stated {stated:.2f},"
                      f" truth {true:.2f}, realised {y[sel].mean():.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
