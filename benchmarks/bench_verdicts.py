"""The learning time the fault verdicts add, measured side by side with another checkout.

    python benchmarks/bench_verdicts.py --against OTHER_SRC [--scenario boyd2] [--steps 300]
        [--seeds 6] [--repeats 3]

Each repeat runs, in turn, one process per source tree (this one's ``src`` and ``OTHER_SRC``,
another checkout), each learning ``mirl-t`` models on the same grid observations of the
scenario (boyd2: J's left wheel damaged; 300 steps, seeds 0…N−1, at L's door and full view)
with one BLAS thread, and reports each tree's CPU time per learn, the ratio, and this tree's
``verdicts`` phase as a share of its learning time. The learned numbers of both trees are
compared too: the verdicts change no feature probability, weight or equilibrium unless a record
makes L learn again under another motion model.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1] / "src"

WORKER = r"""
import json, sys, time
from mirl.learning.learn import learn
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario
scenario = load_scenario(sys.argv[2])
seeds, steps = int(sys.argv[1]), int(sys.argv[3])
data = [(d, simulate(scenario, steps, seed=s, observability=d, random_starts=True).observations)
        for s in range(seeds) for d in (0.14, 1.0)]
cpu, phase, out = 0.0, 0.0, []
for d, obs in data:
    start = time.process_time()
    res = learn(obs, scenario, "mirl-t", observability=d)
    cpu += time.process_time() - start
    phase += res.timings.get("verdicts", 0.0)
    out.append([[round(v, 12) for v in r.feature_probabilities.values()]
                + [round(float(w), 9) for w in r.weights] for r in res.robots]
               + [res.equilibrium.label()])
print(json.dumps({"cpu": cpu / len(data), "verdicts": phase / len(data), "learned": out}))
"""


def measure(src: Path, seeds: int, scenario: str, steps: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    done = subprocess.run(
        [sys.executable, "-c", WORKER, str(seeds), scenario, str(steps)], env=env,
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(done.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", required=True, type=Path, help="the other tree's src directory")
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    ours, theirs = [], []
    for _ in range(args.repeats):  # interleaved: a busy machine slows both alike
        ours.append(measure(HERE, args.seeds, args.scenario, args.steps))
        theirs.append(measure(args.against, args.seeds, args.scenario, args.steps))
    a = min(r["cpu"] for r in ours)
    b = min(r["cpu"] for r in theirs)
    share = min(r["verdicts"] for r in ours) / a
    same = ours[0]["learned"] == theirs[0]["learned"]
    print(f"{args.scenario}, {args.steps} steps: CPU per learn (best of {args.repeats}, "
          f"{2 * args.seeds} learns each):")  # fmt: skip
    print(f"  this tree   {a:.3f} s (of which verdicts {share:.1%})")
    print(f"  other tree  {b:.3f} s")
    print(f"  ratio       {a / b:.3f}")
    print(f"  learned numbers identical: {same}")


if __name__ == "__main__":
    main()
