"""How often robots stay in their cell at their camera's interval: the pace check's crawl.

    python benchmarks/bench_crawl.py [--seeds 11,12,13] [--steps 450]

The physical world's camera records (`mirl simulate --world physics ... --poses`, full view,
random starts), read as `mirl learn` reads them (`--step-seconds auto`, one pose a step at the
camera's 2 s): per robot, its free steps that kept its heading (no other robot L saw in its way,
`mirl.learning.verdicts.free_pace`) and how many of them stayed in its cell. The pace check
(`mirl.learning.model_check.no_pace_setter`) fails a record in which no robot seen on 20 such
steps or more is seen to cross a cell on most of them (its stays below half beyond chance,
`mirl.learning.model_check.sets_the_pace`); the last column says whether it does. Healthy teams,
one robot damaged, and teams all damaged; with ``--bag``, the real Gazebo bag of
`tests/data/real/tb3-gazebo-nav` too.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from mirl.learning.model_check import CRAWL_SHARE, no_pace_setter
from mirl.learning.verdicts import free_pace
from mirl.observations.sources import load_observations
from mirl.world.scenario import load_scenario

CASES = (
    ("boyd2-healthy", ()),
    ("boyd2-healthy", ("J:left_wheel=0.5",)),
    ("boyd2-healthy", ("J:left_wheel=0.6",)),
    ("boyd2-healthy", ("I:right_wheel=0.6",)),
    ("boyd2-healthy", ("J:left_wheel=0.5", "J:right_wheel=0.5")),
    ("boyd2-healthy", ("I:right_wheel=0.5", "J:left_wheel=0.5")),
    ("boyd2-healthy", ("I:right_wheel=0.6", "J:left_wheel=0.6")),
    ("boydright", ()),
    ("boydright", ("J:right_wheel=0.5",)),
    ("boydright-3", ()),
    ("boydright-3", ("I:left_wheel=0.5", "J:left_wheel=0.5")),
)
BAG = Path(__file__).resolve().parents[1] / "tests" / "data" / "real" / "tb3-gazebo-nav"


def shares(path: Path, scenario, **read) -> tuple[str, str, str]:
    """The step chosen, each robot's stays / free steps that kept its heading, and whether the
    pace check's crawl fails the record at that step."""
    loaded = load_observations(path, scenario, **read)
    traj, domain = loaded.trajectories, scenario.domain
    series = [traj.state_series(domain, i) for i in range(len(traj.robot_names))]
    parts, steps = [], {}
    for i, name in enumerate(traj.robot_names):
        stayed, moved = free_pace(domain, series, i)
        steps[name] = (stayed, moved)
        n = stayed + moved
        parts.append(f"{name} {stayed}/{n} ({stayed / n:.2f})" if n else f"{name} -")
    auto = loaded.discretised.auto_step if loaded.discretised else None
    step = f"{auto.seconds:g} s ({auto.why})" if auto else "given"
    crawl = "fails" if no_pace_setter(steps, auto.seconds if auto else 1.0) else "passes"
    return step, ", ".join(parts), crawl


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="11,12,13")
    ap.add_argument("--steps", type=int, default=450)
    ap.add_argument("--bag", action="store_true")
    args = ap.parse_args()
    print(f"crawl: no robot's stays below {CRAWL_SHARE:.0%} of its free steps beyond chance")
    print("| scenario | damage | seed | step | stayed / free steps | crawl check |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, damage in CASES:
        scenario = load_scenario(name)
        for seed in args.seeds.split(","):
            with tempfile.TemporaryDirectory() as tmp:
                flags = [f for d in damage for f in ("--damage", d)]
                subprocess.run(
                    [sys.executable, "-m", "mirl", "simulate", "--scenario", name, "--world",
                     "physics", *flags, "--steps", str(args.steps), "--seed", seed,
                     "--observability", "1", "--random-starts", "--poses", "poses.csv"],
                    cwd=tmp, check=True, capture_output=True,
                )  # fmt: skip
                step, got, crawl = shares(Path(tmp) / "poses.csv", scenario, start_time=0.0)
            print(f"| {name} | {', '.join(damage) or 'none'} | {seed} | {step} | {got} | {crawl} |",
                  flush=True)  # fmt: skip
    if args.bag:
        step, got, crawl = shares(
            BAG / "location.bag", load_scenario(BAG / "world.toml"),
            topics={"/tb_a/location": "I", "/tb_b/location": "J"},
        )  # fmt: skip
        print(f"| the Gazebo bag | none | – | {step} | {got} | {crawl} |")


if __name__ == "__main__":
    main()
