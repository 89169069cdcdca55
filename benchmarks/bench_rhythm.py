"""Smooth tracks of physical robots: the decision rhythm at the step the auto step chooses, and
the verdicts learned from them.

    python benchmarks/bench_rhythm.py [--seeds 1-3] [--steps 450] [--work DIR]
                                      [--noise SIGMA_M SIGMA_DEG]

Each team is simulated in the physical world at full view with ``mirl simulate --world physics
--poses P.csv``, and its true poses at the control rate (``P.true.csv``, the observer L's own
rows left out) are learned with ``mirl learn --json --observability 1``, as a user would read a
motion-capture or odometry track. Per robot it prints the step chosen, the robot's rhythm
strength there (:func:`mirl.observations.discretise.rhythm_strength`; the rhythm is shown above
:data:`~mirl.observations.discretise.RHYTHM_FACTOR`), the verdict, its confidence and whether it
is false (names no damaged part; a motor at 0.7 or below is damaged, as the physical world's
calibration has it) at 0.9 or more. Teams: healthy, one motor at 0.6, both robots' motors at
0.5, 0.6, 0.7 and 0.8 on boyd2-healthy; healthy and two motors at 0.5 on boydright; healthy and
three motors at 0.6 on boydright-3; healthy and four motors at 0.6 on the office (first seed
only). ``--noise`` adds a tracker's Gaussian noise (metres per axis, degrees of yaw, seeded by
the run) to the true poses before they are learned. Simulations are kept in ``--work``
(default ``/tmp/mirl-rhythm``).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from pathlib import Path

import numpy as np

from mirl.cli import main as mirl
from mirl.observations.discretise import RHYTHM_FACTOR, rhythm_strength
from mirl.observations.poses import PoseTracks, read_pose_csv, write_pose_csv
from mirl.world.scenario import load_scenario

DAMAGED_AT = 0.7
CONFIDENT = 0.9

TEAMS = {
    "boyd2-healthy": {
        "healthy": {},
        "one at 0.6": {"I": ("right_wheel", 0.6)},
        "both at 0.5": {"I": ("right_wheel", 0.5), "J": ("left_wheel", 0.5)},
        "both at 0.6": {"I": ("right_wheel", 0.6), "J": ("left_wheel", 0.6)},
        "both at 0.7": {"I": ("left_wheel", 0.7), "J": ("right_wheel", 0.7)},
        "both at 0.8": {"I": ("right_wheel", 0.8), "J": ("left_wheel", 0.8)},
    },
    "boydright": {
        "healthy": {},
        "both at 0.5": {"I": ("left_wheel", 0.5), "J": ("right_wheel", 0.5)},
    },
    "boydright-3": {
        "healthy": {},
        "all at 0.6": {"I": ("left_wheel", 0.6), "J": ("right_wheel", 0.6),
                       "K": ("left_wheel", 0.6)},
    },
    "office": {
        "healthy": {},
        "all at 0.6": {"I": ("left_wheel", 0.6), "J": ("right_wheel", 0.6),
                       "K": ("left_wheel", 0.6), "M": ("right_wheel", 0.6)},
    },
}


def quiet(argv: list[str]) -> str:
    """``mirl ARGV``'s standard output (its warnings left out)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = mirl(argv)
    if code:
        raise SystemExit(f"mirl {' '.join(argv)} exited with {code}")
    return out.getvalue()


def track(work: Path, scenario: str, damage: dict, seed: int, steps: int) -> Path:
    """The team's true poses without L's, simulated once into ``work``."""
    name = f"{scenario}-{'-'.join(f'{r}{p[0][0]}{p[1]}' for r, p in damage.items()) or 'ok'}-{seed}"
    out = work / f"{name}.csv"
    if not out.exists():
        flags = [f for r, (part, s) in damage.items() for f in ("--damage", f"{r}:{part}={s}")]
        quiet(["simulate", "--scenario", scenario, "--world", "physics", "--steps", str(steps),
               "--seed", str(seed), "--observability", "1", "--poses", str(work / f"{name}.p.csv"),
               *flags])
        tracks = read_pose_csv(work / f"{name}.p.true.csv")  # L's own rows left out
        names = load_scenario(scenario).robot_names
        index = np.array([names.index(n) if n in names else -1 for n in tracks.robot_names])
        sel = tracks.select(index[tracks.robot] >= 0)
        write_pose_csv(
            PoseTracks(names, sel.t, index[sel.robot], sel.x, sel.y, sel.yaw, sel.source), out
        )
    return out


def noisy(path: Path, sigma_m: float, sigma_deg: float, seed: int) -> Path:
    """A copy of the track at ``path`` with a tracker's Gaussian noise."""
    if not sigma_m and not sigma_deg:
        return path
    out = path.with_name(f"{path.stem}.noise-{sigma_m:g}-{sigma_deg:g}.csv")
    if not out.exists():
        tr = read_pose_csv(path)
        rng = np.random.default_rng(seed)
        n = len(tr.t)
        write_pose_csv(
            PoseTracks(tr.robot_names, tr.t, tr.robot, tr.x + rng.normal(0, sigma_m, n),
                       tr.y + rng.normal(0, sigma_m, n),
                       tr.yaw + np.deg2rad(rng.normal(0, sigma_deg, n)), tr.source),
            out,
        )  # fmt: skip
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1-3", help="first-last")
    ap.add_argument("--steps", type=int, default=450)
    ap.add_argument("--work", default="/tmp/mirl-rhythm")
    ap.add_argument("--noise", nargs=2, type=float, default=(0.0, 0.0),
                    metavar=("SIGMA_M", "SIGMA_DEG"))
    args = ap.parse_args()
    lo, hi = (int(x) for x in args.seeds.split("-"))
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    confident_false = verdicts = 0
    print("scenario | team | seed | step (s) | robot | rhythm strength | verdict | confidence "
          "| false")
    for scenario, teams in TEAMS.items():
        sc = load_scenario(scenario)
        for team, damage in teams.items():
            for seed in range(lo, hi + 1 if scenario != "office" else lo + 1):
                path = noisy(track(work, scenario, damage, seed, args.steps), *args.noise, seed)
                out = json.loads(quiet(["learn", "--scenario", scenario, "--observations",
                                        str(path), "--observability", "1", "--json"]))
                step = float(out["step_seconds"])
                poses = read_pose_csv(path)
                rf, cf = sc.map.frame.cell_coordinates(poses.x, poses.y)
                for r, robot in out["robots"].items():
                    idx = np.flatnonzero(poses.robot == poses.robot_names.index(r))
                    idx = idx[np.argsort(poses.t[idx], kind="stable")]
                    strength = rhythm_strength(poses.t[idx], rf[idx], cf[idx], poses.yaw[idx], step)
                    v = robot["verdict"]
                    named = set([v["part"]] if v["part"] else v["candidates"])
                    part, strength_true = damage.get(r, (None, 1.0))
                    truly = {part} if strength_true <= DAMAGED_AT else set()
                    false = (not truly and bool(named)) or (truly and not (named & truly))
                    verdicts += 1
                    confident_false += bool(false and v["confidence"] >= CONFIDENT)
                    said = v["part"] or ", ".join(v["candidates"]) or "no part"
                    print(f"{scenario} | {team} | {seed} | {step:g} | {r} | {strength:.2f}"
                          f"{' (shown)' if strength > RHYTHM_FACTOR else ''} | {said} | "
                          f"{v['confidence']:.2f} | {'yes' if false else 'no'}")
    print(f"\n{verdicts} verdicts, {confident_false} confidently false")


if __name__ == "__main__":
    main()
