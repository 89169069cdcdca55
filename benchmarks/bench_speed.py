"""Speed side by side, in one run:

1. start-up: ``mirl run`` (boyd2, ``--obs-steps 300``) against a bare
   ``python -c "import numpy, scipy.sparse, scipy.optimize"`` (target ≤ 1.5×), paired and
   alternated, wall and CPU medians; beside them ``mirl --version`` and ``mirl show-map`` (the
   start-up proper: imports and parsing) and the CPU the run reports for its own work;
2. value iteration and 200-step backward induction against pymdptoolbox on the generated
   30/60/80 offices, setup and sweeps reported separately (targets: ≥ 100× with setup on 60 × 60,
   sweeps ≥ 1×), with the policies compared;
3. ``mirl learn`` (mirl-t, 450 steps at 0.14) on offices of 20–80 cells a side with two
   patrollers: CPU and wall seconds per size and the fitted exponent of CPU time in S.

    pip install -e ".[bench]"   # pymdptoolbox, for part 2 only
    python benchmarks/bench_speed.py [--repeats 5] [--sizes 20 30 40 60 80] [--skip-startup]

``--accuracy`` adds the factored equilibrium weighing against the exact joint filter where both
run (boyd2 and the 20 × 20 office, three seeds each).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the CLI does, before numpy loads

import numpy as np  # noqa: E402

from mirl.mdp import TabularMDP, actions_first, backward_induction, value_iteration  # noqa: E402
from mirl.world.catalog import load_map  # noqa: E402
from mirl.world.domain import PatrolDomain  # noqa: E402
from mirl.world.motion import transition_matrix  # noqa: E402
from mirl.world.scenario import HEALTHY_PROBABILITIES  # noqa: E402

MIRL = [sys.executable, "-m", "mirl.cli"]


# ---- 1. start-up ---------------------------------------------------------------------------
def _timed(cmd: list[str]) -> tuple[float, float]:
    """(wall, CPU) seconds of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _compile_mirl() -> str:
    """Write mirl's bytecode caches, as ``pip install`` does for numpy and scipy: an editable
    install compiles mirl at its first import, and where ``PYTHONDONTWRITEBYTECODE`` is set (as
    in some sandboxes) at every start, ~0.1 s that numpy and scipy, compiled when installed,
    never pay. Returns what was done, for the report."""
    import compileall

    import mirl

    package = Path(mirl.__file__).parent
    ok = compileall.compile_dir(str(package), quiet=1)
    return f"bytecode of {package} {'written' if ok else 'NOT all written'}"


def _run_work(seed: str) -> float:
    """CPU seconds ``mirl run`` itself reports for observing, learning, planning and going."""
    out = subprocess.run(MIRL + ["run", "--obs-steps", "300", "--seed", seed, "--json"],
                         check=True, capture_output=True, text=True).stdout  # fmt: skip
    return float(json.loads(out)["timings"]["cpu"])


def startup(repeats: int) -> None:
    bare = [sys.executable, "-c", "import numpy, scipy.sparse, scipy.optimize"]
    compiled = _compile_mirl()
    commands = {
        "bare imports": lambda k: bare,
        "mirl --version": lambda k: MIRL + ["--version"],
        "mirl show-map": lambda k: MIRL + ["show-map", "boyd2"],
        "mirl run": lambda k: MIRL + ["run", "--obs-steps", "300", "--seed", str(k % 10)],
    }
    runs: dict[str, list[tuple[float, float]]] = {k: [] for k in commands}
    for k in range(repeats):  # alternate, so load changes hit both alike
        for name, cmd in commands.items():
            runs[name].append(_timed(cmd(k)))
    work = [_run_work(str(k % 10)) for k in range(repeats)]
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in runs.items()}  # fmt: skip
    print(f"1. start-up ({repeats} paired runs, medians; mirl run seeds 0..{repeats - 1})")
    print(f"   ({compiled} first)")
    w0, c0 = med["bare imports"]
    for k, (w, c) in med.items():
        print(f"   {k:<14} wall {w:6.3f} s   CPU {c:6.3f} s   / bare: wall {w / w0:.2f}x, "
              f"CPU {c / c0:.2f}x")  # fmt: skip
    w1, c1 = med["mirl run"]
    print(f"   mirl run / bare imports: wall {w1 / w0:.2f}x, CPU {c1 / c0:.2f}x (target <= 1.5x)")
    print(f"   of which the run's own work (observe, learn, plan, go; its --json 'cpu'): "
          f"{statistics.median(work):.3f} s CPU")  # fmt: skip


# ---- 2. value iteration and backward induction against pymdptoolbox ------------------------
def _office_mdp(size: int):
    d = PatrolDomain(load_map(f"office-{size}x{size}"))
    T = transition_matrix(d, HEALTHY_PROBABILITIES)
    R = d.rewards(np.linspace(1.0, 0.1, len(d.reward_feature_names)))
    return d, T, R


def _best(fn, repeats: int = 3):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def solvers(sizes: list[int], horizon: int = 200) -> None:
    import warnings

    warnings.filterwarnings("ignore", module="mdptoolbox")  # its own sparse-comparison notes
    try:
        import mdptoolbox.mdp as mdpt
    except ImportError:
        print("2. skipped: pymdptoolbox is not installed (pip install -e '.[bench]')")
        return

    print(f"2. value iteration (VI) and {horizon}-step backward induction (BI) vs pymdptoolbox "
          "(CPU s, best of 3; setup = everything before the first sweep)")  # fmt: skip
    print(f"   {'office':<8}{'S':>6} {'':4}{'mirl setup':>11}{'sweep ms':>9}{'total':>8}"
          f" | {'mdpt setup':>10}{'sweep ms':>9}{'total':>8} | {'x total':>7}{'x sweep':>8}"
          "  policies")  # fmt: skip
    for size in sizes:
        _compare(size, horizon, mdpt)


def _compare(size: int, horizon: int, mdpt) -> None:
    """One office: VI and BI, ours and pymdptoolbox's, one row each."""
    import scipy.sparse as sp

    d, T, R = _office_mdp(size)
    S, A = d.n_states, d.n_actions
    P = [sp.csr_matrix(T[np.arange(S) * A + a]) for a in range(A)]  # their input format
    t_setup, mdp = _best(lambda: TabularMDP(T, R, 0.95))
    t_af, _ = _best(lambda: actions_first(mdp.transitions, A))
    t_vi, res = _best(lambda: value_iteration(mdp))
    m_setup, m_run, vi = _setup_and_run(
        lambda: mdpt.ValueIteration(P, R, 0.95, epsilon=1e-8, max_iter=10_000)
    )
    ok = _agree(res.q_values, np.asarray(vi.policy))
    ours_setup = t_setup + t_af
    ours_sweep = (t_vi - t_af) / res.iterations
    m_sweep = m_run / vi.iter
    _row(size, S, "VI", ours_setup, ours_sweep, t_setup + t_vi, m_setup, m_sweep,
         m_setup + m_run, ok)  # fmt: skip
    t_bi, bi = _best(lambda: backward_induction(T, R, horizon, discount=0.95))
    m_bsetup, m_brun, fh = _setup_and_run(lambda: mdpt.FiniteHorizon(P, R, 0.95, horizon))
    m_btotal = m_bsetup + m_brun
    ok = _agree(bi.q_values[0], np.asarray(fh.policy)[:, 0])
    _row(size, S, "BI", t_af, (t_bi - t_af) / horizon, t_bi, m_bsetup, m_brun / horizon,
         m_btotal, ok)  # fmt: skip


def _setup_and_run(make, repeats: int = 3):
    """pymdptoolbox: (best constructor CPU s, best run() CPU s, the last solver)."""
    setup = run = np.inf
    solver = None
    for _ in range(repeats):
        t0 = time.process_time()
        solver = make()
        t1 = time.process_time()
        solver.run()
        setup, run = min(setup, t1 - t0), min(run, time.process_time() - t1)
    return setup, run, solver


def _agree(q: np.ndarray, their_policy: np.ndarray) -> str:
    """Share of states where their action is one of ours within 1e-6 of the best."""
    best = q.max(axis=1)
    ok = q[np.arange(len(q)), their_policy] >= best - 1e-6 * np.maximum(1.0, np.abs(best))
    return f"{ok.mean():.1%} agree"


def _row(size, S, kind, o_setup, o_sweep, o_total, m_setup, m_sweep, m_total, ok) -> None:
    print(f"   {size:>2}x{size:<5}{S:>6} {kind:<4}{o_setup:>11.4f}{o_sweep * 1e3:>9.3f}"
          f"{o_total:>8.3f} | {m_setup:>10.4f}{m_sweep * 1e3:>9.3f}{m_total:>8.3f} | "
          f"{m_total / o_total:>6.0f}x{m_sweep / o_sweep:>7.2f}x  {ok}")  # fmt: skip


# ---- 3. mirl learn on offices ---------------------------------------------------------------
def office_scenario_toml(size: int) -> str:
    """Two patrollers on the generated ``office-{size}x{size}``: paid for moving and for turning
    at dead ends; I starts at the first hallway cell, J (left wheel damaged) half-way along."""
    m = load_map(f"office-{size}x{size}")
    cells = np.argwhere(m.patroller)
    a, b = cells[0], cells[len(cells) // 2]
    return f"""name = "office-{size}-two"
map = "office-{size}x{size}"
observability = 0.14

[reward]
features = [{{ name = "moved", kind = "moved" }}, {{ name = "turn_around", kind = "turn_around" }}]
weights = {{ moved = 1.0, turn_around = 0.3 }}

[[robots]]
name = "I"
start = [{a[0]}, {a[1]}, 0]

[[robots]]
name = "J"
start = [{b[0]}, {b[1]}, 0]
feature_probabilities = {{ left_wheel = 0.70 }}
"""


def learning(sizes: list[int], seeds: int, tmp: Path) -> None:
    print(f"3. mirl learn (mirl-t, 450 steps at 0.14) on offices with two patrollers, {seeds} "
          "seed(s) per size, one BLAS thread; medians")  # fmt: skip
    xs, cpus = [], []
    for size in sizes:
        toml = tmp / f"office{size}.toml"
        toml.write_text(office_scenario_toml(size))
        S = 4 * int(load_map(f"office-{size}x{size}").patroller.sum())
        walls, cpu = [], []
        for seed in range(seeds):
            csv = tmp / f"office{size}_{seed}.csv"
            subprocess.run(MIRL + ["simulate", "--scenario", str(toml), "--steps", "450",
                                   "--seed", str(seed), "--random-starts", "--observations",
                                   str(csv)], check=True, stdout=subprocess.DEVNULL)  # fmt: skip
            w, c = _timed(MIRL + ["learn", "--scenario", str(toml), "--observations", str(csv)])
            walls.append(w)
            cpu.append(c)
        xs.append(S)
        cpus.append(statistics.median(cpu))
        print(f"   office {size}x{size}: S = {S:>5}  CPU {cpus[-1]:6.2f} s  wall "
              f"{statistics.median(walls):6.2f} s", flush=True)  # fmt: skip
    if len(xs) >= 2:
        slope = np.polyfit(np.log(xs), np.log(cpus), 1)[0]
        print(f"   fitted: CPU time ~ S^{slope:.2f} from S = {xs[0]} to {xs[-1]} (target <= ~1.2)")


# ---- accuracy of the factored weighing --------------------------------------------------------
def accuracy(tmp: Path) -> None:
    from mirl.learning.equilibria import joint_log_likelihood
    from mirl.learning.learn import learn
    from mirl.simulation.grid import simulate
    from mirl.world.scenario import load_scenario

    (tmp / "office20.toml").write_text(office_scenario_toml(20))
    print("4. factored vs exact equilibrium weighing (log-likelihood per candidate, weights)")
    for name in ("boyd2", str(tmp / "office20.toml")):
        sc = load_scenario(name)
        d, vis = sc.domain, sc.domain.visible_states(0.14)
        for seed in range(3):
            obs = simulate(sc, 450, seed=seed, observability=0.14, random_starts=True)
            obs = obs.observations
            r = learn(obs, sc, "mirl-t", observability=0.14)
            series = [obs.state_series(d, i) for i in range(2)]
            pol, T = [m.policy for m in r.robots], [m.transitions for m in r.robots]
            out = []
            for mj in (None, 0):
                t0 = time.process_time()
                ll = np.array([joint_log_likelihood(d, series, pol, T, e, vis, max_joint_states=mj)
                               for e in sc.game.equilibria()])  # fmt: skip
                w = np.exp(ll - ll.max())
                out.append((ll, w / w.sum(), time.process_time() - t0))
            (le, we, te), (lf, wf, tf) = out
            print(f"   {sc.name} seed {seed} (S={d.n_states}): best {le.argmax()} vs "
                  f"{lf.argmax()}, max |Δ weight| {np.abs(we - wf).max():.3f}, max |Δ ll| "
                  f"{np.abs(le - lf).max():.2f}, {te:.2f} s vs {tf:.2f} s")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="paired start-up runs")
    ap.add_argument("--solver-sizes", type=int, nargs="+", default=[30, 60, 80])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20, 30, 40, 60, 80])
    ap.add_argument("--seeds", type=int, default=2, help="learn runs per office size")
    ap.add_argument("--skip-startup", action="store_true")
    ap.add_argument("--accuracy", action="store_true")
    args = ap.parse_args()
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    if not args.skip_startup:
        startup(args.repeats)
    solvers(args.solver_sizes)
    with tempfile.TemporaryDirectory() as tmp:
        learning(args.sizes, args.seeds, Path(tmp))
        if args.accuracy:
            accuracy(Path(tmp))
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
