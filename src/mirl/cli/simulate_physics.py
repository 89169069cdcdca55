"""``mirl simulate --world physics``: the patrollers in MuJoCo, L's camera at its door."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

__all__ = ["simulate_physics", "true_path"]


def true_path(out: Path) -> Path:
    """Where ``--poses OUT`` puts the true tracks: ``OUT`` with ``.true`` before the suffix."""
    return out.with_name(out.stem + ".true" + out.suffix) if out.suffix else Path(f"{out}.true")


def simulate_physics(args: argparse.Namespace, scenario) -> int:
    from mirl.physics.patrol import PhysicalWorld

    start, cpu = time.perf_counter(), time.process_time()
    world = PhysicalWorld(
        scenario, observability=args.observability, seed=args.seed,
        random_starts=args.random_starts,
    )  # fmt: skip
    for _ in range(args.steps - 1):
        world.step()
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    sim_seconds = (args.steps - 1) * world.cfg.step_seconds
    seen = np.asarray(world.seen)
    degree = world.degree
    strengths = [
        f"{r}:{w}={s:g}" for r, ws in world.cfg.motor_strength.items() for w, s in ws.items()
    ]
    print(
        f"scenario {scenario.name} (physics: {', '.join(strengths) or 'all motors healthy'}): "
        f"{args.steps} steps ({sim_seconds / 60:.1f} min), seed {args.seed}, observability "
        f"{degree:g} ({int(scenario.map.visible_mask(degree).sum())}"
        f"/{scenario.map.n_patroller_cells} cells)"
    )
    for i, name in enumerate(scenario.robot_names):
        print(f"  {name}: observed {np.mean(seen[:, i] >= 0):.1%} of steps")
    print(f"  contacts: {world.contacts} between robots, {world.wall_contacts} with walls")
    print(
        f"  simulated in {elapsed:.2f} s wall, {cpu:.2f} s CPU "
        f"(real-time factor {sim_seconds / max(cpu, 1e-9):.0f} on CPU time)"
    )
    if args.observations:
        obs = world.observations()
        obs.to_csv(args.observations)
        print(f"wrote {args.observations} ({len(obs)} rows)")
    if args.truth:
        truth = world.truth()
        truth.to_csv(args.truth)
        print(f"wrote {args.truth} ({len(truth)} rows)")
    if args.poses:
        _write_tracks(Path(args.poses), world)
    return 0


def _write_tracks(out: Path, world) -> None:
    from mirl.observations.poses import write_pose_csv

    if out.suffix.lower() == ".csv":  # .csv or .mcap: checked before the simulation
        write = write_pose_csv
    else:
        from mirl.observations.bags import write_mcap as write
    observed, truth = world.observed_tracks(), world.true_tracks()
    write(observed, out)
    write(truth, true_path(out))
    print(
        f"wrote {out} ({len(observed)} poses L's camera measured, one per seen patroller per "
        f"step) and {true_path(out)} ({len(truth)} true poses at {world.cfg.control_hz:g} Hz)"
    )
