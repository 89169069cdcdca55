"""The N-robot belief filter: exact joint vs factored.

    python benchmarks/bench_team.py speed            # exact 3-robot joint on boyd2: ms per step
    python benchmarks/bench_team.py error --seeds 50 --seeds3 3  # detection along L's path
    python benchmarks/bench_team.py success --seeds 50  # oracle success, exact vs factored, N=2
    python benchmarks/bench_team.py success --robots 3 --seeds 50 --out team3.jsonl  # N=3

``speed``: three patrollers on boyd2 (124³ = 1 906 624 joint states), the true models; ms
per filter step (propagate + condition) and per predicted step (propagate + detection),
against the factored filter, and one propagation of the exact joint against the first
implementation (tests/references/team_filter.py), all in the same process.
``error``: after 300 observation steps (the true models, so only the filter differs), both
filters predict 60 steps; the error is |d_exact − d_factored| on the cells of L's shortest path
at the step L would reach them if it went now — for two robots on boyd2 (pair joint) and for
three on boyd2 (tensor joint).
``success``: oracle runs with ``joint=True`` and ``joint=False`` on boyd2 (two robots, or
``--robots 3``: boyd2-3 below), common seeds; with ``--out`` one JSON line per run is appended
and seeds already there are skipped (resumable); success / detected / timeout with 95 % Wilson
intervals and the seeds where exactly one filter succeeded.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mirl.learning.results import oracle_models
from mirl.planning.belief import BeliefFilter
from mirl.planning.observer import observer_model, shortest_path_policy
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario

THREE = """\
name = "boyd2-3"
map = "boyd2"
[reward]
upper_hallway = { from = [0, 2], to = [0, 8] }
lower_hallway = { from = [16, 2], to = [16, 8] }
turn_around = [[0, 8], [16, 8]]
[[robots]]
name = "I"
start = [0, 8, 2]
[[robots]]
name = "J"
start = [16, 8, 2]
feature_probabilities = { left_wheel = 0.70 }
[[robots]]
name = "K"
start = [8, 1, 1]
"""


def boyd2_three():
    path = Path(tempfile.mkdtemp()) / "boyd2-3.toml"
    path.write_text(THREE)
    return load_scenario(path)


def _filters(sc, steps, seed):
    learned = oracle_models(sc)
    vis = sc.domain.visible_states(sc.observability)
    res = simulate(sc, steps, seed=seed, random_starts=True)
    n = len(sc.robots)
    seen = np.stack([res.observations.state_series(sc.domain, i) for i in range(n)], axis=1)
    exact = BeliefFilter(sc.domain, learned, visible=vis, joint=True)
    fact = BeliefFilter(sc.domain, learned, visible=vis, joint=False)
    return exact, fact, seen


def speed() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository
    from tests.references.team_filter import ReferenceExactTeam

    sc = boyd2_three()
    exact, fact, seen = _filters(sc, 20, 0)
    first, _, _ = _filters(sc, 20, 0)
    first.form.team = ReferenceExactTeam(exact.form.team.parts)
    model = observer_model(sc)
    rows = []
    for rep in range(2):  # the filters alternate, twice: the machine is shared
        for name, f in (("exact", exact), ("exact, first version", first), ("factored", fact)):
            f.belief, f.t = None, -1
            t = time.perf_counter()
            for row in seen:
                f.update(row)
            upd = (time.perf_counter() - t) / len(seen)
            t = time.perf_counter()
            pred = f.predict(20, model)
            rows.append((rep, name, upd, (time.perf_counter() - t) / 21, pred.detection))
    for rep, name, upd, per, _ in rows:
        print(
            f"{name:21s} (round {rep}) update {upd * 1e3:7.1f} ms/step  "
            f"predict {per * 1e3:7.1f} ms/step"
        )
    diff = np.abs(rows[0][4] - rows[1][4]).max()
    print(f"largest difference in predicted detection, exact vs first version: {diff:.1e}")


def _path_cells(model, steps):
    pol = shortest_path_policy(model)
    s, cells = model.start_state, []
    for _ in range(steps + 1):
        cells.append(int(model.cell_of(s)))
        if model.goal[s]:
            break
        s = int(model.domain.intended[s, pol[s]])
    return cells


def error(seeds: int, seeds3: int) -> None:
    """Two robots: 300 observation steps, ``seeds`` seeds; three: 40 steps (the exact tensor
    filter costs ~0.2 s per step on a loaded machine), ``seeds3`` seeds."""
    cases = (
        ("boyd2, 2 robots", load_scenario("boyd2"), 300, seeds),
        ("boyd2, 3 robots", boyd2_three(), 40, seeds3),
    )
    for label, sc, steps, n_seeds in cases:
        model = observer_model(sc)
        cells = _path_cells(model, 60)
        errs, maxes = [], []
        t0 = time.perf_counter()
        for seed in range(n_seeds):
            exact, fact, seen = _filters(sc, steps, seed)
            for row in seen:
                exact.update(row)
                fact.update(row)
            a, b = exact.predict(len(cells) - 1, model), fact.predict(len(cells) - 1, model)
            k = np.arange(len(cells))
            d = np.abs(a.detection[k, cells] - b.detection[k, cells])
            errs.append(d.mean())
            maxes.append(d.max())
        print(
            f"{label}: {n_seeds} seeds, {steps} steps observed, {len(cells)} path cells; "
            f"|d_exact - d_factored| mean "
            f"{np.mean(errs):.4f}, largest {np.max(maxes):.4f} ({time.perf_counter() - t0:.0f} s)"
        )


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    if n == 0:
        return 0.0, 1.0
    p = k / n
    mid = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, mid - half), min(1.0, mid + half)


def success(seeds: int, robots: int, out: str | None) -> None:
    from mirl.experiments.episode import run_episode

    sc = load_scenario("boyd2") if robots == 2 else boyd2_three()
    path = Path(out) if out else None
    done = (
        [json.loads(line) for line in path.read_text().splitlines()]
        if path and path.exists()
        else []
    )
    have = {(r["seed"], r["joint"]) for r in done}
    for seed in range(seeds):
        for joint in (False, True):  # factored first: it is quick
            if (seed, joint) in have:
                continue
            t = time.perf_counter()
            # 300 observed steps, as measured
            r = run_episode(
                sc, "oracle", seed=seed, protocol={"watch_until_seen": None, "joint": joint}
            )
            rec = {"seed": seed, "joint": joint, "outcome": r.outcome,
                   "seconds": time.perf_counter() - t, "cpu": r.timings["cpu"]}  # fmt: skip
            done.append(rec)
            print(json.dumps(rec), flush=True)
            if path:
                with path.open("a") as fh:
                    fh.write(json.dumps(rec) + "\n")
    summarise(done, sc.name)


def summarise(records: list[dict], name: str) -> None:
    by = {(r["seed"], r["joint"]): r for r in records}
    common = sorted(s for s, j in by if j and (s, False) in by)  # seeds both filters ran
    for joint in (True, False):
        out = [by[s, joint]["outcome"] for s in common]
        n = len(out)
        cells = []
        for k in ("success", "detected", "timeout"):
            lo, hi = wilson(out.count(k), n)
            cells.append(f"{k} {out.count(k) / max(n, 1):.2f} [{lo:.2f}, {hi:.2f}]")
        secs = np.median([by[s, joint]["seconds"] for s in common]) if common else 0.0
        label = "exact" if joint else "factored"
        print(f"{name} oracle {label}: {n} seeds, " + ", ".join(cells) + f", median {secs:.0f} s")
    ok = {j: {s for s in common if by[s, j]["outcome"] == "success"} for j in (True, False)}
    print(f"paired: only exact succeeded on seeds {sorted(ok[True] - ok[False])}, "
          f"only factored on {sorted(ok[False] - ok[True])}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("what", choices=["speed", "error", "success"])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--seeds3", type=int, default=3, help="seeds for three robots (error)")
    ap.add_argument("--robots", type=int, default=2, choices=[2, 3], help="success: team size")
    ap.add_argument("--out", help="success: JSON lines file to append to / resume from")
    args = ap.parse_args()
    {
        "speed": speed,
        "error": lambda: error(args.seeds, args.seeds3),
        "success": lambda: success(args.seeds, args.robots, args.out),
    }[args.what]()


if __name__ == "__main__":
    main()
