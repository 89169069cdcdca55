"""Re-learning on a grown record from an earlier solution, three ways, against learning cold.

    python benchmarks/bench_relearn.py --records 60            # boyd2, mirl-t, 14 %

Each record (seed 0 … N−1) is simulated for the longest length; the first length is learned
cold, then every longer one (each 1.5× the last, the growth at which L re-learns while it
waits) is re-learned cold and from the previous re-learn of each way:

* ``labels``: ``learn(..., warm_start=earlier)`` — the IRL from the earlier weights, the rounds
  on the earlier steps from the earlier fixed point's labels, on the new steps from perception;
* ``all-labels``: the earlier policies label the new steps too (the earlier result's
  ``horizon`` set to the new record's);
* ``weights``: only the IRL starts from the earlier weights (``horizon`` None: the rounds start
  from perception).

Prints per way the mean behaviour accuracy, re-learns better / worse than ``weights``, the
largest loss, the mean rounds, re-learns settled in one round and the mean of (wall seconds /
the cold learning's on the same record).
"""

from __future__ import annotations

import argparse
import os
import statistics
from dataclasses import replace

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from mirl.learning.learn import learn  # noqa: E402
from mirl.simulation.grid import simulate  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402

WAYS = ("labels", "all-labels", "weights")


def _accuracy(result) -> float:
    return float(np.mean([r.behavior_accuracy for r in result.robots]))


def _start(way: str, earlier, steps: int):
    """The warm start of ``way`` for a record of ``steps`` steps."""
    if way == "labels":
        return earlier
    return replace(earlier, horizon=steps if way == "all-labels" else None)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--method", default="mirl-t")
    ap.add_argument("--records", type=int, default=20)
    ap.add_argument("--observability", type=float, default=0.14)
    ap.add_argument("--lengths", type=int, nargs="+", default=[300, 450, 675])
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    kw = {"method": args.method, "observability": args.observability}
    rows: dict[str, list[tuple[float, int, float]]] = {w: [] for w in WAYS}
    for seed in range(args.records):
        obs = simulate(
            scenario, args.lengths[-1], seed=seed, observability=args.observability,
            random_starts=True,
        ).observations  # fmt: skip
        first = learn(obs.truncate(args.lengths[0]), scenario, **kw)
        earlier = dict.fromkeys(WAYS, first)
        for steps in args.lengths[1:]:
            record = obs.truncate(steps)
            cold = learn(record, scenario, **kw)
            for way in WAYS:
                r = learn(record, scenario, warm_start=_start(way, earlier[way], steps), **kw)
                earlier[way] = r
                seconds = r.timings["total"] / cold.timings["total"]
                rows[way].append((_accuracy(r), r.iterations, seconds))
    base = [a for a, _, _ in rows["weights"]]
    print(f"{len(base)} re-learns on {args.records} records of {args.scenario} at "
          f"{args.observability:g}, lengths {args.lengths}")  # fmt: skip
    print("| warm start | accuracy | better / worse than weights | largest loss | rounds | "
          "one round | time / cold |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for way in WAYS:
        acc, rounds, seconds = (list(v) for v in zip(*rows[way], strict=True))
        diff = [a - b for a, b in zip(acc, base, strict=True)]
        print(f"| {way} | {statistics.mean(acc):.4f} | {sum(d > 0 for d in diff)} / "
              f"{sum(d < 0 for d in diff)} | {min(diff):.3f} | {statistics.mean(rounds):.2f} | "
              f"{sum(r == 1 for r in rounds)} | {statistics.mean(seconds):.2f} |")  # fmt: skip


if __name__ == "__main__":
    main()
