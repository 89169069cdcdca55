"""How often the model check fails: on records that fit L's motion models (false alarms) and on
records that do not (detections).

    python benchmarks/bench_model_check.py [--seeds 10] [--steps 150 450 900] [--quick]

Records that fit: the grid world's, which runs the paper's ξ with Eq. 5 — every shipped scenario
with two or three patrollers, at L's door (0.14) and full view, each length, seeds 0…N−1 with
random starts — read as grid states and as noisy poses (5 cm / 3°, 10 Hz, through the pose
discretisation). Records that do not: the same grid records read at twice and three times the
step (every 2nd or 3rd state kept: moves that span two cells, turns and moves in one step). Per
robot seen moving, each check of :mod:`mirl.learning.model_check` is counted as failed or not;
the table gives the share of robots whose record failed each check and any check, and the share
L learned under another motion model than the scenario's (the column "scenario's model kept").
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict

import numpy as np

from mirl.learning.learn import learn
from mirl.observations.discretise import discretise, poses_from_trajectories
from mirl.observations.trajectories import Trajectories
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario

SCENARIOS = ("boyd2", "boyd2-healthy", "boydright", "boydright-3")


def every(observations: Trajectories, k: int) -> Trajectories:
    """The record read at ``k`` times its step: every k-th state kept."""
    keep = observations.t % k == 0
    tr = observations
    lateral = None if tr.lateral is None else tr.lateral[keep]
    return Trajectories(
        tr.robot_names, tr.t[keep] // k, tr.robot[keep], tr.row[keep], tr.col[keep],
        tr.heading[keep], (tr.horizon + k - 1) // k, lateral,
    )  # fmt: skip


def noisy(observations: Trajectories, scenario, seed: int) -> Trajectories:
    """The record as a 10 Hz tracker with 5 cm / 3° noise reports it, discretised again."""
    tracks = poses_from_trajectories(
        observations, scenario, sigma_xy=0.05, sigma_yaw_degrees=3.0, seed=seed
    )
    return discretise(tracks, scenario, n_steps=observations.horizon, start_time=0.0).trajectories


def checks_of(observations: Trajectories, scenario, degree: float) -> list[dict[str, bool]]:
    """Per robot seen moving, each check's outcome, and whether L learned it under another
    motion model than the scenario's (``"learned under another model"``: False is ok)."""
    res = learn(observations, scenario, "mirl-t", observability=degree, score=False)
    out = []
    for r in res.robots:
        fit = r.verdict.fit if r.verdict is not None else None
        if fit is None or not r.verdict.seen_moving:
            continue
        checks = {c.name: c.ok for c in fit.checks}
        checks["scenario's model kept"] = r.motion_model == "paper/uniform"
        out.append(checks)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--steps", type=int, nargs="*", default=[150, 450, 900])
    ap.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    args = ap.parse_args()
    failed: dict[str, Counter] = defaultdict(Counter)
    robots: Counter = Counter()
    for name in args.scenarios:
        scenario = load_scenario(name)
        for steps in args.steps:
            for degree in (0.14, 1.0):
                for seed in range(args.seeds):
                    sim = simulate(scenario, steps, seed=seed, observability=degree,
                                   random_starts=True)  # fmt: skip
                    obs = sim.observations
                    records = {
                        "grid states": obs,
                        "noisy poses": noisy(obs, scenario, seed),
                        "every 2nd step": every(obs, 2),
                        "every 3rd step": every(obs, 3),
                    }
                    for kind, record in records.items():
                        for checks in checks_of(record, scenario, degree):
                            robots[kind] += 1
                            for check, ok in checks.items():
                                failed[kind][check] += not ok
                            kept = checks.pop("scenario's model kept")
                            failed[kind]["any"] += not all(checks.values())
                            checks["scenario's model kept"] = kept
        print(f"done {name}", flush=True)
    names = sorted({c for f in failed.values() for c in f} - {"any"}) + ["any"]
    print("| record | robots | " + " | ".join(names) + " |")
    print("| --- | --- |" + " --- |" * len(names))
    for kind, n in robots.items():
        cells = " | ".join(f"{failed[kind][c] / n:.3f}" for c in names)
        print(f"| {kind} | {n} | {cells} |")
    np.set_printoptions(precision=3)


if __name__ == "__main__":
    main()
