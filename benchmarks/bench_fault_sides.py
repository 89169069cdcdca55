"""Which wheel L finds in the physical world, per damaged motor (issue 26's table).

    python benchmarks/bench_fault_sides.py [--scenario boyd2-healthy] [--seeds 10] [--steps 450]

mirl-t on a scenario whose motors are all healthy (default boyd2-healthy) at full view, one
motor at 0.6 strength (I left, I right, J left, J right), seeds 0..n-1, each run ``mirl run
--world physics ... --json``. Per damaged motor: the max-ent point estimates of the damaged
wheel and the robot's other wheel (mean over seeds), how often the damaged wheel is the
robot's lowest feature (strictly), a paired t-test of the two wheels, how often the verdict
names the damaged wheel alone and among its candidates, and the robot's mean lateral drift
(cells, left positive).
"""

from __future__ import annotations

import argparse
import json
import subprocess

import numpy as np
from scipy import stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--steps", type=int, default=450)
    ap.add_argument("--scenario", default="boyd2-healthy")
    args = ap.parse_args()
    print("| damaged motor | learned damaged vs other wheel | damaged wheel lowest | paired t-test "
          "| verdict: the wheel alone | among candidates | lateral drift (cells) |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for damage in ("I:left_wheel", "I:right_wheel", "J:left_wheel", "J:right_wheel"):
        robot, wheel = damage.split(":")
        other = "right_wheel" if wheel == "left_wheel" else "left_wheel"
        damaged, healthy, drifts = [], [], []
        lowest = alone = among = 0
        for seed in range(args.seeds):
            cmd = ["mirl", "run", "--world", "physics", "--scenario", args.scenario,
                   "--damage", f"{damage}=0.6", "--observability", "1",
                   "--obs-steps", str(args.steps), "--seed", str(seed), "--json"]  # fmt: skip
            run = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
            probs = run["feature_probabilities"][robot]
            damaged.append(probs[wheel])
            healthy.append(probs[other])
            # strictly lowest: forward steps alone fix only the wheels' product, and max-ent
            # splits it evenly, a tie that no order of the features should break
            lowest += all(probs[wheel] < v - 1e-6 for f, v in probs.items() if f != wheel)
            verdict = run["verdicts"][robot]
            alone += verdict["part"] == wheel
            among += wheel in verdict["candidates"]
            drifts.append(run.get("lateral_drifts", {}).get(robot, {}).get("mean", np.nan))
        p = stats.ttest_rel(damaged, healthy).pvalue
        n = args.seeds
        print(f"| {robot} {wheel.replace('_', ' ')} | {np.mean(damaged):.3f} vs "
              f"{np.mean(healthy):.3f} | {lowest}/{n} | p = {p:.2g} | {alone}/{n} | "
              f"{among}/{n} | {np.nanmean(drifts):+.3f} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
