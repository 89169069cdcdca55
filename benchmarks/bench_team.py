"""The N-robot belief filter: exact joint vs factored (issue 14).

    python benchmarks/bench_team.py speed            # exact 3-robot joint on boyd2: s per step
    python benchmarks/bench_team.py error --seeds 50 --seeds3 3  # detection along L's path
    python benchmarks/bench_team.py success --seeds 50  # oracle success, exact vs factored, N=2

``speed``: three patrollers on boyd2 (124³ = 1 906 624 joint states), the true models; seconds
per filter step (propagate + condition) and per predicted step (propagate + detection),
against the factored filter, in the same process.
``error``: after 300 observation steps (the true models, so only the filter differs), both
filters predict 60 steps; the error is |d_exact − d_factored| on the cells of L's shortest path
at the step L would reach them if it went now — for two robots on boyd2 (pair joint) and for
three on boyd2 (tensor joint).
``success``: oracle runs with ``joint=True`` and ``joint=False`` on boyd2 (two robots), common
seeds.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from mirl.learning.models import oracle_models
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
    sc = boyd2_three()
    exact, fact, seen = _filters(sc, 20, 0)
    for name, f in (("exact", exact), ("factored", fact)):
        t = time.perf_counter()
        for row in seen:
            f.update(row)
        upd = (time.perf_counter() - t) / len(seen)
        t = time.perf_counter()
        f.predict(20, observer_model(sc))
        pred = (time.perf_counter() - t) / 21
        print(
            f"{name:9s} mode={f.mode:8s} update {upd * 1e3:8.1f} ms/step  "
            f"predict {pred * 1e3:8.1f} ms/step"
        )


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
    filter costs ~1 s per step), ``seeds3`` seeds."""
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


def success(seeds: int) -> None:
    from mirl.experiments.episode import run_episode

    sc = load_scenario("boyd2")
    for joint in (True, False):
        out = [run_episode(sc, "oracle", seed=s, joint=joint).outcome for s in range(seeds)]
        rates = {k: out.count(k) / seeds for k in ("success", "detected", "timeout")}
        print(f"boyd2 oracle joint={joint}: {seeds} seeds {rates}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("what", choices=["speed", "error", "success"])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--seeds3", type=int, default=3, help="seeds for three robots (error)")
    args = ap.parse_args()
    {
        "speed": speed,
        "error": lambda: error(args.seeds, args.seeds3),
        "success": lambda: success(args.seeds),
    }[args.what]()


if __name__ == "__main__":
    main()
