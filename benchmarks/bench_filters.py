"""The two pair filters' steps against their plain forms, side by side in one process: the
equilibrium weighing's exact joint filter against the reference kept in
``tests/references/joint_filter.py``, and the planner's meeting step (CSR maps for scipy's
mat-vec kernel) against the ``np.bincount`` form it replaced. Both pairs agree bit for bit
(checked here as well as in the tests).

    python benchmarks/bench_filters.py [--seeds 3] [--repeats 3]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the CLI does, before numpy loads

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.references
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_speed import _best  # noqa: E402  (CPU seconds, best of n)

from mirl.experiments.episode import run_episode  # noqa: E402
from mirl.learning.equilibria import joint_log_likelihood  # noqa: E402
from mirl.learning.learn import learn  # noqa: E402
from mirl.planning.pair_sums import MeetingStep  # noqa: E402
from mirl.simulation.grid import simulate  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from tests.references.joint_filter import reference_joint_log_likelihood  # noqa: E402


def _pair_of(sc, degree: float, seed: int):
    """(domain, series, learned policies, learned T) of one boyd2 record."""
    d = sc.domain
    obs = simulate(sc, 450, seed=seed, observability=degree).observations
    res = learn(obs, sc, "mirl-t", observability=degree, random_state=seed, score=False)
    series = [obs.state_series(d, i) for i in range(2)]
    return d, series, [r.policy for r in res.robots], [r.transitions for r in res.robots]


def weighing(seeds: int, repeats: int) -> None:
    sc = load_scenario("boyd2")
    print("1. exact joint filter, boyd2, 450 steps, learned models, 3 candidates (CPU s, best of "
          f"{repeats}, summed over {seeds} seeds)")  # fmt: skip
    for degree in (0.14, 0.5, 1.0):
        vis = sc.domain.visible_states(degree)
        ours = ref = 0.0
        for seed in range(seeds):
            pair = _pair_of(sc, degree, seed)
            for e in sc.game.equilibria():
                t_new, a = _best(lambda: joint_log_likelihood(*pair, e, vis), repeats)  # noqa: B023
                t_ref, b = _best(lambda: reference_joint_log_likelihood(*pair, e, vis), repeats)  # noqa: B023
                assert a == b, (a, b)
                ours, ref = ours + t_new, ref + t_ref
        print(f"   observability {degree:<4}  ours {ours:6.3f} s  plain {ref:6.3f} s  "
              f"{ref / ours:.2f}x")  # fmt: skip


def _planner_meeting_step() -> MeetingStep:
    """The meeting step of the first pair filter a boyd2 run builds (seed 0)."""
    import mirl.planning.belief as belief

    made = []
    original = belief.MeetingStep.__init__

    def keep(self, *args):
        original(self, *args)
        made.append(self)

    belief.MeetingStep.__init__ = keep
    try:
        run_episode(load_scenario("boyd2"), seed=0, protocol={"watch_until_seen": None})
    finally:
        belief.MeetingStep.__init__ = original
    return made[0]


def meeting_step(repeats: int) -> None:
    step = _planner_meeting_step()
    S2 = int(step.at.max()) + 1
    met = np.random.default_rng(0).random(len(step.at))

    def plain(out_t):  # the np.bincount form
        x = np.bincount(step._dst1, step._coef1 * met[step._src1], len(step._x_at))
        y = np.bincount(step._dst2, step._coef2 * x[step._src2], len(step._out_at))
        np.add.at(out_t, step._out_at, y)

    size = max(S2, int(step._out_at.max()) + 1)
    a, b = np.zeros(size), np.zeros(size)
    step.add_to(a, met)
    plain(b)
    assert np.array_equal(a, b)
    n = 2000
    t_new, _ = _best(lambda: [step.add_to(a, met) for _ in range(n)], repeats)
    t_ref, _ = _best(lambda: [plain(b) for _ in range(n)], repeats)
    print(f"2. planner meeting step, boyd2 ({len(step.at)} meeting states; µs per call, best of "
          f"{repeats}): CSR maps {t_new / n * 1e6:.1f}, bincount {t_ref / n * 1e6:.1f}, "
          f"{t_ref / t_new:.2f}x")  # fmt: skip


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    weighing(a.seeds, a.repeats)
    meeting_step(a.repeats)
