"""Record the adaptive go rule's decisions of many runs, for measuring chances offline: at every
round that weighs going now against waiting, the round's plan, the models L holds and whether
it went; at the go, the chance L stated; per run, everything L saw and the outcome.

    python benchmarks/capture_decisions.py --out /tmp/dec --base 1000 --runs 60
    python benchmarks/capture_decisions.py --out /tmp/dec --method known-r-t --observability 1

Run i is ``run_episode(scenario, method, seed=run_seed(BASE, i))`` under the default protocol
with 300 observed steps (the sweeps' protocol; ``--watch`` adds ``mirl run``'s watching until
every patroller was seen on 40 steps). Each run is one pickle ``OUT/run_<i>.pkl`` (a second
call skips the runs it holds). The decisions are read through the internals of the episode
and go-rule modules (the watcher, the planner, the value of waiting and the call of
``success_probability`` for the point models' chance at the go),
which is why this is a benchmark and not a library function; ``bench_posterior_chance.py``
reads what it writes.
"""

from __future__ import annotations

import argparse
import os
import pickle
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import mirl.experiments.episode as episode  # noqa: E402
import mirl.experiments.go_rules as go_rules  # noqa: E402
from mirl.experiments.conditions import Condition, run_seed  # noqa: E402
from mirl.experiments.options import RunProtocol  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--damage", default=None)
    ap.add_argument("--method", default="mirl-t")
    ap.add_argument("--observability", type=float, default=0.14)
    ap.add_argument("--base", type=int, default=1000, help="run i is seeded run_seed(BASE, i)")
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--world", default="grid")
    ap.add_argument("--watch", action="store_true", help="mirl run's watching protocol")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cond = Condition(args.method, args.scenario, args.observability, damage=args.damage)
    scenario = cond.scenario_object()
    state: dict = {}

    watcher_init = episode._Watcher.__init__
    solve = go_rules.solve_observer_mdp
    waiting_value = go_rules.waiting_value
    evaluate = go_rules.success_probability

    def keep_watcher(self, *a, **k):
        state["watcher"] = self
        watcher_init(self, *a, **k)

    def keep_plan(model, prediction, **kwargs):
        plan = solve(model, prediction, **kwargs)
        if kwargs.get("window", 0) > 0 and kwargs.get("detection_penalty") == 0.0:
            state["plan"], state["model"] = plan, model  # the adaptive rule's plan
        return plan

    def models_key(learned) -> int:
        models = state["models"]
        for k, m in enumerate(models):
            if m is learned:
                return k
        models.append(learned)
        return len(models) - 1

    def weigh(chances, later):
        value = waiting_value(chances, later)
        watcher, plan = state["watcher"], state["plan"]
        state["decisions"].append({
            "t": watcher.world.t, "went": bool(plan.go_values[0] >= value), "value": value,
            "go_value": float(plan.go_values[0]), "plan": plan, "later": later,
            "moments": list(chances), "models": models_key(watcher.learned), "forced": False,
        })  # fmt: skip
        return value

    def at_go(belief_filter, model, plan, **kwargs):
        stated = evaluate(belief_filter, model, plan, **kwargs)
        watcher = state["watcher"]
        dec = state["decisions"]
        if not dec or dec[-1]["t"] != watcher.world.t or not dec[-1]["went"]:
            dec.append({
                "t": watcher.world.t, "went": True, "value": None,
                "go_value": float(plan.go_values[0]), "plan": plan, "later": 0, "moments": [],
                "models": models_key(watcher.learned), "forced": True,
            })  # fmt: skip
        dec[-1]["stated"] = stated.success
        dec[-1]["extra"] = kwargs.get("extra", 0)
        return stated

    episode._Watcher.__init__ = keep_watcher
    go_rules.solve_observer_mdp = keep_plan
    go_rules.waiting_value = weigh
    go_rules.success_probability = at_go
    for i in range(args.first, args.first + args.runs):
        path = out / f"run_{i}.pkl"
        if path.exists():
            continue
        state.update(decisions=[], models=[])
        seed = run_seed(args.base, i)
        protocol = RunProtocol(obs_steps=300, watch_until_seen=None)
        if args.watch:
            protocol = RunProtocol()
        r = episode.run_episode(
            scenario, args.method, observability=args.observability, seed=seed,
            world=args.world, protocol=protocol,
        )  # fmt: skip
        watcher = state["watcher"]
        go = r.go_time
        seen = np.asarray(watcher.world.seen[: (go if go is not None else watcher.world.t) + 1])
        record = {
            "run": i, "seed": seed, "method": args.method, "scenario": args.scenario,
            "damage": args.damage, "observability": args.observability, "world": args.world,
            "outcome": r.outcome, "go_time": go, "stated": r.predicted_success_point,
            "seen": seen, "visible": watcher.visible, "joint": watcher.joint,
            "decisions": state["decisions"], "models": state["models"],
            "relearns": len(r.relearns or ()), "cpu": r.timings["cpu"],
            "seen_steps": r.seen_steps,
        }  # fmt: skip
        with open(path, "wb") as f:
            pickle.dump(record, f)
        print(i, r.outcome, go, f"{r.predicted_success_point:.3f}" if go is not None else "-",
              len(state["decisions"]), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
