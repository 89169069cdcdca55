"""The CPU cost of a default `mirl run` on two versions of mirl, whole processes side by side,
and whether both state the same chance and make the same decisions.

    python benchmarks/bench_stated_cost.py BEFORE/src AFTER/src --scenario office --seeds 0
    python benchmarks/bench_stated_cost.py BEFORE/src AFTER/src --seeds 0,1,2,3,4 --pairs 3

``BEFORE/src`` and ``AFTER/src`` are the ``src`` folders of two checkouts (e.g. a
``git worktree add /tmp/before <commit>``). A *pair* runs ``python -m mirl run --scenario S
--seed s --json`` for every seed under each version (its ``src`` first on ``PYTHONPATH``), the
versions in turn (A B A B …, after one warm-up pair that is not counted), so a shared machine's
drifting load falls on both alike. A version's cost in a pair is the CPU time (user + system,
``getrusage`` of the finished children) of its runs, summed over the seeds; the report gives
each pair's ratio AFTER / BEFORE and their min, median and max. The counted runs' outputs are
compared field by field: the stated chance (``predicted_success``, its interval and the point
models' chance), the go time and the outcome.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys

FIELDS = (
    "outcome",
    "go_time",
    "predicted_success",
    "predicted_success_interval",
    "predicted_success_point",
)


def run(src: str, scenario: str, seed: int) -> tuple[float, dict]:
    """One `mirl run` of version ``src``: its CPU seconds and its JSON output."""
    env = {**os.environ, "PYTHONPATH": src, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    argv = [sys.executable, "-m", "mirl", "run", "--scenario", scenario, "--seed", str(seed)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([*argv, "--json"], env=env, capture_output=True, text=True, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, json.loads(done.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", help="the src folder of the version measured against")
    ap.add_argument("after", help="the src folder of the version measured")
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--seeds", default="0", help="comma-separated seeds, run in each pair")
    ap.add_argument("--pairs", type=int, default=3, help="counted pairs (after one warm-up)")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    versions = {"before": args.before, "after": args.after}
    ratios, outputs = [], {}
    for k in range(args.pairs + 1):
        cpu = {}
        for name, src in versions.items():
            cpu[name] = 0.0
            for seed in seeds:
                seconds, out = run(src, args.scenario, seed)
                cpu[name] += seconds
                outputs.setdefault((name, seed), out)
        if k == 0:
            print(f"warm-up: before {cpu['before']:.2f} s, after {cpu['after']:.2f} s")
            continue
        ratios.append(cpu["after"] / cpu["before"])
        print(f"pair {k}: before {cpu['before']:.2f} s, after {cpu['after']:.2f} s, "
              f"ratio {ratios[-1]:.3f}")  # fmt: skip
        sys.stdout.flush()
    print(f"{args.scenario}, seeds {args.seeds}: ratio after / before, min {min(ratios):.3f}, "
          f"median {statistics.median(ratios):.3f}, max {max(ratios):.3f} "
          f"({len(ratios)} pairs)")  # fmt: skip
    differ = [
        (seed, field)
        for seed in seeds
        for field in FIELDS
        if outputs[("before", seed)].get(field) != outputs[("after", seed)].get(field)
    ]
    same = "identical in " + ", ".join(FIELDS)
    print("outputs: " + (same if not differ else f"differ: {differ}"))


if __name__ == "__main__":
    main()
