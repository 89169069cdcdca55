"""The physical world: calibration and speed.

    python benchmarks/bench_physics.py [--seeds 4] [--steps 750] [--skip-speed]

1. **Calibration.** Healthy patrollers (boyd2-healthy) and J with a 0.6-strength left wheel
   motor (boyd2) patrol with their actions known; per robot and action: the effective success
   rate (every step, and steps with no other robot within 2 cells), m/s per forward step, peak
   turn rate; each wheel's open-loop top speed and pivot turn rate.
2. **What mIRL*/T recovers at full view**: Eq. 4 (max entropy) on (a) the true steps with the
   executed actions, (b) L's full-view camera observations labelled by the true policy (Known
   R/T), (c) the whole mirl-t learner (``learn``) on L's full-view observations, 300 steps.
3. **Speed.** A 750-step (25-minute) run with three robots (I, J, L): CPU and wall seconds and
   the real-time factor; ``run_episode(world="physics")`` end to end.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mirl.experiments.episode import run_episode
from mirl.learning.learn import learn
from mirl.learning.transitions import TransitionFeatureLearner, observed_steps, policy_labels
from mirl.physics.calibration import calibrate, open_loop
from mirl.physics.patrol import PhysicalWorld
from mirl.world.domain import ACTIONS
from mirl.world.scenario import load_scenario

FEATURES = ("left_wheel", "right_wheel", "navigation", "floor")


def _fmt(p: dict) -> str:
    return "  ".join(f"{f} {p[f]:.3f}" for f in FEATURES)


def calibration(name: str, seeds: int, steps: int) -> None:
    sc = load_scenario(name)
    dom = sc.domain
    cal = calibrate(sc, steps=steps, seeds=range(seeds))
    print(f"\n## {name}: {seeds} patrols x {steps} steps, full view "
          f"({cal.cpu_seconds:.1f} s CPU for {cal.sim_seconds / 60:.0f} simulated min; "
          f"{cal.contacts} robot contacts, {cal.wall_contacts} wall contacts)")  # fmt: skip
    print("robot  motors          action      success (n)        alone (n)     m/s | deg/s")
    for i, rn in enumerate(cal.robot_names):
        ms = {w: cal_strength(sc, rn, w) for w in ("left_wheel", "right_wheel")}
        motors = f"L {ms['left_wheel']:.1f} R {ms['right_wheel']:.1f}"
        for a in ACTIONS:
            r, n = cal.rate(i, a)
            ra, na = cal.rate(i, a, alone=True)
            extra = ""
            if a == "forward" and cal.forward_speed[i]:
                extra = f"{np.mean(cal.forward_speed[i]):.2f} m/s"
            elif a in ("turn_left", "turn_right") and cal.turn_rate[i][a]:
                extra = f"{np.mean(cal.turn_rate[i][a]):.0f} deg/s peak"
            print(f"{rn:<6} {motors:<15} {a:<11} {r:>6.3f} ({n:>4})   {ra:>6.3f} ({na:>4})   "
                  f"{extra}")  # fmt: skip
        ol = open_loop(sc, rn)
        print(f"{rn:<6} open loop: left wheel {ol['left_wheel_speed']:.2f} m/s, right wheel "
              f"{ol['right_wheel_speed']:.2f} m/s; pivot turn_left {ol['turn_left_rate']:.0f} "
              f"deg/s, turn_right {ol['turn_right_rate']:.0f} deg/s")  # fmt: skip
    share, failed = cal.stayed()
    print(
        f"failed moving steps that stayed put: {share:.3f} of {failed} (the rest reached "
        f"another action's state or elsewhere); forward: {cal.stayed('forward')[0]:.3f}"
    )
    # (a) Eq. 4 from the true steps and executed actions
    print("mIRL*/T (Eq. 4, max entropy):")
    n = len(sc.robots)
    for i, rn in enumerate(cal.robot_names):
        tr = np.concatenate(cal.transitions[i::n])
        m = TransitionFeatureLearner(dom, sc.error_model).fit(tr[:, 0], tr[:, 1], tr[:, 2])
        print(f"  {rn} (a) true steps, executed actions:     {_fmt(m.feature_probabilities_)}")
    # (b), (c): what L's camera gives at full view
    w = PhysicalWorld(sc, seed=1000, random_starts=True, observability=1.0)
    for _ in range(299):
        w.step()
    obs = w.observations()
    series = [obs.state_series(dom, i) for i in range(n)]
    labels = policy_labels(dom, series, [sc.true_policy(i) for i in range(n)],
                           sc.played_equilibrium)  # fmt: skip
    res = learn(obs, sc, "mirl-t", observability=1.0, random_state=0)
    for i, rn in enumerate(cal.robot_names):
        t, s, s2 = observed_steps(series[i])
        m = TransitionFeatureLearner(dom, sc.error_model).fit(s, labels[i][t], s2)
        print(f"  {rn} (b) L's camera, 300 steps, true-policy labels: "
              f"{_fmt(m.feature_probabilities_)}")  # fmt: skip
        print(f"  {rn} (c) mirl-t learn(), 300 steps:           "
              f"{_fmt(res.robots[i].feature_probabilities)}")  # fmt: skip


def cal_strength(sc, robot: str, wheel: str) -> float:
    from mirl.physics.patrol import scenario_physics

    return scenario_physics(sc).strength(robot, wheel)


def speed(repeats: int = 3) -> None:
    sc = load_scenario("boyd2")
    print("\n## speed")
    cpus, walls = [], []
    for r in range(repeats):
        c, t = time.process_time(), time.perf_counter()
        w = PhysicalWorld(sc, seed=r, random_starts=True)
        for _ in range(750):
            w.step()
        cpus.append(time.process_time() - c)
        walls.append(time.perf_counter() - t)
    print(f"750 steps (1500 s), I + J + L: CPU {np.median(cpus):.2f} s (median of {repeats}; "
          f"real-time factor {1500 / np.median(cpus):.0f}), wall {np.median(walls):.2f} s "
          f"(timestep {w.cfg.timestep} s, control {w.cfg.control_hz:g} Hz)")  # fmt: skip
    cpus, walls, outs = [], [], []
    for seed in range(5):
        c, t = time.process_time(), time.perf_counter()
        res = run_episode(
            sc, "mirl-t", seed=seed, world="physics", protocol={"watch_until_seen": None}
        )
        cpus.append(time.process_time() - c)
        walls.append(time.perf_counter() - t)
        outs.append(f"{res.outcome}@{res.end_time}")
    print(f"run_episode(mirl-t, world='physics'), 5 seeds: CPU median {np.median(cpus):.1f} "
          f"s (max {max(cpus):.1f}), wall median {np.median(walls):.1f} s (max "
          f"{max(walls):.1f}); {', '.join(outs)}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--steps", type=int, default=750)
    ap.add_argument("--skip-speed", action="store_true")
    args = ap.parse_args()
    for name in ("boyd2-healthy", "boyd2"):
        calibration(name, args.seeds, args.steps)
    if not args.skip_speed:
        speed()


if __name__ == "__main__":
    main()
