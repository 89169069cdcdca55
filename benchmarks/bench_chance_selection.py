"""Whether L's stated chance errs everywhere or only where it goes: at every decision of the
adaptive rule that weighs going now against waiting, the chance of going now along the plan,
under L's learned models and under the true ones (same record, same plan), split by whether
L went.

    python benchmarks/bench_chance_selection.py --scenario boyd2 --seeds 40 --observability 0.14
    python benchmarks/bench_chance_selection.py --scenario boyd2 --seeds 40 --observability 1

Run i uses ``run_seed(0, i)`` (the sweeps' seed of run i), method mirl-t, the default protocol
and 300 observed steps. A chance that is right on average where L waits and too high where it
goes is a selection effect: L goes when its models' error favours going (the winner's curse).
Decisions forced by the deadline are not counted (nothing is weighed there). The chances are
``mirl.planning.success`` without the shortest path after the plan's last step, the same for
both models. The decisions are read through the run's internals (the episode's watcher, the go
rules' planner and value of waiting), which is why this is a benchmark and not a library function.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import mirl.experiments.episode as episode  # noqa: E402
import mirl.experiments.go_rules as go_rules  # noqa: E402
from mirl.experiments.conditions import run_seed  # noqa: E402
from mirl.learning.results import oracle_models  # noqa: E402
from mirl.planning.belief import BeliefFilter  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--observability", type=float, default=0.14)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    truth = oracle_models(scenario)
    state: dict = {}
    rows: list[tuple[bool, float, float]] = []  # (went, learned chance, true chance)

    watcher_init = episode._Watcher.__init__
    solve = go_rules.solve_observer_mdp
    waiting_value = go_rules.waiting_value

    def keep_watcher(self, *a, **k):
        state["watcher"] = self
        watcher_init(self, *a, **k)

    def keep_plan(model, prediction, **kwargs):
        plan = solve(model, prediction, **kwargs)
        if kwargs.get("window", 0) > 0 and kwargs.get("detection_penalty") == 0.0:
            state["plan"], state["model"] = plan, model  # the adaptive rule's plan
        return plan

    def weigh(chances, later):
        value = waiting_value(chances, later)
        watcher, plan, model = state["watcher"], state["plan"], state["model"]
        true_filter = BeliefFilter(
            scenario.domain, truth, visible=watcher.visible, joint=watcher.joint
        )
        for now in watcher.world.seen:
            true_filter.update(now)
        learned = go_rules.success_probability(watcher.belief, model, plan).success
        true = go_rules.success_probability(true_filter, model, plan).success
        rows.append((bool(plan.go_values[0] >= value), learned, true))
        return value

    episode._Watcher.__init__ = keep_watcher
    go_rules.solve_observer_mdp = keep_plan
    go_rules.waiting_value = weigh
    for i in range(args.seeds):
        episode.run_episode(
            scenario, "mirl-t", observability=args.observability, seed=run_seed(0, i),
            protocol={"watch_until_seen": None},  # 300 observed steps, as measured
        )  # fmt: skip
    print(f"{args.scenario}, d = {args.observability}, {args.seeds} runs\n")
    print("| decision | n | learned chance | true chance | learned − true |")
    print("| --- | --- | --- | --- | --- |")
    for went in (True, False):
        sel = np.array([(a, b) for w, a, b in rows if w == went]).reshape(-1, 2)
        if len(sel):
            print(f"| {'went' if went else 'waited'} | {len(sel)} | {sel[:, 0].mean():.3f} | "
                  f"{sel[:, 1].mean():.3f} | {(sel[:, 0] - sel[:, 1]).mean():+.3f} |")  # fmt: skip


if __name__ == "__main__":
    main()
