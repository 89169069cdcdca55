"""The fault verdicts on short records: what the "few steps" check changes.

    python benchmarks/bench_short_records.py [--seeds 100-249] [--healthy-seeds 100-399]
        [--work DIR] [--out FILE.jsonl]

At L's door on the grid (boyd2-healthy, 450 steps, view 0.14) J is seen on few steps, and fewer
when a wheel is damaged. Runs with J's left wheel at 0.7 and with its right wheel at 0.7 on
``--seeds``, and healthy runs on ``--healthy-seeds``, each simulated with ``mirl simulate`` and
learned with ``mirl learn --json`` (in this process, as ``bench_verdict_cases.py`` does), and
learned again with the check switched off (``check_record_length``'s minimum at 0). Per
robot: the steps L saw it on at both ends, the verdict and its confidence, whether it is false
(it names no damaged part). Printed: J's damaged share and its verdicts by record length, and
per robot the expected calibration error (ten bins of the stated confidence) and the
confidently false statements (≥ 0.9), with and without the check.
"""

from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

import numpy as np
from bench_verdict_cases import Case, false_statement, learned, seeds_of, simulated

import mirl.learning.verdicts as verdicts
from mirl.learning.model_check import check_record_length
from mirl.observations.trajectories import read_csv
from mirl.world.scenario import load_scenario

SCENARIO = "boyd2-healthy"
CASES = {
    "J left wheel 0.7": Case("door-j-left", SCENARIO, "grid", ("J:left_wheel=0.7",),
                             {"I": (), "J": ("left_wheel",)}, "grid", 0.14),
    "J right wheel 0.7": Case("door-j-right", SCENARIO, "grid", ("J:right_wheel=0.7",),
                              {"I": (), "J": ("right_wheel",)}, "grid", 0.14),
    "healthy": Case("door-healthy", SCENARIO, "grid", (), {"I": (), "J": ()}, "grid", 0.14),
}  # fmt: skip
BINS = ((0, 20), (20, 40), (40, 10**9))


def steps_seen(path: Path, robot: str) -> int:
    """Steps at which L saw ``robot`` and saw it again at the next."""
    scenario = load_scenario(SCENARIO)
    obs = read_csv(path, scenario.domain, scenario.robot_names)
    x = obs.state_series(scenario.domain, scenario.robot_names.index(robot))
    return int(((x[:-1] >= 0) & (x[1:] >= 0)).sum())


def verdict_rows(case: Case, seed: int, work: Path, checked: bool) -> list[dict]:
    data = simulated(case, seed, work)
    if checked:
        out = learned(case, data)
    else:
        original = verdicts.check_record_length
        verdicts.check_record_length = lambda n: check_record_length(n, min_steps=0)
        try:
            out = learned(case, data)
        finally:
            verdicts.check_record_length = original
    rows = []
    for robot, truth in case.truth.items():
        v = out["robots"][robot]["verdict"]
        if v.get("seen_moving") is False:
            continue
        rows.append(dict(case=case.name, seed=seed, robot=robot, checked=checked,
                         damaged=bool(truth), steps=steps_seen(data, robot),
                         none=v["part"] is None and not v["candidates"],
                         confidence=v["confidence"], false=false_statement(v, truth)))  # fmt: skip
    return rows


def ece(rows: list[dict]) -> float:
    c = np.array([r["confidence"] for r in rows])
    right = np.array([not r["false"] for r in rows])
    bins = np.minimum((c * 10).astype(int), 9)
    return float(sum((bins == b).mean() * abs(c[bins == b].mean() - right[bins == b].mean())
                     for b in range(10) if (bins == b).any()))  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="100-249", help="damaged runs, e.g. 100-249")
    ap.add_argument("--healthy-seeds", default="100-399")
    ap.add_argument("--work", type=Path, default=Path("/tmp/mirl-short-records"))
    ap.add_argument("--out", type=Path, help="also write every robot's row (JSON lines)")
    args = ap.parse_args()
    rows: list[dict] = []
    for label, case in CASES.items():
        seeds = seeds_of(args.healthy_seeds if label == "healthy" else args.seeds)
        for seed in seeds:
            for checked in (False, True):
                rows += verdict_rows(case, seed, args.work, checked)
        print(f"done {label} ({len(seeds)} seeds)", flush=True)
    if args.out:
        args.out.write_text("".join(json.dumps(r) + "\n" for r in rows))
    j = [r for r in rows if r["robot"] == "J" and not r["checked"]]
    print("\nJ's records by steps seen at both ends (without the check):")
    print("| steps | records | damaged | 'no part' ≥ 0.9 | of which false | mean confidence |")
    print("| --- | --- | --- | --- | --- | --- |")
    for lo, hi in BINS:
        b = [r for r in j if lo <= r["steps"] < hi]
        if not b:
            continue
        sure = [r for r in b if r["none"] and r["confidence"] >= 0.9]
        mean = np.mean([r["confidence"] for r in sure]) if sure else float("nan")
        span = f"{lo}–{hi - 1}" if hi < 10**9 else f"≥ {lo}"
        print(f"| {span} | {len(b)} | {np.mean([r['damaged'] for r in b]):.2f} | {len(sure)} "
              f"| {sum(r['false'] for r in sure)} | {mean:.3f} |")  # fmt: skip
    print("\n| robot | check | verdicts | confident (≥ 0.9) | confidently false | ECE |")
    print("| --- | --- | --- | --- | --- | --- |")
    by = collections.defaultdict(list)
    for r in rows:
        by[(r["robot"], r["checked"])].append(r)
    for (robot, checked), rs in sorted(by.items()):
        sure = [r for r in rs if r["confidence"] >= 0.9]
        print(f"| {robot} | {'with' if checked else 'without'} | {len(rs)} | {len(sure)} "
              f"| {sum(r['false'] for r in sure)} | {ece(rs):.3f} |")  # fmt: skip


if __name__ == "__main__":
    main()
