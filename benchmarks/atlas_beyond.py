"""The atlas's runs on design points outside its design: what the verdicts say where the
atlas never looked.

    python benchmarks/atlas_beyond.py --seeds 1,2 --out beyond.jsonl
    python benchmarks/atlas_beyond.py --out beyond.jsonl --report

Each point runs :func:`mirl.experiments.atlas.atlas_run` (simulate, then ``mirl learn --json``
from the grid CSV, the pose CSV and the MCAP, each command a fresh process; scored against the
world's own definition of damage) on values none of the atlas's axes takes: the TurtleBot3
world's real map (``docs/examples/turtlebot3-world.toml``) on the grid (its 0.5 m cells are
narrower than the physical world's calibration: results.md, "Cells narrower than the
calibration's"), wheel values 0.4, 0.55, 0.7 (physics) and 0.85 (grid: weaker, not damaged by
its effect), views 0.3 and 0.5, records of 300 and 600 steps, boydright-3 in physics at view
0.5 and the office at 900 steps through L's door. Runs are JSON lines in ``--out``; a (point,
seed) already there is not run again, so an interrupted probe resumes. The report counts the
verdicts L states (a robot never seen moving has none), the confidently false statements (wrong
at confidence >= 0.9) and the reliability by deciles.
"""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

from mirl.experiments.atlas import DATA_PATHS, atlas_run  # noqa: E402
from mirl.learning.verdicts import NEVER_SEEN  # noqa: E402

TB3 = str(Path(__file__).resolve().parents[1] / "docs" / "examples" / "turtlebot3-world.toml")


@dataclass(frozen=True)
class Point:
    """A design point (:class:`mirl.experiments.atlas.DesignPoint`) outside the atlas's."""

    world: str
    scenario: str
    observability: float
    obs_steps: int
    damage: str

    @property
    def key(self) -> str:
        """Seeds the point's simulations (the scenario by its file name, not its folder)."""
        name = Path(self.scenario).stem if self.scenario.endswith(".toml") else self.scenario
        return f"beyond|{self.world}|{name}|{self.observability:g}|{self.obs_steps}|{self.damage}"


def points() -> list[Point]:
    """The probe's design points."""
    out = [
        Point("grid", TB3, 1.0, 450, d)
        for d in ("none", "I:left_wheel=0.7", "J:right_wheel=0.7",
                  "I:right_wheel=0.6,J:left_wheel=0.6")
    ]  # fmt: skip
    out += [
        Point("grid", "boydright", v, 450, d)
        for d in ("I:right_wheel=0.55", "I:right_wheel=0.85", "J:left_wheel=0.85")
        for v in (1.0, 0.14)
    ]
    out += [
        Point("grid", "boyd2-healthy", v, n, d)
        for d in ("none", "J:left_wheel=0.7")
        for v, n in ((0.3, 300), (0.5, 600))
    ]
    out += [
        Point("physics", "boyd2-healthy", 1.0, 450, d)
        for d in ("J:right_wheel=0.7", "J:right_wheel=0.4", "I:left_wheel=0.6,J:left_wheel=0.6",
                  "none")
    ]  # fmt: skip
    out += [
        Point("physics", "boydright", 0.3, 600, d)
        for d in ("I:left_wheel=0.7", "none", "J:right_wheel=0.5")
    ]
    out += [Point("physics", "boydright-3", 0.5, 300, "K:right_wheel=0.7")]
    out += [Point("grid", "office", 0.14, 900, "J:left_wheel=0.55")]
    return out


def _one(point: Point, seed: int) -> dict:
    result = atlas_run(point, seed)
    result.pop("timings", None)
    return {"point": point.key, "seed": seed, **result}


def report(rows: list[dict]) -> None:
    """Print the counts, the confidently false statements and the deciles of the verdicts L
    states (a robot it never saw move has none: design, "The calibration atlas")."""
    conf, right, false = [], [], []
    per_world: dict[tuple[str, str], int] = {}
    unseen = 0
    for r in rows:
        robots = [k.split(".", 1)[1] for k in r if k.startswith("truth.")]
        for path in DATA_PATHS:
            for robot in robots:
                k = f"{path}.{robot}"
                if f"confidence.{k}" not in r:
                    continue
                if r.get(f"fit.{k}") == NEVER_SEEN:
                    unseen += 1
                    continue
                c, ok = float(r[f"confidence.{k}"]), int(r[f"right.{k}"])
                conf.append(c)
                right.append(ok)
                world = r["point"].split("|")[1]
                per_world[world, path] = per_world.get((world, path), 0) + 1
                if not ok and c >= 0.9:
                    false.append((r["point"], r["seed"], path, robot, r[f"verdict.{k}"], c))
    c, o = np.array(conf), np.array(right)
    print(f"{len(rows)} runs, {len(c)} verdicts: " + ", ".join(
        f"{w} {p} {n}" for (w, p), n in sorted(per_world.items())))  # fmt: skip
    print(f"robots never seen moving (no verdict, left out): {unseen}")
    print(f"confidently false (wrong at >= 0.9): {len(false)}")
    for x in false:
        print("  ", *x)
    print(f"wrong at any confidence: {int((o == 0).sum())}; mean confidence {c.mean():.3f}, "
          f"right {o.mean():.3f}")  # fmt: skip
    bins = np.minimum((c * 10).astype(int), 9)
    ece = sum(abs(c[bins == b].mean() - o[bins == b].mean()) * (bins == b).sum()
              for b in np.unique(bins)) / len(c)  # fmt: skip
    print(f"ECE (10 bins) {ece:.3f}")
    for b in np.unique(bins):
        m = bins == b
        print(f"  {b / 10:.1f}-{(b + 1) / 10:.1f}: {m.sum():4d} verdicts, stated "
              f"{c[m].mean():.3f}, right {o[m].mean():.3f}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1,2", help="comma-separated run seeds")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", required=True)
    ap.add_argument("--report", action="store_true", help="only report what --out holds")
    args = ap.parse_args()
    out = Path(args.out)
    rows = [json.loads(line) for line in out.read_text().splitlines()] if out.exists() else []
    if not args.report:
        done = {(r["point"], r["seed"]) for r in rows}
        jobs = [
            (p, s)
            for p in points()
            for s in (int(x) for x in args.seeds.split(","))
            if (p.key, s) not in done
        ]
        with out.open("a") as f:
            for r in Parallel(n_jobs=args.workers, return_as="generator_unordered")(
                delayed(_one)(p, s) for p, s in jobs
            ):
                f.write(json.dumps(r) + "\n")
                f.flush()
                rows.append(r)
    report(rows)


if __name__ == "__main__":
    main()
