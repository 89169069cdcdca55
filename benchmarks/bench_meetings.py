"""Head-on meetings in the physical world: how often two patrollers pass each other untouched.

    python benchmarks/bench_meetings.py [--seeds 300] [--set lane_offset=0.2 ...]

Two healthy patrollers of boyd2-healthy drive at each other along the long hallway for ten
decision steps (:func:`mirl.physics.calibration.head_on_meeting`), on seeds 0 … N − 1. A meeting
passes when they get past each other without a robot-robot contact. Prints the passes, the
meetings that touched and those that did not get past, the wall contact events, and a 95 %
Wilson interval of the pass rate; ``--set FIELD=VALUE`` changes a ``[physics]`` field (the lane
offset kept while passing, ``keep_right_within``, ...). The outcome of one seed differs between
CPUs and MuJoCo releases (the simulation is chaotic); the rate is what the tests and the docs
state (tests/physics/test_patrol.py, docs/results.md, "Keeping right").
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import mujoco
from scipy.stats import binomtest

from mirl.physics.calibration import head_on_meeting
from mirl.physics.config import scenario_physics
from mirl.world.scenario import load_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=300)
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    args = ap.parse_args()
    scenario = load_scenario("boyd2-healthy")
    config = scenario_physics(scenario)
    for item in args.set:
        key, value = item.split("=", 1)
        config = replace(config, **{key: float(value)})
    meetings = [head_on_meeting(scenario, s, config=config) for s in range(args.seeds)]
    passed = sum(m.passed for m in meetings)
    touched = [s for s, m in enumerate(meetings) if m.contacts]
    stuck = [s for s, m in enumerate(meetings) if not m.got_past]
    n = len(meetings)
    ci = binomtest(passed, n).proportion_ci(method="wilson")
    print(f"MuJoCo {mujoco.__version__}; {' '.join(args.set) or 'the default [physics]'}")
    print(f"passed {passed} of {n} ({passed / n:.3f}, 95 % {ci.low:.3f}–{ci.high:.3f})")
    print(f"touched: {len(touched)} (seeds {touched}); not past: {len(stuck)} (seeds {stuck})")
    print(f"wall contact events: {sum(m.wall_contacts for m in meetings)}")


if __name__ == "__main__":
    main()
