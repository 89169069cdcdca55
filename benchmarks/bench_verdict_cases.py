"""The fault verdicts on the cases of issue 39, with the README's own commands, a few seeds each.

    python benchmarks/bench_verdict_cases.py [--cases NAME ...] [--seeds 0-9] [--work DIR]

Each case simulates with ``mirl simulate`` (in this process, through :func:`mirl.cli.main`) and
learns with ``mirl learn --json``, as a user would, and scores each robot's verdict against
the truth: a statement is *false* when it names no damaged part (a healthy part, candidates
without a damaged one, or "no part" for a damaged robot), *confidently* false at confidence
≥ 0.9. Simulations are kept in ``--work`` (default ``/tmp/mirl-verdict-cases``), so a second
run only learns. Cases:

=================  ===========================================================================
``physics-right``  physics, boyd2-healthy, I's right motor at 0.6, full view, grid CSV
``physics-poses``  the same runs read from L's pose CSV (``--poses``)
``physics-two``    physics, boyd2 (J's left motor at 0.6) and I's right at 0.6, grid CSV
``boydright``      physics, boydright, J's right motor at 0.5, full view, grid CSV
``long-step``      physics, boyd2-healthy, no damage: the true 10 Hz poses at 3 s steps, so
                   that some moves span two cells (a tracker read at too long a step)
``grid``           grid, boyd2 (J's left wheel at 0.70), L's door (0.14), grid CSV
``physics-left``   ``physics-right`` mirrored: I's left motor at 0.6, grid CSV
``physics-left-poses``  the same runs read from L's pose CSV
``physics-two-mirror``  physics, boyd2-healthy, I's left and J's right motor at 0.6, pose CSV
``grid-right``     grid, boyd2-healthy with I's right wheel at 0.70, L's door (0.14), grid CSV
``boydleft``       ``boydright`` mirrored: J's left motor at 0.5
``three-right``    physics, boydright-3, I's right motor at 0.5, full view, grid CSV
``office-right``   physics, office, K's right motor at 0.5, full view, grid CSV
``two-true-poses``  physics, boyd2-healthy, I's right and J's left motor at 0.6, the true 10 Hz
                   poses at the auto step (a smooth track of a team slowed down alike)
``amcl-healthy``   physics, boyd2-healthy, no damage, the true poses as Nav2's AMCL publishes
                   them (:func:`amcl_stream`: a pose once the robot has moved 0.25 m or turned
                   0.2 rad, with a localisation error), at the auto step
``amcl-healthy-1s``  the same at ``--step-seconds 1``, as the issue's TurtleBot record was read
``amcl-left``      the same stream, I's left motor at 0.6
``amcl-right``     the same stream of ``boydright`` (J's right motor at 0.5)
``amcl-two``       the same stream, I's right and J's left motor at 0.6
``amcl-two-1s``    the same at ``--step-seconds 1``
``edge-right``     physics, boyd2-healthy, I's right motor at 0.74 (damaged by its effect, just
                   below the margin: its forward steps succeed 0.76-0.81, a healthy robot's
                   0.98-1.00), full view, grid CSV
``edge-left-poses``  the same mirrored (I's left motor), from L's pose CSV
``edge-boydright``  physics, boydright, J's right motor at 0.74, full view, grid CSV
=================  ===========================================================================

Per case and robot it prints the verdict, its confidence, whether it is (confidently) false,
the feature probabilities, the fit check and the motion-model weights where the JSON has them;
a record ``mirl learn`` refuses is counted, with the line it printed.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mirl.cli import main as mirl
from mirl.observations.poses import PoseTracks, read_pose_csv, write_pose_csv
from mirl.world.scenario import load_scenario

CONFIDENT = 0.9


@dataclass(frozen=True)
class Case:
    name: str
    scenario: str
    world: str  # "grid" or "physics"
    damage: tuple[str, ...]  # --damage values
    truth: dict[str, tuple[str, ...]]  # robot -> damaged parts
    # "grid" (obs.csv), "poses" (L's pose CSV), "true-poses" (10 Hz true poses), "amcl" (the
    # true poses as AMCL publishes them)
    data: str
    observability: float
    learn_flags: tuple[str, ...] = ()


CASES = {
    c.name: c
    for c in (
        Case("physics-right", "boyd2-healthy", "physics", ("I:right_wheel=0.6",),
             {"I": ("right_wheel",), "J": ()}, "grid", 1.0),
        Case("physics-poses", "boyd2-healthy", "physics", ("I:right_wheel=0.6",),
             {"I": ("right_wheel",), "J": ()}, "poses", 1.0),
        Case("physics-two", "boyd2", "physics", ("I:right_wheel=0.6",),
             {"I": ("right_wheel",), "J": ("left_wheel",)}, "grid", 1.0),
        Case("boydright", "boydright", "physics", ("J:right_wheel=0.5",),
             {"I": (), "J": ("right_wheel",)}, "grid", 1.0),
        Case("long-step", "boyd2-healthy", "physics", (), {"I": (), "J": ()}, "true-poses", 1.0,
             ("--step-seconds", "3")),
        Case("grid", "boyd2", "grid", (), {"I": (), "J": ("left_wheel",)}, "grid", 0.14),
        # the same questions mirrored (the other wheel, the other robot), as a user may ask them
        Case("physics-left", "boyd2-healthy", "physics", ("I:left_wheel=0.6",),
             {"I": ("left_wheel",), "J": ()}, "grid", 1.0),
        Case("physics-left-poses", "boyd2-healthy", "physics", ("I:left_wheel=0.6",),
             {"I": ("left_wheel",), "J": ()}, "poses", 1.0),
        Case("physics-two-mirror", "boyd2-healthy", "physics",
             ("I:left_wheel=0.6", "J:right_wheel=0.6"),
             {"I": ("left_wheel",), "J": ("right_wheel",)}, "poses", 1.0),
        Case("grid-right", "boyd2-healthy", "grid", ("I:right_wheel=0.7",),
             {"I": ("right_wheel",), "J": ()}, "grid", 0.14),
        Case("boydleft", "boydright", "physics", ("J:left_wheel=0.5",),
             {"I": (), "J": ("left_wheel",)}, "grid", 1.0),
        # other maps and teams, the grid CSV of the physical world
        Case("three-right", "boydright-3", "physics", ("I:right_wheel=0.5",),
             {"I": ("right_wheel",), "J": (), "K": ()}, "grid", 1.0),
        Case("office-right", "office", "physics", ("K:right_wheel=0.5",),
             {"I": (), "J": (), "K": ("right_wheel",), "M": ()}, "grid", 1.0),
        Case("two-true-poses", "boyd2-healthy", "physics",
             ("I:right_wheel=0.6", "J:left_wheel=0.6"),
             {"I": ("right_wheel",), "J": ("left_wheel",)}, "true-poses", 1.0),
        # a localiser's event-triggered poses: none while a robot stands, irregular while it moves
        Case("amcl-healthy", "boyd2-healthy", "physics", (), {"I": (), "J": ()}, "amcl", 1.0),
        Case("amcl-healthy-1s", "boyd2-healthy", "physics", (), {"I": (), "J": ()}, "amcl", 1.0,
             ("--step-seconds", "1")),
        Case("amcl-left", "boyd2-healthy", "physics", ("I:left_wheel=0.6",),
             {"I": ("left_wheel",), "J": ()}, "amcl", 1.0),
        Case("amcl-right", "boydright", "physics", ("J:right_wheel=0.5",),
             {"I": (), "J": ("right_wheel",)}, "amcl", 1.0),
        Case("amcl-two", "boyd2-healthy", "physics", ("I:right_wheel=0.6", "J:left_wheel=0.6"),
             {"I": ("right_wheel",), "J": ("left_wheel",)}, "amcl", 1.0),
        Case("amcl-two-1s", "boyd2-healthy", "physics", ("I:right_wheel=0.6", "J:left_wheel=0.6"),
             {"I": ("right_wheel",), "J": ("left_wheel",)}, "amcl", 1.0, ("--step-seconds", "1")),
        Case("edge-right", "boyd2-healthy", "physics", ("I:right_wheel=0.74",),
             {"I": ("right_wheel",), "J": ()}, "grid", 1.0),
        Case("edge-left-poses", "boyd2-healthy", "physics", ("I:left_wheel=0.74",),
             {"I": ("left_wheel",), "J": ()}, "poses", 1.0),
        Case("edge-boydright", "boydright", "physics", ("J:right_wheel=0.74",),
             {"I": (), "J": ("right_wheel",)}, "grid", 1.0),
    )
}  # fmt: skip

AMCL_MIN_D, AMCL_MIN_A = 0.25, 0.2
"""Nav2 AMCL's defaults ``update_min_d`` (m) and ``update_min_a`` (rad): it publishes a pose
only after a filter update, which waits for that much motion."""
AMCL_SIGMA_XY, AMCL_SIGMA_YAW = 0.03, np.deg2rad(2.0)
"""The localisation error added to each published pose (m, rad)."""


def amcl_stream(tracks: PoseTracks, seed: int) -> PoseTracks:
    """``tracks`` as AMCL would publish them: per robot the first pose, then each pose at
    which the robot has moved :data:`AMCL_MIN_D` or turned :data:`AMCL_MIN_A` since the last
    one published, with Gaussian error."""
    rng = np.random.default_rng(seed)
    keep = np.zeros(len(tracks), dtype=bool)
    for r in range(len(tracks.robot_names)):
        idx = np.flatnonzero(tracks.robot == r)
        idx = idx[np.argsort(tracks.t[idx], kind="stable")]
        last = None
        for i in idx:  # a loop, for each pose depends on the last one published
            if last is None or (
                np.hypot(tracks.x[i] - tracks.x[last], tracks.y[i] - tracks.y[last]) >= AMCL_MIN_D
                or abs(np.angle(np.exp(1j * (tracks.yaw[i] - tracks.yaw[last])))) >= AMCL_MIN_A
            ):
                keep[i], last = True, i
    sel = tracks.select(keep)
    n = len(sel)
    return PoseTracks(
        sel.robot_names, sel.t, sel.robot, sel.x + rng.normal(0, AMCL_SIGMA_XY, n),
        sel.y + rng.normal(0, AMCL_SIGMA_XY, n), sel.yaw + rng.normal(0, AMCL_SIGMA_YAW, n),
        sel.source,
    )  # fmt: skip


class Refused(RuntimeError):
    """mirl refused the command (exit code 2): its one line is the message."""


def run_cli(argv: list[str]) -> str:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = mirl(argv)
    if code == 2:
        raise Refused(err.getvalue().strip().splitlines()[-1])
    if code != 0:
        raise RuntimeError(f"mirl {' '.join(argv)} exited with {code}")
    return out.getvalue()


def simulated(case: Case, seed: int, work: Path) -> Path:
    """The case's data file for ``seed``, simulated once."""
    key = "-".join([case.scenario, case.world, *case.damage, f"o{case.observability:g}", str(seed)])
    folder = work / key.replace(":", "_").replace("=", "_")
    obs, poses = folder / "obs.csv", folder / "poses.csv"
    if not obs.exists():
        folder.mkdir(parents=True, exist_ok=True)
        argv = ["simulate", "--scenario", case.scenario, "--world", case.world,
                "--observability", f"{case.observability:g}", "--steps", "450",
                "--seed", str(seed), "--observations", str(obs)]  # fmt: skip
        for d in case.damage:
            argv += ["--damage", d]
        if case.world == "physics":
            argv += ["--poses", str(poses)]
        run_cli(argv)
    if case.data in ("grid", "poses"):
        return {"grid": obs, "poses": poses}[case.data]
    robots = folder / "robots.true.csv"  # the patrollers' true poses, L's own left out
    if not robots.exists():
        tracks = read_pose_csv(folder / "poses.true.csv")
        names = load_scenario(case.scenario).robot_names
        index = np.array([names.index(n) if n in names else -1 for n in tracks.robot_names])
        sel = tracks.select(index[tracks.robot] >= 0)
        write_pose_csv(
            PoseTracks(names, sel.t, index[sel.robot], sel.x, sel.y, sel.yaw, sel.source), robots
        )
    if case.data == "true-poses":
        return robots
    amcl = folder / "robots.amcl.csv"
    if not amcl.exists():
        write_pose_csv(amcl_stream(read_pose_csv(robots), seed), amcl)
    return amcl


def learned(case: Case, data: Path) -> dict:
    # no --damage: the verdicts never read the truth (it only scores a grid CSV's behaviour
    # accuracy, which this does not print), and on pose data it is refused as changing nothing
    argv = ["learn", "--scenario", case.scenario, "--observations", str(data),
            "--observability", f"{case.observability:g}", "--json", *case.learn_flags]  # fmt: skip
    return json.loads(run_cli(argv))


def false_statement(verdict: dict, damaged: tuple[str, ...]) -> bool:
    """Whether the verdict names no damaged part (a robot L never saw move has no verdict)."""
    if verdict.get("seen_moving") is False:
        return False
    named = [verdict["part"]] if verdict["part"] else list(verdict["candidates"])
    if not named:
        return bool(damaged)
    return not any(p in damaged for p in named)


def seeds_of(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    ap.add_argument("--seeds", default="0-9", help="e.g. 0-9 or 0,3,5-7")
    ap.add_argument("--work", type=Path, default=Path("/tmp/mirl-verdict-cases"))
    args = ap.parse_args()
    summary = []
    for name in args.cases:
        case = CASES[name]
        n = wrong = alone = among = damaged = misfit = refused = 0
        print(f"== {name}: {case.scenario}, {case.world}, damage {case.damage or 'scenario'}, "
              f"data {case.data}, view {case.observability:g}")  # fmt: skip
        for seed in seeds_of(args.seeds):
            try:  # a record mirl refuses is counted, with its reason, as a user would see it
                out = learned(case, simulated(case, seed, args.work))
            except Refused as e:
                refused += 1
                print(f"  seed {seed}: refused: {e}")
                continue
            for robot, r in out["robots"].items():
                v = r["verdict"]
                false = false_statement(v, case.truth[robot])
                confident = false and v["confidence"] >= CONFIDENT
                n += 1
                wrong += confident
                misfit += not v.get("fit", {"ok": True})["ok"]
                if case.truth[robot]:
                    damaged += 1
                    alone += v["part"] in case.truth[robot]
                    among += any(c in case.truth[robot] for c in v["candidates"])
                named = v["part"] or "|".join(v["candidates"]) or "none"
                if v.get("seen_moving") is False:
                    named = "(never seen moving)"
                probs = " ".join(f"{k[:4]}={p:.2f}" for k, p in r["feature_probabilities"].items())
                fit = r["verdict"].get("fit")
                extra = "" if fit is None else f" fit={'ok' if fit['ok'] else 'FAIL'}"
                models = r.get("motion_models")
                if models:
                    best = max(models, key=models.get)
                    extra += f" model={best}:{models[best]:.2f}"
                if fit is not None and not fit["ok"]:
                    if "untempered" in fit:  # the statement under L's models alone
                        extra += f" untempered={fit['untempered']:.4f}"
                    extra += f" ({fit['reason'][:70]})"
                flag = "CONFIDENTLY FALSE" if confident else ("false" if false else "")
                print(f"  seed {seed} {robot}: {named:<28} {v['confidence']:.2f} {flag:<17} "
                      f"{probs}{extra}")  # fmt: skip
        more = f"; {refused} refused" if refused else ""
        print(f"  -> confidently false: {wrong} of {n}{more}")
        summary.append(f"| {name} | {n} | {wrong} | {alone} / {damaged} | {among} / {damaged} | "
                       f"{misfit} | {refused} |")  # fmt: skip
    print("| case | verdicts | confidently false | damaged part alone | among candidates | "
          "record does not fit | records refused |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- | --- |")
    print("\n".join(summary))


if __name__ == "__main__":
    main()
