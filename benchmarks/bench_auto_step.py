"""The step `--step-seconds auto` chooses, on tracks whose pace is known.

    python benchmarks/bench_auto_step.py [--seeds 4] [--physics DIR]

Grid records of boyd2, boydright and the office (300 steps; 600 on the office), at L's door and
full view, written as 10 Hz poses at 2 s steps (mirl's simulated poses: a robot that moves in
jumps) without noise, with 5 cm / 3° and with 30 cm / 20°; and, with ``--physics DIR`` (the
directories ``benchmarks/bench_verdict_cases.py`` writes), the physical world's tracks: L's
camera (one pose a step, 2 s) and the patrollers' true poses at 10 Hz (moving smoothly). Prints
each step chosen and why.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

from mirl.observations.discretise import auto_step_seconds, poses_from_trajectories
from mirl.observations.poses import PoseTracks, read_pose_csv
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--physics", type=Path, default=None)
    args = ap.parse_args()
    noises = {"none": (0.0, 0.0), "5 cm / 3°": (0.05, 3.0), "30 cm / 20°": (0.3, 20.0)}
    print("| track | noise | steps chosen (count) |")
    print("| --- | --- | --- |")
    for name in ("boyd2", "boydright", "office"):
        scenario = load_scenario(name)
        for label, (xy, yaw) in noises.items():
            chosen: Counter = Counter()
            for degree in (0.14, 1.0):
                for seed in range(args.seeds):
                    steps = 600 if name == "office" else 300
                    sim = simulate(scenario, steps, seed=seed, observability=degree,
                                   random_starts=True)  # fmt: skip
                    obs = sim.observations
                    tracks = poses_from_trajectories(
                        obs, scenario, sigma_xy=xy, sigma_yaw_degrees=yaw, seed=seed
                    )
                    auto = auto_step_seconds(tracks, scenario)
                    chosen[f"{auto.seconds:g} s ({auto.why})"] += 1
            print(f"| {name}, simulated poses | {label} | {dict(chosen)} |", flush=True)
    if args.physics is None:
        return
    for kind, pattern in (("L's camera", "*/poses.csv"), ("true, 10 Hz", "*/poses.true.csv")):
        chosen = Counter()
        for path in sorted(args.physics.glob(pattern)):
            scenario = load_scenario(path.parent.name.split("-physics")[0])
            tracks = read_pose_csv(path)
            names = scenario.robot_names
            keep = [i for i, n in enumerate(tracks.robot_names) if n in names]
            mask = sum((tracks.robot == i) for i in keep).astype(bool)
            sel = tracks.select(mask)
            index = {i: names.index(tracks.robot_names[i]) for i in keep}
            robots = PoseTracks(names, sel.t, [index[i] for i in sel.robot], sel.x, sel.y,
                                sel.yaw, sel.source)  # fmt: skip
            auto = auto_step_seconds(robots, scenario)
            chosen[f"{auto.seconds:g} s ({auto.why})"] += 1
        print(f"| physical world, {kind} | — | {dict(chosen)} |")


if __name__ == "__main__":
    main()
