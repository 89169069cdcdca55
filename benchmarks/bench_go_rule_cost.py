"""CPU cost of a run under mirl's default protocol (the adaptive rule, re-learning while L
waits) against the paper's (the value rule, learning once), side by side on the same seeds.

    python benchmarks/bench_go_rule_cost.py --scenario office --seeds 3
    python benchmarks/bench_go_rule_cost.py --scenario boyd2 --seeds 20 --method mirl-t

Each seed runs both protocols one after the other in this process (one BLAS thread), so a
shared machine's load falls on both alike; prints each seed's CPU seconds and their ratio, and
the ratio of the totals; then what a re-learn of the default protocol costs against the run's
first learning (wall seconds of each, from the run record).
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from mirl.experiments.conditions import run_seed  # noqa: E402
from mirl.experiments.episode import run_episode  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--method", default="mirl-t")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--observability", type=float, default=None)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    totals = {"paper": 0.0, "default": 0.0}
    relearn_shares: list[float] = []
    print("| seed | paper's protocol (s CPU) | default (s CPU) | ratio | outcome (default) |")
    print("| --- | --- | --- | --- | --- |")
    for i in range(args.seeds):
        cpu = {}
        for name, rule, relearn in (("paper", "value", False), ("default", "adaptive", True)):
            r = run_episode(
                scenario, args.method, observability=args.observability, seed=run_seed(0, i),
                # 300 observed steps, as measured; the rule and re-learning as compared
                protocol={"watch_until_seen": None, "go_rule": rule, "relearn": relearn},
            )  # fmt: skip
            cpu[name] = r.timings["cpu"]
            totals[name] += cpu[name]
            if relearn and r.relearns:
                again = [x.seconds for x in r.relearns]
                first = r.timings["learn"] - sum(again)
                relearn_shares += [x / first for x in again]
        print(f"| {i} | {cpu['paper']:.2f} | {cpu['default']:.2f} | "
              f"{cpu['default'] / cpu['paper']:.2f} | {r.outcome} |")  # fmt: skip
    print(f"\nratio of the totals: {totals['default'] / totals['paper']:.2f}")
    if relearn_shares:
        q = sorted(relearn_shares)
        print(f"re-learns: {len(q)}; each costs {sum(q) / len(q):.2f}× the first learning on "
              f"average (median {q[len(q) // 2]:.2f}, {q[0]:.2f}–{q[-1]:.2f})")  # fmt: skip


if __name__ == "__main__":
    main()
