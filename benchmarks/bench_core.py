"""Core speed: value iteration on the largest generated office map, sparse CSR
(mirl.mdp) against a dense (S, A, S) numpy baseline run side by side, and simulation speed.

    python benchmarks/bench_core.py [--size 80]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mirl.mdp import TabularMDP, value_iteration
from mirl.simulation.grid import simulate
from mirl.world.domain import PatrolDomain
from mirl.world.motion import transition_matrix
from mirl.world.office_maps import generate_office_map
from mirl.world.scenario import HEALTHY_PROBABILITIES, load_scenario


def best_of(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def dense_value_iteration(P: np.ndarray, R: np.ndarray, gamma: float, tol: float = 1e-8):
    """Baseline: the textbook dense Bellman backup, Q = R + γ Σ_s' P[s,a,s'] V[s']."""
    V = np.zeros(R.shape[0])
    while True:
        V_new = (R + gamma * (P @ V)).max(axis=1)
        if np.abs(V_new - V).max() < tol:
            return V_new
        V = V_new


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=60, help="office map side (cells)")
    args = ap.parse_args()
    gridmap = generate_office_map(args.size, args.size, seed=0)
    d = PatrolDomain(gridmap)
    T = transition_matrix(d, HEALTHY_PROBABILITIES)
    R = d.rewards([1.0, 0.0, 0.0, 0.3])
    mdp = TabularMDP(T, R, 0.95)
    sparse = best_of(lambda: value_iteration(mdp))
    res = value_iteration(mdp)
    print(
        f"office {args.size}x{args.size}: {gridmap.n_patroller_cells} hallway cells, "
        f"{d.n_states} states, VI {res.iterations} sweeps"
    )
    dense_P = T.toarray().reshape(d.n_states, d.n_actions, d.n_states)
    dense = best_of(lambda: dense_value_iteration(dense_P, R, 0.95), repeats=1)
    assert np.allclose(dense_value_iteration(dense_P, R, 0.95), res.values, atol=1e-6)
    print(
        f"  value iteration: sparse {sparse:.3f} s, dense baseline {dense:.3f} s "
        f"(sparse is {dense / sparse:.1f}x faster)"
    )
    scenario = load_scenario("boyd2")
    scenario.true_policy(0)  # solve the true models outside the timing
    sim = best_of(lambda: simulate(scenario, 1000, seed=0, observability=0.14))
    print(f"boyd2: simulate 1000 steps in {sim * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
