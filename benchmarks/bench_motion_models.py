"""The motion models' weights on grid records each candidate model made.

    python benchmarks/bench_motion_models.py [--seeds 0-4] [--steps 450] [--strength 0.6]

For each of the four candidates (the paper's ξ or turns without wheels, × Eq. 5 or failed steps
that stay put; :mod:`mirl.learning.motion_models`), boyd2 is simulated on the grid with that
model and J's left wheel at ``--strength`` (full view, random starts), and learned with the
shipped scenario (the paper's ξ with Eq. 5), as a user would. Per record it prints J's weight of
the model that made it, the weight of that model's error model (summed over ξ), and the model L
learned with.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from mirl.learning.learn import learn
from mirl.simulation.grid import simulate
from mirl.world.motion import turns_without_wheels
from mirl.world.scenario import load_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-4")
    ap.add_argument("--steps", type=int, default=450)
    ap.add_argument("--strength", type=float, default=0.6)
    args = ap.parse_args()
    lo, _, hi = args.seeds.partition("-")
    seeds = range(int(lo), int(hi or lo) + 1)
    base = load_scenario("boyd2")
    print("| model that made the record | seed | its weight | its error model's | learned with |")
    print("| --- | --- | --- | --- | --- |")
    for xi in ("paper", "free-turns"):
        for errors in ("uniform", "stop"):
            fm = base.feature_map if xi == "paper" else turns_without_wheels(base.feature_map)
            truth = replace(base, error_model=errors).modelled_with(fm, error_model=errors)
            truth = truth.with_damage("J", "left_wheel", args.strength)
            for seed in seeds:
                obs = simulate(truth, args.steps, seed=seed, observability=1.0,
                               random_starts=True).observations  # fmt: skip
                j = learn(obs, base, "mirl-t", observability=1.0, score=False).robot("J")
                w = j.uncertainty.motion_models
                same = sum(v for m, v in w.items() if m.endswith("/" + errors))
                print(f"| {xi}/{errors} | {seed} | {w[f'{xi}/{errors}']:.3f} | {same:.3f} | "
                      f"{j.motion_model} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
