"""Forward against reverse mode for the sequence objective's gradient, side by side.

    python benchmarks/bench_gradients.py [--scenarios boyd2 boydright-3 office] [--repeats 15]

For each scenario: robot 0's record of a 450-step simulation at the scenario's observability,
``OccludedMaxEntIRL._loss(θ, grad=True)`` at θ = the robot's true weights, evaluated with
``gradient="forward"`` and ``"reverse"`` in turn (alternating, in one process, one BLAS
thread; soft values warm-started from the previous evaluation, as inside the optimiser). Prints
the median time per evaluation of each, their ratio, the size the ``"auto"``
rule looks at ((2K + 1)·nnz(P_πᵀ) against ``irl._REVERSE_FROM``), and the largest relative
difference between the two gradients.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, before numpy loads
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from mirl.learning import irl as irl_module  # noqa: E402
from mirl.simulation.grid import simulate  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402


def _estimators(name: str, seed: int):
    """The same robot-0 record prepared twice, once per gradient mode."""
    sc = load_scenario(name)
    d = sc.domain
    run = simulate(sc, 450, seed=seed, observability=sc.observability, random_starts=True)
    x = run.observations.state_series(d, 0)
    problem = irl_module.IRLProblem(
        d.reward_features,
        sc.true_transitions(0),
        discount=sc.discount,
        visible=d.visible_states(sc.observability),
    )
    out = []
    for mode in ("forward", "reverse"):
        est = irl_module.OccludedMaxEntIRL(gradient=mode)
        est._prepare(problem, x, None, None)
        out.append(est)
    return out, np.asarray(sc.robots[0].weights, dtype=float)


def compare(name: str, repeats: int, seed: int) -> None:
    (fwd, rev), theta = _estimators(name, seed)
    times: dict[str, list[float]] = {"forward": [], "reverse": []}
    grads = {}
    for _ in range(repeats):
        for mode, est in (("forward", fwd), ("reverse", rev)):
            t0 = time.perf_counter()
            _, grads[mode] = est._loss(theta, grad=True)
            times[mode].append(time.perf_counter() - t0)
    f, r = (float(np.median(times[m])) * 1e3 for m in ("forward", "reverse"))
    K = fwd._features.shape[2]
    size = (2 * K + 1) * len(fwd._dyn._pt_indices)
    diff = np.abs(grads["reverse"] - grads["forward"]).max() / np.abs(grads["forward"]).max()
    auto = "reverse" if size >= irl_module._REVERSE_FROM else "forward"
    print(
        f"{name:12s} seed {seed}  S {fwd._features.shape[0]:5d}  K {K}  (2K+1)·nnz {size:7d}  "
        f"forward {f:7.2f} ms  reverse {r:7.2f} ms  forward/reverse {f / r:5.2f}  "
        f"auto: {auto}  gradient rel. diff {diff:.1e}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=["boyd2", "boydright-3", "office"])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=15)
    args = ap.parse_args()
    print(f"auto takes reverse mode from (2K+1)·nnz >= {irl_module._REVERSE_FROM}")
    for name in args.scenarios:
        for seed in range(args.seeds):
            compare(name, args.repeats, seed)


if __name__ == "__main__":
    main()
