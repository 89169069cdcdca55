"""What `mirl run` itself answers, seed after seed: its stated chance against the outcome, and its
fault verdicts against the truth, under its own protocol (L watches until it has seen every
patroller on 40 steps, re-learns while it waits, goes by the adaptive rule).

    python benchmarks/bench_run_protocol.py --seeds 0 200 --out runs.jsonl           # boyd2, grid
    python benchmarks/bench_run_protocol.py --method known-r-t --seeds 0 200 --out k.jsonl
    python benchmarks/bench_run_protocol.py --world physics --scenario boyd2-healthy \\
        --damage I:left_wheel=0.6 --seeds 0 13 --out phys.jsonl

Run s is ``mirl run --scenario S --method M --world W [--damage D] --seed s`` (the command
line's seeds, not the sweeps' ``run_seed``), one process, one BLAS thread. Each finished run is
a line of ``--out``; a second call with the same file skips the seeds it holds (an interrupted
measurement resumes). Prints the outcomes, the mean stated chance of the runs where L went
against their realised success (± one standard error) per decile, and, for a method with
verdicts, each robot's verdicts against the world's truth: how many name a damaged part alone
or among candidates, how many say no part, how many confidently name damage that is not there
(``VerdictItem.confident_wrong``, the verdict sweep's measure) and how many confidently say "no
part" of a damaged robot, and the expected calibration error (``mirl.viz.verdicts``).
"""

from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from mirl.cli.flags import parse_damage  # noqa: E402
from mirl.experiments.episode import run_episode  # noqa: E402
from mirl.viz.verdicts import VerdictItem, expected_calibration_error  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from mirl.worlds import WORLDS  # noqa: E402


def _run(scenario, args, seed: int, truth) -> dict:
    # the protocol: `mirl run`'s, run_episode's default
    result = run_episode(
        scenario, args.method, observability=args.observability, seed=seed, world=args.world
    )
    d = result.to_dict()
    verdicts = {}
    if result.learned is not None:
        for r in result.learned.robots:
            if r.verdict is not None:
                verdicts[r.name] = {
                    "named": list(r.verdict.named),
                    "part": r.verdict.part,
                    "confidence": float(r.verdict.confidence),
                    "right": bool(r.verdict.is_right(truth[r.name])),
                    "truth": list(truth[r.name]),
                }
    return {
        "seed": seed, "outcome": d["outcome"], "stated": d["predicted_success"],
        "obs_steps": d["obs_steps"], "seen": d["seen_steps"],
        "relearns": len(d.get("relearns") or []), "verdicts": verdicts, "cpu": d["timings"]["cpu"],
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--method", default="mirl-t")
    ap.add_argument("--world", default="grid")
    ap.add_argument("--damage", default=None, help="ROBOT:FEATURE=VALUE, as `mirl run --damage`")
    ap.add_argument("--observability", type=float, default=None)
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 20), metavar=("FIRST", "END"))
    ap.add_argument("--out", required=True, help="JSON-lines file of the runs (resumable)")
    args = ap.parse_args()
    world = WORLDS[args.world].load()
    scenario = load_scenario(args.scenario)
    if args.damage:
        robot, feature, value = parse_damage(args.damage)
        scenario = world.apply_damage(scenario, robot, feature, value)
    truth = world.damaged_parts(scenario)
    done = set()
    if os.path.exists(args.out):
        with open(args.out) as f:
            done = {json.loads(line)["seed"] for line in f}
    with open(args.out, "a") as f:
        for seed in range(*args.seeds):
            if seed not in done:
                f.write(json.dumps(_run(scenario, args, seed, truth)) + "\n")
                f.flush()
    with open(args.out) as f:
        rows = [r for r in map(json.loads, f) if args.seeds[0] <= r["seed"] < args.seeds[1]]
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    print(f"{len(rows)} runs of `mirl run --scenario {args.scenario} --method {args.method} "
          f"--world {args.world}{' --damage ' + args.damage if args.damage else ''}`, seeds "
          f"{args.seeds[0]}–{args.seeds[1] - 1}: {outcomes}; re-learned in "
          f"{sum(r['relearns'] > 0 for r in rows)}")  # fmt: skip
    went = [r for r in rows if r["stated"] is not None]
    if went:
        stated = np.array([r["stated"] for r in went])
        ok = np.array([r["outcome"] == "success" for r in went], dtype=float)
        se = ok.std() / np.sqrt(len(ok))
        gap = stated.mean() - ok.mean()
        print(f"\nstated chance {stated.mean():.3f} against realised {ok.mean():.3f} ± {se:.3f} "
              f"({gap:+.3f}) over the {len(went)} runs where L went")  # fmt: skip
        print("\n| stated | runs | mean stated | realised |\n| --- | --- | --- | --- |")
        for lo in np.arange(0.0, 1.0, 0.1):
            m = (stated >= lo) & ((stated < lo + 0.1) if lo < 0.85 else (stated <= 1.0))
            if m.any():
                print(f"| {lo:.1f}–{lo + 0.1:.1f} | {m.sum()} | {stated[m].mean():.3f} | "
                      f"{ok[m].mean():.3f} |")  # fmt: skip
    items = [
        VerdictItem(
            args.world, args.observability or 0.0, args.damage, name, r["seed"],
            tuple(v["named"]), v["confidence"], tuple(v["truth"]), v["right"],
        )
        for r in rows
        for name, v in r["verdicts"].items()
    ]  # fmt: skip
    if items:
        print("\n| robot | truth | the part alone | among candidates | no part | another part "
              "| confident and wrong | confident 'no part' on a damaged robot |\n"
              "| --- | --- | --- | --- | --- | --- | --- | --- |")  # fmt: skip
        for name in sorted({i.robot for i in items}):
            mine = [i for i in items if i.robot == name]
            truth_parts = mine[0].truth
            alone = sum(len(i.verdict) == 1 and i.right and bool(i.truth) for i in mine)
            among = sum(len(i.verdict) > 1 and i.right for i in mine)
            none = sum(not i.verdict for i in mine)
            other = len(mine) - alone - among - none
            wrong = sum(i.confident_wrong for i in mine)
            missed = sum(not i.verdict and bool(i.truth) and i.confidence >= 0.9 for i in mine)
            print(f"| {name} | {', '.join(truth_parts) or 'healthy'} | {alone} | {among} | "
                  f"{none} | {other} | {wrong} | {missed} |")  # fmt: skip
        wrong = sum(i.confident_wrong for i in items)
        print(f"\n{len(items)} verdicts: ECE {expected_calibration_error(items):.3f}; confident "
              f"(≥ 0.9) and naming damage that is not there: {wrong}")  # fmt: skip


if __name__ == "__main__":
    main()
