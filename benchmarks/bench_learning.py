"""Learned behaviour accuracy and speed of `mirl.learning.learn`.

    python benchmarks/bench_learning.py [--seeds 10] [--workers 2]            # accuracy grid
    python benchmarks/bench_learning.py --timing-only [--repeats 9]           # `mirl learn` time
    python benchmarks/bench_learning.py --variants --seeds 10                 # IRL design choices

The grid is mean ± std (over seeds) of the per-run behaviour accuracy averaged over both
patrollers, for every observability degree × observation length, on boyd2 (J's left wheel
damaged) with random patroller starts. The timing runs the real command line
(`mirl learn --scenario boyd2 --observations FILE --observability 0.14`, 450 steps) pinned to one
core with single-threaded BLAS, and reports the median wall time and the split of `timings`.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core per run, before numpy loads
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

from mirl.learning.learn import learn
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario

OBSERVABILITY = (0.14, 0.3, 0.5, 0.75, 1.0)
STEPS = (150, 300, 450, 900)


def one_run(scenario_name: str, method: str, degree: float, steps: int, seed: int, **options):
    scenario = load_scenario(scenario_name)
    run = simulate(scenario, steps, seed=seed, observability=degree, random_starts=True)
    cpu = time.process_time()
    res = learn(
        run.observations, scenario, method, observability=degree, random_state=seed,
        options=options,
    )  # fmt: skip
    return {
        "method": method,
        "degree": degree,
        "steps": steps,
        "seed": seed,
        "accuracy": [r.behavior_accuracy for r in res.robots],
        "iterations": res.iterations,
        "converged": res.success,
        "equilibrium": res.equilibrium.label(),
        "cpu": time.process_time() - cpu,
        "left_right_J": [
            res.robots[1].feature_probabilities.get(f, np.nan)
            for f in ("left_wheel", "right_wheel")
        ],
        "variant": json.dumps(options, sort_keys=True),
    }


def grid(args) -> list[dict]:
    jobs = [
        delayed(one_run)(args.scenario, m, d, n, s)
        for m in args.methods
        for d in args.observability
        for n in args.steps
        for s in range(args.seeds)
    ]
    rows = Parallel(n_jobs=args.workers, verbose=0)(jobs)
    for method in args.methods:
        print(f"\n{method}: behaviour accuracy, mean ± std over {args.seeds} seeds (both robots)")
        print(f"{'observability':>13}" + "".join(f"{n:>16}" for n in args.steps))
        for d in args.observability:
            cells = []
            for n in args.steps:
                acc = [
                    np.mean(r["accuracy"])
                    for r in rows
                    if r["method"] == method and r["degree"] == d and r["steps"] == n
                ]
                cells.append(f"{np.mean(acc):.3f} ± {np.std(acc, ddof=1):.3f}")
            print(f"{d:>13g}" + "".join(f"{c:>16}" for c in cells))
        sel = [r for r in rows if r["method"] == method]
        print(
            f"  cpu per run: median {np.median([r['cpu'] for r in sel]):.2f} s; "
            f"labels converged in {np.mean([r['converged'] for r in sel]):.0%} of runs; "
            f"mean rounds {np.mean([r['iterations'] for r in sel]):.2f}; "
            f"stop/go chosen in {np.mean([r['equilibrium'] == 'stop/go' for r in sel]):.0%}"
        )
    return rows


VARIANTS = (
    {"objective": "sequence", "optimizer": "lbfgs"},
    {"objective": "sequence", "optimizer": "nelder-mead"},
    {"objective": "counts", "optimizer": "nelder-mead"},
    {"objective": "counts", "optimizer": "nelder-mead", "irl_options": {"anchor": "first"}},
    {"objective": "counts", "optimizer": "lbfgs"},
    {"objective": "likelihood", "optimizer": "lbfgs"},
    {"objective": "both", "optimizer": "lbfgs"},
)


def variants(args) -> list[dict]:
    """mirl-t with each IRL objective × optimiser at 450 steps."""
    jobs = [
        delayed(one_run)(args.scenario, "mirl-t", d, 450, s, **v)
        for v in VARIANTS
        for d in (0.14, 0.5, 1.0)
        for s in range(args.seeds)
    ]
    rows = Parallel(n_jobs=args.workers)(jobs)
    print(f"\nmirl-t at 450 steps by IRL objective / optimiser ({args.seeds} seeds)")
    print(f"{'objective':>11}{'optimizer':>19}" + "".join(f"{d:>16g}" for d in (0.14, 0.5, 1.0)))
    for v in VARIANTS:
        cells, cpu = [], []
        for d in (0.14, 0.5, 1.0):
            key = json.dumps(v, sort_keys=True)
            sel = [r for r in rows if r["degree"] == d and r["variant"] == key]
            acc = [np.mean(r["accuracy"]) for r in sel]
            cpu += [r["cpu"] for r in sel]
            cells.append(f"{np.mean(acc):.3f} ± {np.std(acc, ddof=1):.3f}")
        name = v["optimizer"] + ("/first" if "irl_options" in v else "")
        print(
            f"{v['objective']:>11}{name:>19}"
            + "".join(f"{c:>16}" for c in cells)
            + f"   median cpu {np.median(cpu):.2f} s"
        )
    return rows


def timing(args) -> None:
    """Median wall time of the `mirl learn` command at 0.14 observability and 450 steps."""
    exe = shutil.which("mirl")
    if exe is None:
        raise SystemExit("the mirl command is not on PATH (pip install -e .)")
    pin = ["taskset", "-c", "0"] if shutil.which("taskset") else []
    scenario = load_scenario(args.scenario)
    walls, splits = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeats):
            csv = Path(tmp) / f"obs{rep}.csv"
            run = simulate(scenario, 450, seed=100 + rep, observability=0.14, random_starts=True)
            run.observations.to_csv(csv)
            cmd = [exe, "learn", "--scenario", args.scenario, "--observations", str(csv)]
            cmd += ["--observability", "0.14", "--json"]
            t0 = time.perf_counter()
            out = subprocess.run(pin + cmd, capture_output=True, text=True, check=True)
            walls.append(time.perf_counter() - t0)
            splits.append(json.loads(out.stdout)["timings"])
    print(f"\n`mirl learn` on {args.scenario}, 0.14 observability, 450 steps, {args.repeats} runs")
    print(
        f"  wall time (whole command, {'one core' if pin else 'unpinned'}): median "
        f"{np.median(walls):.2f} s, min {min(walls):.2f} s, max {max(walls):.2f} s"
    )
    phases = sorted(
        {k for s in splits for k in s}, key=lambda k: -np.median([s.get(k, 0) for s in splits])
    )
    print(
        "  inside learn (median): "
        + ", ".join(f"{k} {np.median([s.get(k, 0.0) for s in splits]):.2f} s" for k in phases)
    )
    print(
        f"  outside learn (start-up, imports, CSV, scenario truth): median "
        f"{np.median([w - s['total'] for w, s in zip(walls, splits, strict=True)]):.2f} s"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--methods", nargs="+", default=["mirl-t", "known-r-t"])
    ap.add_argument("--observability", type=float, nargs="+", default=list(OBSERVABILITY))
    ap.add_argument("--steps", type=int, nargs="+", default=list(STEPS))
    ap.add_argument("--repeats", type=int, default=9, help="timing runs of `mirl learn`")
    ap.add_argument("--timing-only", action="store_true")
    ap.add_argument("--variants", action="store_true", help="compare IRL objectives/optimisers")
    ap.add_argument("--json", metavar="FILE", help="also write every run as JSON")
    args = ap.parse_args()
    rows: list[dict] = []
    if args.variants:
        rows = variants(args)
    elif not args.timing_only:
        rows = grid(args)
    if not args.variants:
        timing(args)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float))


if __name__ == "__main__":
    main()
