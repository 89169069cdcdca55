"""The cost estimate of `mirl run` against the measured peak memory and CPU time, on maps given
as scenario files (e.g. public ROS maps resampled to 0.5 and 0.25 m cells), run one at a time:

    python benchmarks/bench_cost.py SCENARIO.toml [...] [--obs-steps 300]

Prints per scenario the states, the estimate (memory, time) and the measurement (peak RSS of the
child process, its CPU time and wall time), and their ratios: an estimate is meant to be an upper
bound, so a ratio of measured / estimated above 1 is a constant to raise in mirl.experiments.cost.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import time


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scenarios", nargs="+")
    ap.add_argument("--obs-steps", type=int, default=300)
    args = ap.parse_args()
    from mirl.experiments.cost import estimate_cost
    from mirl.world.scenario import load_scenario

    print(f"{'scenario':<28}{'states':>9}{'est MB':>9}{'RSS MB':>9}{'ratio':>7}"
          f"{'est s':>8}{'CPU s':>8}{'wall s':>8}{'ratio':>7}")  # fmt: skip
    for path in args.scenarios:
        est = estimate_cost(load_scenario(path), "run", steps=args.obs_steps)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        cmd = [sys.executable, "-m", "mirl", "run", "--scenario", path]
        cmd += ["--obs-steps", str(args.obs_steps), "--max-memory", "1T"]
        subprocess.run(cmd, check=True, capture_output=True)
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
        rss = after.ru_maxrss * 1024  # the largest child so far: run the maps smallest first
        print(
            f"{path[-28:]:<28}{est.states:>9,}{est.memory / 2**20:>9.0f}{rss / 2**20:>9.0f}"
            f"{rss / est.memory:>7.2f}{est.seconds:>8.1f}{cpu:>8.1f}{wall:>8.1f}"
            f"{cpu / est.seconds:>7.2f}"
        )


if __name__ == "__main__":
    main()
