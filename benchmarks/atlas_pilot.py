"""A pilot of the calibration atlas: its first design points, through the sweep that runs it.

    python benchmarks/atlas_pilot.py --points 30 --workers 2 --out results/atlas-pilot

The atlas's design is shuffled, so its first points are a random sample of it. The pilot
stores them as ``mirl experiment atlas`` does (the same experiment, base seed 0) and writes
``DIR/report.md``; ``mirl experiment atlas --resume --out DIR`` later runs the remaining points
without repeating these, and ``--resume`` here extends an interrupted pilot.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from mirl.experiments.conditions import get_experiment
from mirl.experiments.sweep import run_experiment
from mirl.viz.report import write_report


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=30, help="design points to run (default 30)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="results/atlas-pilot")
    ap.add_argument("--resume", action="store_true")
    args = ap.parse_args()
    atlas = get_experiment("atlas")
    if not 1 <= args.points <= len(atlas.conditions):
        ap.error(f"--points: between 1 and {len(atlas.conditions)}, got {args.points}")
    pilot = replace(atlas, conditions=atlas.conditions[: args.points])
    run_experiment(pilot, args.out, {"workers": args.workers, "resume": args.resume})
    print(f"wrote {write_report(args.out)}")


if __name__ == "__main__":
    main()
