"""What a weaker motor does to a robot's moves in the physical world: the forward steps' success
at each motor strength, against a healthy robot's in the same runs.

    python benchmarks/calibrate_strength.py [--scenario boyd2-healthy] [--seeds 100 101]
        [--strengths 0.5 0.6 0.7 0.75 0.8 0.85 0.9 0.95] [--steps 300]

A wheel is damaged when its success probability lies below its healthy level by more than the
margin (docs/design.md, "Fault verdicts"); in the physical world the truth is a motor strength,
and this says which strengths that is. For each strength, each robot's either motor in turn
(seeds apart from those the verdicts are evaluated on), it counts the forward steps driven alone
(:func:`mirl.physics.calibration.calibrate`'s, no other robot within the detection distance)
and their successes, for the weak robot and for the healthy one beside it; the ratio of the two
success rates is what the weak wheel's success probability is, in ξ's terms, over its healthy
level (forward steps need both wheels; the other wheel, navigation and floor are the healthy
robot's). The table it prints is ``mirl.physics.calibration.FORWARD_SUCCESS_RATIO``.
"""

from __future__ import annotations

import argparse

import numpy as np

from mirl.physics.calibration import calibrate
from mirl.physics.config import with_motor_strength
from mirl.world.faults import DEFAULT_HEALTHY, DEFAULT_MARGIN
from mirl.world.scenario import load_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="boyd2-healthy")
    ap.add_argument("--seeds", type=int, nargs="*", default=[100, 101])
    ap.add_argument("--strengths", type=float, nargs="*",
                    default=[0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95])  # fmt: skip
    ap.add_argument("--steps", type=int, default=300)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    names = scenario.robot_names
    print(f"{args.scenario}, seeds {args.seeds}, {args.steps} steps; forward steps driven alone")
    print("| strength | weak: successes / trials | healthy: successes / trials | ratio | "
          "p = h · ratio | damaged (p < h − margin) |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- |")
    ratios = {}
    for s in args.strengths:
        weak, healthy = np.zeros(2), np.zeros(2)
        for robot in names:
            for wheel in ("left_wheel", "right_wheel"):
                sc = with_motor_strength(scenario, robot, wheel, s)
                cal = calibrate(sc, steps=args.steps, seeds=args.seeds,
                                alone=sc.detect_distance, observability=1.0)  # fmt: skip
                for j, other in enumerate(names):
                    rate, n = cal.rate(j, "forward", alone=True)
                    counts = np.array([rate * n, n]) if n else np.zeros(2)
                    (weak if other == robot else healthy)[:] += counts
        ratio = (weak[0] / weak[1]) / (healthy[0] / healthy[1])
        ratios[s] = ratio
        p = DEFAULT_HEALTHY * ratio
        damaged = "yes" if p < DEFAULT_HEALTHY - DEFAULT_MARGIN else "no"
        print(f"| {s:g} | {weak[0]:.0f} / {weak[1]:.0f} | {healthy[0]:.0f} / {healthy[1]:.0f} | "
              f"{ratio:.3f} | {p:.3f} | {damaged} |", flush=True)  # fmt: skip
    print("FORWARD_SUCCESS_RATIO = {" + ", ".join(f"{s:g}: {r:.3f}" for s, r in ratios.items())
          + "}")  # fmt: skip


if __name__ == "__main__":
    main()
