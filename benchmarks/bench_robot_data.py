"""Robot data in: reading and discretising one hour of three robots at 30 Hz from MCAP
(324 000 PoseStamped messages), and reading a 50 MB grid CSV, against the slower ways side by
side. Targets: ≤ 5 s each on one core.

    python benchmarks/bench_robot_data.py [--hours 1] [--csv-mb 50] [--repeats 3]
    python benchmarks/bench_robot_data.py --round-trip [--seeds 5]

``--round-trip``: for each seed and observability, ``mirl simulate`` writes the grid CSV and
MCAP poses (10 Hz; no noise, and Gaussian noise σ = 5 cm / 3°, 15 cm / 10°, 30 cm / 20°);
``mirl learn --json`` runs on each, and the JSON of the noiseless MCAP is compared with the grid
CSV's (minus the file name, timings and what the poses' lateral drift moves: intervals, verdicts,
the drift), the noisy ones by their feature probabilities.

Everything runs in one process on one thread (pyarrow's CSV reader is asked for one thread;
numpy does no BLAS work here). Setup (writing the files) is timed and reported apart.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from mirl.observations.bags import read_bag, write_mcap
from mirl.observations.discretise import discretise
from mirl.observations.poses import PoseTracks, read_pose_csv, write_pose_csv
from mirl.observations.trajectories import Trajectories, _read_csv_python, read_csv
from mirl.world.maps import HEADING_YAWS
from mirl.world.scenario import load_scenario

RATE_HZ = 30.0
STEP_S = 2.0


def best_of(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def three_robot_scenario():
    sc = load_scenario("boyd2")
    k = dataclasses.replace(sc.robots[0], name="K")
    return dataclasses.replace(sc, robots=(*sc.robots, k))


def hour_of_poses(scenario, hours: float, seed: int = 0) -> PoseTracks:
    """Three robots at 30 Hz: each 2 s step on a random hallway state, 5 cm / 3° noise."""
    rng = np.random.default_rng(seed)
    d = scenario.domain
    n_steps = int(hours * 3600 / STEP_S)
    per_step = int(RATE_HZ * STEP_S)
    n_robots = len(scenario.robots)
    states = rng.integers(0, d.n_states, size=(n_robots, n_steps))
    rch = d.states[states]  # (robots, steps, 3)
    x, y = scenario.map.frame.cell_centre(rch[..., 0], rch[..., 1])
    yaw = HEADING_YAWS[rch[..., 2]]
    m = n_steps * per_step
    # the step's pose for the half-step either side of the step time
    j = np.arange(m)
    step_of = np.minimum((j + per_step // 2) // per_step, n_steps - 1)
    t = 1.7e9 + j / RATE_HZ
    cols = []
    for r in range(n_robots):
        cols.append(
            (
                t,
                np.full(m, r),
                x[r, step_of] + rng.normal(0, 0.05, m),
                y[r, step_of] + rng.normal(0, 0.05, m),
                yaw[r, step_of] + np.deg2rad(rng.normal(0, 3, m)),
            )
        )
    t, robot, px, py, pyaw = (np.concatenate(c) for c in zip(*cols, strict=True))
    return PoseTracks(scenario.robot_names, t, robot, px, py, pyaw)


def grid_csv(path: Path, scenario, megabytes: float, seed: int = 0) -> int:
    """A grid observations CSV of about ``megabytes`` MB; returns the number of rows."""
    rng = np.random.default_rng(seed)
    d = scenario.domain
    rows = int(megabytes * 1e6 / 15.5)  # ~15.5 bytes a row at these magnitudes
    steps = rows // 2
    tr = Trajectories.from_states(
        d, scenario.robot_names[:2], rng.integers(0, d.n_states, size=(steps, 2))
    )
    tr.to_csv(path)
    return len(tr)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--csv-mb", type=float, default=50.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--round-trip", action="store_true", help="the learn round trip instead")
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    if args.round_trip:
        round_trip(args.seeds)
        return
    sc3 = three_robot_scenario()
    topics = {f"/{n}/pose": n for n in sc3.robot_names}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # ---- MCAP ----------------------------------------------------------------------
        tracks = hour_of_poses(sc3, args.hours)
        mcap = tmp / "hour.mcap"
        t0 = time.perf_counter()
        write_mcap(tracks, mcap)
        t_write = time.perf_counter() - t0
        print(
            f"MCAP: {len(tracks)} PoseStamped messages, {args.hours:g} h x 3 robots x 30 Hz, "
            f"{mcap.stat().st_size / 1e6:.1f} MB (written in {t_write:.2f} s)"
        )
        t_fast, got = best_of(lambda: read_bag(mcap, topics, robot_names=sc3.robot_names), 1)
        t_fast = min(
            t_fast,
            best_of(lambda: read_bag(mcap, topics, robot_names=sc3.robot_names), args.repeats - 1)[
                0
            ]
            if args.repeats > 1
            else t_fast,
        )
        t_slow, slow = best_of(
            lambda: read_bag(mcap, topics, robot_names=sc3.robot_names, decode="rosbags"), 1
        )
        assert np.array_equal(got.x, slow.x) and np.array_equal(got.t, slow.t)
        t_disc, d = best_of(lambda: discretise(got, sc3, step_seconds=STEP_S), args.repeats)
        observed = sum(c.observed_steps for c in d.report)
        print(f"  read_bag, vectorised decoding      {t_fast:6.2f} s")
        print(
            f"  read_bag, rosbags deserialize       {t_slow:6.2f} s  "
            f"({t_slow / t_fast:.1f}x the vectorised path)"
        )
        print(
            f"  discretise                          {t_disc:6.2f} s  "
            f"({d.trajectories.horizon} steps, {observed} observed robot-steps)"
        )
        print(f"  read + discretise                   {t_fast + t_disc:6.2f} s  (target <= 5 s)")
        # the same poses as a pose CSV
        pcsv = tmp / "hour.csv"
        write_pose_csv(tracks, pcsv)
        t_pcsv, _ = best_of(lambda: read_pose_csv(pcsv), args.repeats)
        print(
            f"  read_pose_csv of the same poses     {t_pcsv:6.2f} s  "
            f"({pcsv.stat().st_size / 1e6:.1f} MB)"
        )

        # ---- grid CSV -------------------------------------------------------------------
        sc2 = load_scenario("boyd2")
        big = tmp / "grid.csv"
        t0 = time.perf_counter()
        n = grid_csv(big, sc2, args.csv_mb)
        t_gen = time.perf_counter() - t0
        mb = big.stat().st_size / 1e6
        print(f"grid CSV: {mb:.1f} MB, {n} rows (written in {t_gen:.2f} s)")
        t_vec, tr = best_of(lambda: read_csv(big, sc2.domain, sc2.robot_names), args.repeats)
        assert len(tr) == n
        # the row-by-row reference on the first 100 000 rows, per row
        head = tmp / "head.csv"
        with open(big) as src, open(head, "w") as dst:
            for _ in range(100_001):
                dst.write(src.readline())
        t_ref, _ = best_of(lambda: _read_csv_python(head, sc2.domain, sc2.robot_names), 1)
        per_ref = t_ref / 100_000
        print(
            f"  read_csv (pyarrow, vectorised)      {t_vec:6.2f} s  "
            f"({t_vec / n * 1e6:.2f} us/row; target <= 5 s)"
        )
        print(
            f"  row-by-row reference                {per_ref * n:6.2f} s  "
            f"(extrapolated from 100 000 rows: {per_ref * 1e6:.1f} us/row, "
            f"{per_ref * n / t_vec:.0f}x slower)"
        )
        _parse_only(big, args.repeats)


def _parse_only(path: Path, repeats: int) -> None:
    """Parse-only times of the candidate libraries on the same file (no validation)."""
    import pyarrow as pa
    import pyarrow.csv as pv

    t, _ = best_of(
        lambda: pv.read_csv(
            path,
            read_options=pv.ReadOptions(use_threads=False, block_size=1 << 22),
            convert_options=pv.ConvertOptions(column_types={"t": pa.int64()}),
        ),
        repeats,
    )
    print(f"  parse only: pyarrow.csv, 1 thread   {t:6.2f} s")
    try:
        import os

        os.environ.setdefault("POLARS_MAX_THREADS", "1")
        import polars as pl
    except ImportError:
        print("  parse only: polars                  (not installed)")
    else:
        t, _ = best_of(lambda: pl.read_csv(path), repeats)
        print(f"  parse only: polars                  {t:6.2f} s  (POLARS_MAX_THREADS=1)")
    head = path.with_name("head.csv")
    t, _ = best_of(
        lambda: np.loadtxt(head, delimiter=",", skiprows=1, usecols=(0, 2, 3, 4), dtype=int), 1
    )
    n = sum(1 for _ in open(head)) - 1
    size = path.stat().st_size / head.stat().st_size
    print(f"  parse only: numpy.loadtxt           {t * size:6.2f} s  (extrapolated from {n} rows)")


NOISE = [(0.05, 3.0), (0.15, 10.0), (0.30, 20.0)]


def _cli_json(argv: list[str]) -> dict:
    import contextlib
    import io
    import json

    from mirl.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    if code != 0:
        raise SystemExit(f"mirl {' '.join(argv)} exited {code}")
    text = buf.getvalue()
    return json.loads(text[text.index("{") :]) if "--json" in argv else {}


def round_trip(n_seeds: int, steps: int = 300) -> None:
    import contextlib
    import io

    from mirl.cli import main

    topics = ["--topic", "/I/pose=I", "--topic", "/J/pose=J", "--start-time", "0"]
    print(f"round trip on boyd2, {steps} steps, seeds 0-{n_seeds - 1}, poses at 10 Hz")
    print("obs.  seed  MCAP==CSV  " + "  ".join(f"max|dp| {m:g} m/{d:g} deg" for m, d in NOISE))
    worst = {n: 0.0 for n in NOISE}
    with tempfile.TemporaryDirectory() as tmp:
        for degree in ("0.14", "1.0"):
            for seed in range(n_seeds):
                d = Path(tmp) / f"{degree}-{seed}"
                d.mkdir()
                sim = ["simulate", "--scenario", "boyd2", "--steps", str(steps)]
                sim += ["--seed", str(seed), "--observability", degree]
                with contextlib.redirect_stdout(io.StringIO()):
                    main([*sim, "--observations", str(d / "o.csv"), "--poses", str(d / "p.mcap")])
                    for k, (m, deg) in enumerate(NOISE):
                        noisy = ["--pose-noise", str(m), str(deg)]
                        main([*sim, "--poses", str(d / f"n{k}.mcap"), *noisy])
                learn = ["learn", "--scenario", "boyd2", "--observability", degree, "--json"]
                ref = _cli_json([*learn, "--observations", str(d / "o.csv")])
                clean = _cli_json([*learn, "--observations", str(d / "p.mcap"), *topics])
                for res in (ref, clean):
                    res.pop("observations"), res.pop("timings")
                    for r in res["robots"].values():  # poses add a drift, which moves these
                        for key in ("feature_intervals", "verdict", "lateral_drift"):
                            r.pop(key, None)
                deltas = []
                for k, n in enumerate(NOISE):
                    noisy = [*learn, "--observations", str(d / f"n{k}.mcap"), *topics]
                    res = _cli_json([*noisy, "--drop-off-map"])  # 30 cm: a few poses > 0.5 cell off
                    delta = max(
                        abs(res["robots"][r]["feature_probabilities"][f] - p)
                        for r, v in ref["robots"].items()
                        for f, p in v["feature_probabilities"].items()
                    )
                    worst[n] = max(worst[n], delta)
                    deltas.append(delta)
                same = "yes" if clean == ref else "NO"
                cells = "  ".join(f"{x:>22.4f}" for x in deltas)
                print(f"{degree:>5}  {seed:>4}  {same:>9}  {cells}")
    print("worst  " + "  ".join(f"{m:g} m/{d:g} deg: {worst[(m, d)]:.4f}" for m, d in NOISE))


if __name__ == "__main__":
    main()
