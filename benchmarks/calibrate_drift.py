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
  steps' success rate driving alone, no other robot within the detection distance
  (:func:`mirl.physics.calibration.calibrate`'s), the healthy q from the other, healthy robot
  of the same runs), and the gap h − that.

κ = |drift| / gap per condition. Conditions whose gap is below the damage margin (0.15: a motor
that still drives its steps, e.g. at 0.85 strength) say little about κ (a drift of a few
hundredths over a gap near 0) and are printed but left out of the summary: κ's least-squares
fit through the origin over the others, and their mean and relative spread.
"""

from __future__ import annotations

import argparse

import numpy as np

from mirl.learning.verdicts import in_company, lateral_drift
from mirl.physics.calibration import calibrate
from mirl.physics.config import with_motor_strength
from mirl.world.faults import DEFAULT_HEALTHY as HEALTHY
from mirl.world.faults import DEFAULT_MARGIN as MARGIN
from mirl.world.scenario import load_scenario


def measure(scenario, robot: str, wheel: str, strength: float, seed: int, steps: int):
    """One patrol with ``robot``'s ``wheel`` at ``strength``: ``robot``'s index and, per robot,
    (its drift, its forward steps' success rate driving alone, how many such steps)."""
    sc = with_motor_strength(scenario, robot, wheel, strength)
    reach = sc.detect_distance
    cal = calibrate(sc, steps=steps, seeds=[seed], alone=reach, observability=1.0)
    rec = cal.records[0]
    dom = sc.domain
    actions = np.asarray(rec.actions)
    seen = np.asarray(rec.seen)
    lateral = np.asarray(rec.seen_lateral)
    out = {}
    for j in range(len(sc.robots)):
        company = in_company(dom, list(seen.T), j, reach)
        t = np.flatnonzero((seen[:-1, j] >= 0) & (seen[1:, j] >= 0))
        drift = lateral_drift(dom, t, seen[t, j], actions[t, j], seen[t + 1, j], lateral[:, j],
                              company)  # fmt: skip
        out[j] = (drift, *cal.rate(j, "forward", alone=True))
    return sc.robot_index(robot), out


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
