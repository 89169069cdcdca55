"""mIRL*/T statistics : accuracy with plenty of data, identification of a damaged wheel
under occlusion (t-test over seeds), and the solver's speed.

    python benchmarks/bench_transitions.py [--seeds 30] [--workers 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from joblib import Parallel, delayed
from scipy import stats

from mirl.learning.feature_solver import solve_feature_probabilities
from mirl.learning.transitions import TransitionFeatureLearner, observed_steps, policy_labels
from mirl.simulation.grid import simulate
from mirl.world.faults import WHEELS
from mirl.world.scenario import load_scenario


def learn(scenario, steps: int, observability: float, seed: int) -> list[dict[str, float]]:
    """True-policy labels (Known R/T setting), random patroller starts."""
    d = scenario.domain
    run = simulate(scenario, steps, seed=seed, observability=observability, random_starts=True)
    series = [run.observations.state_series(d, i) for i in range(len(scenario.robots))]
    policies = [scenario.true_policy(i) for i in range(len(scenario.robots))]
    labels = policy_labels(d, series, policies, scenario.played_equilibrium)
    out = []
    for i in range(len(scenario.robots)):
        t, s, s_next = observed_steps(series[i])
        m = TransitionFeatureLearner(d, scenario.error_model).fit(s, labels[i][t], s_next)
        out.append(m.feature_probabilities_)
    return out


def wheel_test(name, scenario, robot: str, damaged: str, seeds, workers) -> None:
    i = scenario.robot_index(robot)
    res = Parallel(n_jobs=workers)(delayed(learn)(scenario, 450, 0.14, s) for s in seeds)
    left = np.array([r[i]["left_wheel"] for r in res])
    right = np.array([r[i]["right_wheel"] for r in res])
    lowest = np.mean([min(WHEELS, key=r[i].__getitem__) == damaged for r in res])
    strict = np.mean([r[i][damaged] < min(r[i][w] for w in WHEELS if w != damaged) for r in res])
    t = stats.ttest_ind(left, right)  # two-tailed, as in the paper
    print(f"{name}: {robot} at 0.14, 450 steps, {len(seeds)} seeds")
    print(
        f"  left  {left.mean():.3f} ± {left.std(ddof=1):.3f}   right {right.mean():.3f} ± "
        f"{right.std(ddof=1):.3f}   two-tailed t = {t.statistic:.2f}, p = {t.pvalue:.2e}"
    )
    print(
        f"  {damaged} is {robot}'s lowest wheel in {lowest:.0%} of seeds "
        f"(strictly lowest: {strict:.0%})"
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    boyd2 = load_scenario("boyd2")
    print("full observability, 10000 steps, true-policy labels: max |p - p_true| per robot")
    errs = Parallel(n_jobs=args.workers)(delayed(learn)(boyd2, 10_000, 1.0, s) for s in range(10))
    for s, probs in enumerate(errs):
        e = [
            max(abs(p[f] - boyd2.robots[i].feature_probabilities[f]) for f in p)
            for i, p in enumerate(probs)
        ]
        print(f"  seed {s}: I {e[0]:.3f}  J {e[1]:.3f}")
    seeds = range(1000, 1000 + args.seeds)
    wheel_test("boyd2 (J left 0.70)", boyd2, "J", "left_wheel", seeds, args.workers)
    i_right = load_scenario("boyd2-healthy").with_damage("I", "right_wheel", 0.70)
    wheel_test("boyd2-healthy + I right 0.70", i_right, "I", "right_wheel", seeds, args.workers)
    obs = [
        (("left_wheel", "right_wheel", "navigation", "floor"), 290, 450),
        (("right_wheel", "navigation", "floor"), 80, 88),
        (("left_wheel", "navigation", "floor"), 30, 45),
        (("floor",), 20, 20),
    ]
    feats = ("left_wheel", "right_wheel", "navigation", "floor")
    times = []
    for _ in range(200):
        t0 = time.perf_counter()
        solve_feature_probabilities(feats, obs)
        times.append(time.perf_counter() - t0)
    print(
        f"solver: median {np.median(times) * 1e3:.2f} ms per robot program (4 features, 4 subsets)"
    )


if __name__ == "__main__":
    main()
