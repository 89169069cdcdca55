"""How far a weak motor drifts a robot per unit of wheel gap in the physical world (κ).

    python benchmarks/calibrate_drift.py [--scenario boyd2-healthy] [--seeds 100 101]
        [--strengths 0.5 0.7 0.85] [--steps 450]

The fault verdicts read a robot's side from its lateral drift, offset ~ N(κ (p_right −
p_left), ...) (docs/design.md, "Which side: the lateral drift"). This measures κ in the
physical world, for every robot and either motor at each strength, on seeds and strengths
apart from those the verdicts are evaluated on (0.6, seeds 0-9):

* the drift: L's own statistic (:func:`mirl.learning.verdicts.lateral_drift`) on L's full-view
  camera track of the weak robot, labelled with the actions its controller executed;
* the gap in ξ's terms: a weak wheel alone explains the weak robot's forward deficit, so its
  success probability is h · q_weak / q_healthy (h = 0.95, the healthy level; q the forward
  steps' success rate driving alone, no other robot within the detection distance, the
  healthy q from the other, healthy robot of the same runs), and the gap h − that.

κ = |drift| / gap per condition. Conditions whose gap is below the damage margin (0.15: a motor
that still drives its steps, e.g. at 0.85 strength) say little about κ (a drift of a few
hundredths over a gap near 0) and are printed but left out of the summary: κ's least-squares
fit through the origin over the others, and their mean and relative spread.
"""

from __future__ import annotations

import argparse

import numpy as np

from mirl.learning.verdicts import in_company, lateral_drift
from mirl.physics.config import with_motor_strength
from mirl.physics.patrol import PhysicalWorld
from mirl.world.domain import FORWARD
from mirl.world.scenario import load_scenario

HEALTHY = 0.95
MARGIN = 0.15  # mirl.world.faults.DEFAULT_MARGIN


def measure(scenario, robot: str, wheel: str, strength: float, seed: int, steps: int):
    sc = with_motor_strength(scenario, robot, wheel, strength)
    w = PhysicalWorld(sc, seed=seed, random_starts=True, observability=1.0)
    for _ in range(steps - 1):
        w.step()
    dom = sc.domain
    true = w.records.true_states()
    actions = np.asarray(w.records.actions)
    seen = np.asarray(w.records.seen)
    lateral = np.asarray(w.records.seen_lateral)
    i = sc.robot_index(robot)
    reach = sc.detect_distance
    out = {}
    for j in range(len(sc.robots)):
        company = in_company(dom, [seen[:, k] for k in range(seen.shape[1])], j, reach)
        t = np.flatnonzero((seen[:-1, j] >= 0) & (seen[1:, j] >= 0))
        drift = lateral_drift(dom, t, seen[t, j], actions[t, j], seen[t + 1, j], lateral[:, j],
                              company)  # fmt: skip
        # forward success alone, from the true states and the executed actions
        cells = dom.states[true][:, :, :2]
        others = [k for k in range(len(sc.robots)) if k != j]
        d = np.min([np.hypot(*(cells[:, j] - cells[:, k]).T) for k in others], axis=0)
        alone = (d[:-1] > reach) & (d[1:] > reach)
        fwd = (actions[:, j] == FORWARD) & alone
        ok = dom.intended[true[:-1, j], FORWARD] == true[1:, j]
        out[j] = (drift, ok[fwd].mean(), int(fwd.sum()))
    return i, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="boyd2-healthy")
    ap.add_argument("--seeds", type=int, nargs="+", default=[100, 101])
    ap.add_argument("--strengths", type=float, nargs="+", default=[0.5, 0.7, 0.85])
    ap.add_argument("--steps", type=int, default=450)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    print("| motor | strength | seed | drift (cells) | q weak | q healthy | gap | κ |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    points = []
    for robot in scenario.robot_names:
        for wheel in ("left_wheel", "right_wheel"):
            for s in args.strengths:
                for seed in args.seeds:
                    i, out = measure(scenario, robot, wheel, s, seed, args.steps)
                    drift, q_weak, _ = out[i]
                    q_healthy = np.mean([out[j][1] for j in out if j != i])
                    gap = HEALTHY * (1 - q_weak / q_healthy)
                    mean = np.nan if drift is None else drift.mean
                    kappa = abs(mean) / gap if gap > 0 else np.nan
                    points.append((abs(mean), gap))
                    print(f"| {robot} {wheel} | {s} | {seed} | {mean:+.3f} | {q_weak:.3f} | "
                          f"{q_healthy:.3f} | {gap:.3f} | {kappa:.3f} |", flush=True)  # fmt: skip
    d, g = np.asarray(points).T
    keep = np.isfinite(d) & (g >= MARGIN)
    d, g = d[keep], g[keep]
    k = d / g
    print(
        f"\nκ over the {keep.sum()} conditions with a gap ≥ {MARGIN}: least squares "
        f"{(d @ g) / (g @ g):.3f}, mean {k.mean():.3f}, relative sd "
        f"{k.std(ddof=1) / k.mean():.2f}, range {k.min():.3f}-{k.max():.3f}"
    )


if __name__ == "__main__":
    main()
