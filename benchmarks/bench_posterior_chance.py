"""The chance of going now averaged over model sets drawn from a posterior of the patrollers'
models, at the decisions ``capture_decisions.py`` recorded, beside the point models' chance and
the true models' (same record, same plan).

    python benchmarks/capture_decisions.py --out /tmp/dec --base 1000 --runs 60
    python benchmarks/bench_posterior_chance.py /tmp/dec --draws 16 --out /tmp/dec.jsonl

Every decision where L went is scored, and up to ``--waited`` of the decisions where it waited
per run (drawn with a fixed seed). The chance is ``mirl.planning.success`` along the round's
plan with the travel horizon after it, as L states it at a go. Variants (``--variants``):

- ``T``: each robot's T drawn from its feature posterior (the verdicts');
- ``R``: each robot's reward from a block bootstrap of its visits (refitted, warm-started);
- ``RL``: the reward from a Laplace approximation at the IRL optimum;
- ``E``: the equilibrium drawn by its posterior weights;
- ``all``: T, R (bootstrap) and E together; ``allL``: T, RL and E.

Prints, where L went and where it waited, the mean of each chance and its difference from the
true models' chance, and, at the go, the realised success rate (± s.e.). One JSON line per
decision scored (each variant's draws kept) goes to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from mirl.experiments.conditions import Condition  # noqa: E402
from mirl.learning.model_posterior import draw_models  # noqa: E402
from mirl.learning.results import oracle_models  # noqa: E402
from mirl.planning.belief import BeliefFilter  # noqa: E402
from mirl.planning.observer import observer_model  # noqa: E402
from mirl.planning.success import success_probability  # noqa: E402
from mirl.worlds import get_world  # noqa: E402

VARIANTS = {
    "T": dict(parts=("transitions",)),
    "R": dict(parts=("rewards",), reward="bootstrap"),
    "RL": dict(parts=("rewards",), reward="laplace"),
    "E": dict(parts=("equilibrium",)),
    "all": dict(parts=("transitions", "rewards", "equilibrium"), reward="bootstrap"),
    "allL": dict(parts=("transitions", "rewards", "equilibrium"), reward="laplace"),
    "allS": dict(parts=("transitions", "rewards", "equilibrium"), reward="bootstrap", shared=True),
    "RS": dict(parts=("rewards",), reward="bootstrap", shared=True),
    "allNS": dict(parts=("transitions", "rewards", "equilibrium"), reward="newton", shared=True),
    "RN": dict(parts=("rewards",), reward="newton"),
    "allS0": dict(parts=("transitions", "rewards", "equilibrium"), reward="point", shared=True),
    "allLS": dict(parts=("transitions", "rewards", "equilibrium"), reward="laplace", shared=True),
    "allSIR": dict(
        parts=("transitions", "rewards", "equilibrium"), reward="laplace-sir", shared=True
    ),
    "allN1S": dict(parts=("transitions", "rewards", "equilibrium"), reward="newton1", shared=True),
    "allSIRp": dict(
        parts=("transitions", "rewards", "equilibrium"), reward="laplace-sir-prior", shared=True
    ),
    "allSIRn": dict(parts=("transitions", "rewards", "equilibrium"), reward="laplace-sir"),
    "allSIRpn": dict(parts=("transitions", "rewards", "equilibrium"), reward="laplace-sir-prior"),
    "TE": dict(parts=("transitions", "equilibrium")),
    "allSIRP": dict(
        parts=("transitions", "rewards", "equilibrium"), reward="laplace-sir", shared="pooled"
    ),
    "allS0m": dict(
        parts=("transitions", "rewards", "equilibrium"),
        reward="point",
        shared=True,
        motion="posterior",
    ),
    "allN": dict(parts=("transitions", "rewards", "equilibrium"), reward="newton"),
}


def mixture(learned, draws, domain):
    """One model set whose robots move, every step, by the average of the draws' one-step
    kernels (their policies' actions under their T): the draws' policies averaged, not their
    chances. The point policy names each state's action (the meeting rule reads it); its row of
    T is the draws' averaged kernel."""
    A = domain.n_actions
    robots = []
    for i, r in enumerate(learned.robots):
        T = r.transitions.toarray()
        pol = np.asarray(r.policy, dtype=int)
        rows = np.arange(len(pol)) * A + pol
        T[rows] = np.mean(
            [m.robots[i].transitions.toarray()[np.arange(len(pol)) * A + m.robots[i].policy]
             for m in draws], axis=0,
        )  # fmt: skip
        robots.append(replace(r, transitions=sp.csr_array(T)))
    return replace(learned, robots=tuple(robots))


def chance(scenario, models, run, t, model, plan, travel, joint=None) -> float:
    joint = run["joint"] if joint is None else joint
    f = BeliefFilter(scenario.domain, models, visible=run["visible"], joint=joint)
    for now in run["seen"][: t + 1]:
        f.update(now)
    return success_probability(f, model, plan, extra=travel).success


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("captured")
    ap.add_argument("--draws", type=int, default=16)
    ap.add_argument("--variants", default="T,R,E,all")
    ap.add_argument("--waited", type=int, default=2)
    ap.add_argument("--out", default=None)
    ap.add_argument("--runs", type=int, default=None)
    ap.add_argument("--mix", action="store_true", help="also the draws' policies averaged")
    ap.add_argument("--only-went", action="store_true")
    ap.add_argument(
        "--factored", action="store_true",
        help="also the point chance shifted by the draws' mean change under factored filters",
    )  # fmt: skip
    args = ap.parse_args()
    variants = args.variants.split(",")
    paths = sorted(Path(args.captured).glob("run_*.pkl"), key=lambda p: int(p.stem[4:]))
    if args.runs:
        paths = paths[: args.runs]
    rows = []
    cache: dict = {}
    out = open(args.out, "w") if args.out else None
    cpu = {v: 0.0 for v in ["point", *variants]}
    for path in paths:
        with open(path, "rb") as f:
            run = pickle.load(f)
        key = (run["scenario"], run["damage"], run["method"], run["observability"], run["world"])
        if key not in cache:
            cond = Condition(run["method"], run["scenario"], run["observability"], run["damage"])
            scenario = cond.scenario_object()
            model = observer_model(scenario)
            # L's models take the world's ξ (the physical world's turns need no wheel)
            scenario = get_world(run.get("world", "grid")).load().modelled(scenario)
            travel = max(20, 3 * int(model.distance_to_goal[model.start_state]))
            cache[key] = (scenario, model, travel, oracle_models(scenario))
        scenario, model, travel, truth = cache[key]
        rng = np.random.default_rng(run["run"])
        decisions = run["decisions"]
        waited = [k for k, d in enumerate(decisions) if not d["went"]]
        pick = set(rng.permutation(waited)[: 0 if args.only_went else args.waited].tolist())
        draws: dict = {}
        for k, d in enumerate(decisions):
            if not (d["went"] or k in pick):
                continue
            learned = run["models"][d["models"]]
            is_go = d["went"] and k == len(decisions) - 1 and run["go_time"] == d["t"]
            row = {
                "run": run["run"], "t": d["t"], "went": d["went"], "forced": d["forced"],
                "go": is_go, "success": run["outcome"] == "success" if is_go else None,
                "seen": run["seen_steps"],
            }  # fmt: skip
            clock = time.process_time()
            row["learned"] = chance(scenario, learned, run, d["t"], model, d["plan"], travel)
            cpu["point"] += time.process_time() - clock
            row["truth"] = chance(scenario, truth, run, d["t"], model, d["plan"], travel)
            for v in variants:
                clock = time.process_time()
                dk = (v, d["models"])
                if dk not in draws:
                    series = list(run["seen"][: learned.horizon].T)
                    draws[dk] = draw_models(
                        learned, series, scenario, visible=run["visible"], n_draws=args.draws,
                        random_state=run["seed"] % 2**31, **VARIANTS[v],
                    )  # fmt: skip
                vals = [
                    chance(scenario, m, run, d["t"], model, d["plan"], travel) for m in draws[dk]
                ]
                cpu[v] += time.process_time() - clock
                row[v] = float(np.mean(vals))
                row[v + "_draws"] = vals
                if args.factored:
                    clock = time.process_time()
                    fact = [
                        chance(scenario, m, run, d["t"], model, d["plan"], travel, joint=False)
                        for m in draws[dk]
                    ]
                    base = chance(
                        scenario, learned, run, d["t"], model, d["plan"], travel, joint=False
                    )
                    row[v + "shift"] = row["learned"] + float(np.mean(fact)) - base
                    cpu[v + "shift"] = cpu.get(v + "shift", 0.0) + time.process_time() - clock
                if args.mix:
                    mixed = mixture(learned, draws[dk], scenario.domain)
                    row[v + "mix"] = chance(scenario, mixed, run, d["t"], model, d["plan"], travel)
            rows.append(row)
            if out is not None:
                print(json.dumps(row), file=out, flush=True)
    extra = [v + "mix" for v in variants if args.mix]
    extra += [v + "shift" for v in variants if args.factored]
    report(rows, ["learned", "truth", *variants, *extra])
    n = len(rows)
    print("\nCPU per scored decision (s): " + ", ".join(f"{k} {v / n:.3f}" for k, v in cpu.items()))


def report(rows, keys) -> None:
    for label, sel in (
        ("went (weighed)", [r for r in rows if r["went"] and not r["forced"]]),
        ("went (forced)", [r for r in rows if r["forced"]]),
        ("waited", [r for r in rows if not r["went"]]),
    ):
        if not sel:
            continue
        print(f"\n{label}: {len(sel)} decisions")
        print("| chance | mean | minus true |")
        print("| --- | --- | --- |")
        tr = np.array([r["truth"] for r in sel])
        for k in keys:
            d = np.array([r[k] for r in sel]) - tr
            se = d.std() / np.sqrt(len(d))
            print(f"| {k} | {(d + tr).mean():.3f} | {d.mean():+.3f} ± {se:.3f} |")
    go = [r for r in rows if r["go"]]
    if go:
        y = np.array([r["success"] for r in go], dtype=float)
        se = y.std() / np.sqrt(len(y))
        print(f"\nat the go: {len(go)} runs, realised {y.mean():.3f} ± {se:.3f}")
        print("| chance | mean stated | minus realised | Brier |")
        print("| --- | --- | --- | --- |")
        for k in keys:
            v = np.array([r[k] for r in go])
            brier = np.mean((v - y) ** 2)
            print(f"| {k} | {v.mean():.3f} | {v.mean() - y.mean():+.3f} | {brier:.3f} |")


if __name__ == "__main__":
    main()
