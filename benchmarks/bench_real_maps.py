"""Real ROS maps, as a new user meets them: a scenario in metres next to each map, then
``show-map``, ``simulate``, ``learn`` (on the grid CSV and on an MCAP bag) and ``run``, each
timed in its own process (wall, CPU, peak RSS):

    python benchmarks/bench_real_maps.py MAP.yaml [...] [--cell-size 0.5 0.25] [--native]
        [--out DIR] [--obs-steps 300] [--max-memory 6G] [--timeout 900]

Public maps to try (none ships here but the TurtleBot3 world): Nav2's ``nav2_bringup/maps``
``depot.yaml`` (0.05 m/px) and ``warehouse.yaml`` (0.03 m/px), Willow Garage at 0.1 m/px
(``willow-2010-02-18-0.10``, ROS navigation's stage maps) and at 0.05 m/px
(``slam_karto/maps/willow-full-0.05.pgm``, with a YAML of resolution 0.05 and origin 0).

The scenario is written from the map alone, discretised at the cell size: the largest connected
free region; L hides at a dead end far across it and wants to reach the free cell farthest from
there; two patrollers, rewarded for moving and for turning round at the cells 35 % and 65 % of
the way, start on those cells. Every position is written in metres of the map frame (cell
centres), so the scenario is the same one a user would write by reading RViz. ``--native`` also
tries each map at its own resolution, where mirl should either run within ``--max-memory`` or
refuse in one line within seconds; ``show-map`` there is run only when the grid fits.

Prints one row per (map, cell size, command): cells, patroller states, wall s, CPU s, peak MB
and the outcome (the last line of a refusal or failure).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections import deque
from pathlib import Path

import numpy as np

HEADING_YAW = (0, 90, 180, 270)  # east, north, west, south
STEPS = ((0, 1), (-1, 0), (0, -1), (1, 0))  # the moves of headings 0..3 in (row, col)


def _bfs(free: np.ndarray, src: tuple[int, int]) -> np.ndarray:
    dist = np.full(free.shape, -1, dtype=int)
    dist[src] = 0
    queue = deque([src])
    while queue:
        r, c = queue.popleft()
        for dr, dc in STEPS:
            rr, cc = r + dr, c + dc
            if 0 <= rr < free.shape[0] and 0 <= cc < free.shape[1]:
                if free[rr, cc] and dist[rr, cc] < 0:
                    dist[rr, cc] = dist[r, c] + 1
                    queue.append((rr, cc))
    return dist


def _largest_region(free: np.ndarray) -> np.ndarray:
    from scipy import ndimage

    labels, n = ndimage.label(free)
    if n == 0:
        raise SystemExit("no free cell")
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    return labels == sizes.argmax()


def write_scenario(map_yaml: Path, cell_size: float, out: Path) -> Path:
    """Write ``out`` (a scenario TOML) for ``map_yaml`` at ``cell_size``; positions in metres.
    Written twice: the second time patroller I's patrol reaches into L's view (which needs L's
    start in a scenario to compute)."""
    from mirl.world.scenario import load_scenario

    _write_scenario(map_yaml, cell_size, out, None)
    sc = load_scenario(out)
    return _write_scenario(map_yaml, cell_size, out, sc.map.visible_mask(sc.observability))


def _write_scenario(
    map_yaml: Path, cell_size: float, out: Path, visible: np.ndarray | None
) -> Path:
    from mirl.world.ros_maps import load_ros_map

    gm = load_ros_map(map_yaml, cell_size=cell_size)
    free = _largest_region(gm.patroller | gm.observer_only)
    neighbours = sum(np.roll(free, s, a) for s in (1, -1) for a in (0, 1))
    cells = np.argwhere(free)
    ends = np.argwhere(free & (neighbours == 1))
    if len(ends) == 0:
        ends = cells
    d0 = _bfs(free, (int(cells[0][0]), int(cells[0][1])))
    r, c = ends[np.argmax(d0[tuple(ends.T)])]
    start = (int(r), int(c))
    ds = _bfs(free, start)
    goal = tuple(int(v) for v in np.unravel_index(np.argmax(ds), ds.shape))
    far = int(ds.max())

    def at_cell(rc: tuple[int, int]) -> int:
        """A heading from ``rc`` to a free neighbour."""
        for h, (dr, dc) in enumerate(STEPS):
            if 0 <= rc[0] + dr < free.shape[0] and 0 <= rc[1] + dc < free.shape[1]:
                if free[rc[0] + dr, rc[1] + dc]:
                    return h
        return 0

    def at(frac: float) -> tuple[int, int, int]:
        """A cell at ``frac`` of the way from L's start to its goal, heading to a free neighbour."""
        rr, cc = (int(v) for v in np.argwhere(ds == max(1, int(far * frac)))[0])
        return rr, cc, at_cell((rr, cc))

    r1, r2 = at(0.35), at(0.65)
    if visible is not None and visible[free].any():
        # I turns round at the cell of L's view farthest from L: its patrol crosses the view
        dv = np.where(visible & free & (ds > 0), ds, -1)
        rv = tuple(int(v) for v in np.unravel_index(np.argmax(dv), dv.shape))
        if rv not in (r1[:2], r2[:2]):
            r1 = (*rv, at_cell(rv))

    def xy(rc) -> str:
        x, y = gm.frame.cell_centre(rc[0], rc[1])
        return f"x = {float(x):.3f}, y = {float(y):.3f}"

    def pose(rch) -> str:
        return f"{{ {xy(rch)}, yaw = {HEADING_YAW[rch[2]]} }}"

    try:
        map_ref = os.path.relpath(map_yaml.resolve(), out.parent.resolve())
    except ValueError:  # another drive
        map_ref = str(map_yaml.resolve())
    name = f"{map_yaml.stem}-{cell_size:g}m"
    out.write_text(
        f"""# by benchmarks/bench_real_maps.py from {map_yaml.name} alone; positions in metres
name = "{name}"
map = "{map_ref}"
observability = 0.14
detect_distance = 6

[frame]
cell_size = {cell_size:g}

[observer]
start = {{ {xy(start)} }}
goal = {{ {xy(goal)} }}

[reward]
features = [
  {{ name = "moved", kind = "moved" }},
  {{ name = "ends", kind = "turn_around", cells = [{{ {xy(r1)} }}, {{ {xy(r2)} }}] }},
]
weights = {{ moved = 1.0, ends = 0.3 }}

[[robots]]
name = "I"
start = {pose(r1)}

[[robots]]
name = "J"
start = {pose(r2)}
feature_probabilities = {{ left_wheel = 0.70 }}
"""
    )
    return out


def timed(
    cmd: list[str], timeout: float, limit_gb: float = 0.0
) -> tuple[int, float, float, float, str, str]:
    """Run ``cmd``; (return code, wall s, CPU s, peak RSS MB, stdout, stderr) of that process.
    ``limit_gb`` > 0 caps its address space (a safety net: a late crash, not a swapped machine)."""

    def cap() -> None:
        if limit_gb > 0:
            import resource

            lim = int(limit_gb * 2**30)
            resource.setrlimit(resource.RLIMIT_AS, (lim, lim))

    wall = time.perf_counter()
    with open(os.devnull, "rb") as devnull:
        proc = subprocess.Popen(
            cmd,
            stdin=devnull,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=cap,
        )
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            err += f"\ntimed out after {timeout:g} s"
    wall = time.perf_counter() - wall
    # each command runs through a tiny wrapper that reports its own CPU time and peak RSS
    # (below): the peak is read from /proc/self/status (VmHWM, this process's own), as Linux
    # carries ru_maxrss over fork and exec from this (large, after --native) parent
    rc = proc.returncode
    cpu, rss = float("nan"), float("nan")
    lines = err.splitlines()
    if lines and lines[-1].startswith("RUSAGE "):
        _, cpu_s, rss_kb = lines.pop().split()
        cpu, rss = float(cpu_s), float(rss_kb) / 1024
        err = "\n".join(lines)
    return rc, wall, cpu, rss, out, err


_WRAP = (
    "import resource, runpy, sys\n"
    "sys.argv = ['mirl'] + sys.argv[1:]\n"
    "code = 0\n"
    "try:\n"
    "    runpy.run_module('mirl', run_name='__main__')\n"
    "except SystemExit as exc:\n"
    "    code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)\n"
    "    if not isinstance(exc.code, int) and exc.code is not None:\n"
    "        print(exc.code, file=sys.stderr)\n"
    "finally:\n"
    "    u = resource.getrusage(resource.RUSAGE_SELF)\n"
    "    hwm = [ln.split()[1] for ln in open('/proc/self/status') if ln.startswith('VmHWM')]\n"
    "    sys.stdout.flush()\n"
    "    print('RUSAGE', u.ru_utime + u.ru_stime, hwm[0] if hwm else u.ru_maxrss,\n"
    "          file=sys.stderr)\n"
    "sys.exit(code)\n"
)


def mirl(args: list[str], timeout: float, limit_gb: float = 0.0):
    return timed([sys.executable, "-c", _WRAP, *args], timeout, limit_gb)


def outcome(rc: int, out: str, err: str, command: str) -> str:
    if rc != 0:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        return f"FAILED rc={rc}: " + (lines[-1] if lines else "(no message)")
    lines = out.splitlines()
    if command == "run":
        hits = [ln.strip() for ln in lines if ln.lower().lstrip().startswith("outcome")]
        return hits[-1] if hits else (lines[-1].strip() if lines else "ok")
    if command.startswith("learn"):
        hits = [ln.strip() for ln in lines if "accuracy" in ln.lower()]
        return hits[0][:90] if hits else "ok"
    return "ok"


def states_of(show_map_out: str) -> tuple[str, str]:
    import re

    m = re.search(r"(\d+) patroller cells, (\d+) patroller states", show_map_out)
    return (m.group(1), m.group(2)) if m else ("?", "?")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+", type=Path, help="ROS map_server YAML files")
    ap.add_argument("--cell-size", type=float, nargs="*", default=[0.5])
    ap.add_argument("--native", action="store_true", help="also each map at its resolution")
    ap.add_argument("--out", type=Path, default=None, help="where to write (default: by the map)")
    ap.add_argument("--obs-steps", type=int, default=300)
    ap.add_argument("--max-memory", default=None, help="passed to learn and run (e.g. 6G)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds a command may take")
    ap.add_argument("--limit-gb", type=float, default=8.0, help="address-space cap (0: none)")
    every = ["show-map", "simulate", "learn", "learn-bag", "run"]
    ap.add_argument("--commands", nargs="+", default=every, choices=every)
    args = ap.parse_args()
    import yaml

    budget = ["--max-memory", args.max_memory] if args.max_memory else []
    print(f"{'map':<24}{'cell m':>7}{'cells':>8}{'states':>8}  {'command':<10}"
          f"{'wall s':>8}{'CPU s':>8}{'peak MB':>9}  outcome", flush=True)  # fmt: skip
    for map_yaml in args.maps:
        resolution = float(yaml.safe_load(map_yaml.read_text())["resolution"])
        sizes = list(args.cell_size) + ([resolution] if args.native else [])
        for cell in sizes:
            out_dir = args.out or map_yaml.parent
            out_dir.mkdir(parents=True, exist_ok=True)
            stem = f"{map_yaml.stem}-{cell:g}m"
            cells, states = "?", "?"
            try:
                sc = str(write_scenario(map_yaml, cell, out_dir / f"{stem}.toml"))
            except Exception as exc:  # e.g. a grid over the side limit: show-map says why
                sc = None
                msg = str(exc).splitlines()[0]
                print(f"{map_yaml.stem[:24]:<24}{cell:>7g}{'':>8}{'':>8}  {'scenario':<10}"
                      f"{'':>8}{'':>8}{'':>9}  not written: {msg}", flush=True)  # fmt: skip
            obs, bag = out_dir / f"{stem}.csv", out_dir / f"{stem}.mcap"
            commands = {
                "show-map": ["show-map", sc or str(map_yaml), "--png", str(out_dir / f"{stem}.png")]
                + ([] if sc else ["--cell-size", f"{cell:g}"]),
                "simulate": ["simulate", "--scenario", str(sc), "--steps", str(args.obs_steps),
                             "--seed", "1", "--observations", str(obs), "--poses", str(bag),
                             "--pose-noise", "0.05", "3"],
                "learn": ["learn", "--scenario", str(sc), "--observations", str(obs), *budget],
                "learn-bag": ["learn", "--scenario", str(sc), "--observations", str(bag),
                              "--topic", "/I/pose=I", "--topic", "/J/pose=J", *budget],
                "run": ["run", "--scenario", str(sc), "--obs-steps", str(args.obs_steps),
                        "--seed", "0", *budget],
            }  # fmt: skip
            for name in args.commands:
                if sc is None and name != "show-map":
                    continue
                if (
                    name in ("learn", "learn-bag")
                    and not (obs if name == "learn" else bag).exists()
                ):
                    print(f"{'':<24}{cell:>7g}{cells:>8}{states:>8}  {name:<10}  skipped: "
                          "no simulated data", flush=True)  # fmt: skip
                    continue
                if name == "simulate":  # fresh outputs (mirl never overwrites an MCAP)
                    obs.unlink(missing_ok=True)
                    bag.unlink(missing_ok=True)
                rc, wall, cpu, rss, out, err = mirl(commands[name], args.timeout, args.limit_gb)
                if name == "show-map" and rc == 0:
                    cells, states = states_of(out)
                print(f"{map_yaml.stem[:24]:<24}{cell:>7g}{cells:>8}{states:>8}  {name:<10}"
                      f"{wall:>8.1f}{cpu:>8.1f}{rss:>9.0f}  {outcome(rc, out, err, name)}",
                      flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
