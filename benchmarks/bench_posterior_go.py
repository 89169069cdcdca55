"""The stated chance over a posterior of L's models, and the go rule that acts on it, run by run
on the same seeds as today's rule.

    python benchmarks/bench_posterior_go.py --base 7000 --runs 100 --out odds.jsonl
    python benchmarks/bench_posterior_go.py --out odds.jsonl --report --plot reliability.png

Run i is ``run_episode(scenario, method, seed=run_seed(BASE, i))`` under the default protocol
(``mirl run``'s; ``--obs-steps 300`` observes a fixed 300 steps, as Fig. 4a does), once with the
``adaptive`` go rule (today's decisions; it states both the posterior-averaged chance and its
point models') and once with ``adaptive-posterior`` (``--rules`` picks). Each run is one JSON line
(its outcome, go time, the stated chance, its 5–95 % interval, the point models' chance, the
averaged chance before calibration, the fraction of states L sees, the patrollers it had never
seen when it went, the steps its belief found impossible and the run's CPU seconds); a run
already in ``--out`` is not run again, so a long measurement can be split over processes
(``--first``, ``--runs``) and resumed. The report splits the runs where L went by whether it
had seen every patroller, and by whether it had seen something its models call impossible
(``filter_fallbacks``).

The report: per rule, success and timeouts; where L went, the mean stated chance (posterior and
point) against the realised rate with standard errors, the Brier scores, and the deciles of the
stated chance with their counts; the posterior rule paired against today's by seed (wins,
losses, two-sided sign test); the CPU per run.
"""

from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.stats import binomtest  # noqa: E402

from mirl.experiments.conditions import Condition, run_seed  # noqa: E402
from mirl.experiments.episode import run_episode  # noqa: E402
from mirl.experiments.options import RunProtocol  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="boyd2")
    ap.add_argument("--method", default="mirl-t")
    ap.add_argument("--observability", type=float, default=0.14)
    ap.add_argument("--world", default="grid")
    ap.add_argument("--obs-steps", type=int, default=None, help="a fixed observation time")
    ap.add_argument("--rules", default="adaptive,adaptive-posterior")
    ap.add_argument("--base", type=int, default=7000, help="run i is seeded run_seed(BASE, i)")
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--out", required=True)
    ap.add_argument("--report", action="store_true", help="only report what --out holds")
    ap.add_argument("--plot", default=None, help="draw the reliability diagram to this file")
    ap.add_argument("--panels", nargs="+", default=None, metavar="FILE.jsonl",
                    help="with --plot: one panel per file (its name the title), the first rule's "
                    "runs; --out is then only the first file")  # fmt: skip
    args = ap.parse_args()
    if args.panels:
        plot_panels(args.panels, args.plot or "panels.png")
        return
    if not args.report:
        measure(args)
    with open(args.out) as f:
        rows = [json.loads(line) for line in f]
    report(rows)
    if args.plot:
        plot(rows, args.plot)


def _reliability(ax, went: list[dict]) -> np.ndarray:
    """Realised against stated, per decile, for the posterior and the point models' chance."""
    y = np.array([r["outcome"] == "success" for r in went], dtype=float)
    for key, name, colour in (("stated", "stated", "C0"), ("point", "point models'", "C3")):
        x = np.array([r[key] for r in went])
        k = np.minimum((x * 10).astype(int), 9)
        d = [j for j in range(10) if (k == j).any()]
        ax.scatter([x[k == j].mean() for j in d], [y[k == j].mean() for j in d],
                   s=[12 * (k == j).sum() for j in d], c=colour, alpha=0.7,
                   label=f"{name}: {x.mean():.2f} stated")  # fmt: skip
    ax.plot([0, 1], [0, 1], "k:", lw=1)
    ax.set(xlim=(0, 1), ylim=(0, 1), xlabel="stated chance (decile mean)",
           ylabel="realised success")  # fmt: skip
    ax.legend(loc="upper left", fontsize=8)
    return y


def plot_panels(paths: list[str], out: str, columns: int = 4) -> None:
    """One reliability diagram per file of runs (a method and view each), on one figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows_of = [[json.loads(line) for line in open(p)] for p in paths]
    n_rows = -(-len(paths) // columns)
    fig, axes = plt.subplots(n_rows, columns, figsize=(3.6 * columns, 3.6 * n_rows),
                             squeeze=False)  # fmt: skip
    for ax, path, rows in zip(axes.flat, paths, rows_of, strict=False):
        rule = rows[0]["rule"]
        went = [r for r in rows if r["rule"] == rule and r["stated"] is not None]
        y = _reliability(ax, went)
        name = os.path.splitext(os.path.basename(path))[0]
        ax.set_title(f"{name}: {len(went)} runs, {y.mean():.2f} realised", fontsize=9)
    for ax in list(axes.flat)[len(paths):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=100)


def plot(rows: list[dict], path: str) -> None:
    """The reliability diagram: per rule, the realised rate against the mean stated chance of
    each decile (posterior and point models'), the marker's area its runs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rules = sorted({r["rule"] for r in rows})
    fig, axes = plt.subplots(1, len(rules), figsize=(4.2 * len(rules), 4.2), squeeze=False)
    for ax, rule in zip(axes[0], rules, strict=True):
        went = [r for r in rows if r["rule"] == rule and r["stated"] is not None]
        y = _reliability(ax, went)
        ax.set_title(f"{rule}: {len(went)} runs, {y.mean():.2f} realised")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def measure(args) -> None:
    scenario = Condition(args.method, args.scenario, args.observability).scenario_object()
    view = float(scenario.domain.visible_states(args.observability).mean())  # as the run's
    done = set()
    if os.path.exists(args.out):
        with open(args.out) as f:
            done = {(r["rule"], r["run"]) for r in map(json.loads, f)}
    fixed = {}
    if args.obs_steps is not None:
        fixed = {"obs_steps": args.obs_steps, "watch_until_seen": None}
    with open(args.out, "a") as out:
        for i in range(args.first, args.first + args.runs):
            for rule in args.rules.split(","):
                if (rule, i) in done:
                    continue
                protocol = RunProtocol(go_rule=rule, **fixed)
                r = run_episode(
                    scenario, args.method, seed=run_seed(args.base, i),
                    observability=args.observability, protocol=protocol, world=args.world,
                )  # fmt: skip
                row = {
                    "rule": rule, "run": i, "base": args.base, "outcome": r.outcome,
                    "go": r.go_time, "stated": r.predicted_success,
                    "interval": r.predicted_success_interval,
                    "point": r.predicted_success_point,
                    "averaged": r.predicted_success_averaged,
                    "averaged_interval": r.predicted_success_interval_averaged,
                    "cpu": r.timings["cpu"],
                    "method": args.method, "scenario": args.scenario, "world": args.world,
                    "observability": args.observability, "view": view,
                    "obs_steps": args.obs_steps, "never_seen": list(r.never_seen),
                    "filter_fallbacks": r.filter_fallbacks,
                }  # fmt: skip
                print(json.dumps(row), file=out, flush=True)


def _mean_se(x: np.ndarray) -> str:
    return f"{x.mean():.3f} ± {x.std(ddof=1) / np.sqrt(len(x)):.3f}"


def report(rows: list[dict]) -> None:
    by_rule: dict[str, dict[int, dict]] = {}
    for r in rows:
        by_rule.setdefault(r["rule"], {})[r["run"]] = r
    for rule, runs in by_rule.items():
        rs = [runs[i] for i in sorted(runs)]
        y = np.array([r["outcome"] == "success" for r in rs], dtype=float)
        print(f"\n## {rule}: {len(rs)} runs (seed base {rs[0]['base']})")
        print(f"success {_mean_se(y)}, timeouts "
              f"{np.mean([r['outcome'] == 'timeout' for r in rs]):.3f}, "
              f"CPU per run {np.mean([r['cpu'] for r in rs]):.2f} s")  # fmt: skip
        went = [r for r in rs if r["stated"] is not None]
        if not went:
            continue
        s = np.array([r["stated"] for r in went])
        pt = np.array([r["point"] for r in went])
        yw = np.array([r["outcome"] == "success" for r in went], dtype=float)
        print(f"\nwhere L went ({len(went)} runs): realised {_mean_se(yw)}\n")
        print("| chance | mean stated | stated − realised | Brier |")
        print("| --- | --- | --- | --- |")
        for name, x in (("posterior (stated)", s), ("point models'", pt)):
            print(f"| {name} | {x.mean():.3f} | {_mean_se(x - yw)} | "
                  f"{np.mean((x - yw) ** 2):.3f} |")  # fmt: skip
        if all("never_seen" in r for r in went):  # the chance's assumption about a robot
            unseen = np.array([bool(r["never_seen"]) for r in went])
            for name, sel in (("every patroller seen", ~unseen), ("one never seen", unseen)):
                if sel.sum() > 1:
                    print(f"\n{name} when L went: {int(sel.sum())} runs, stated − realised "
                          f"{_mean_se(s[sel] - yw[sel])}, point models' − realised "
                          f"{_mean_se(pt[sel] - yw[sel])}")  # fmt: skip
        if all(r.get("filter_fallbacks") is not None for r in went):  # L's models contradicted
            odd = np.array([r["filter_fallbacks"] > 0 for r in went])
            for name, sel in (("no sighting its models call impossible", ~odd),
                              ("some sighting its models call impossible", odd)):  # fmt: skip
                if sel.sum() > 1:
                    print(f"\n{name}: {int(sel.sum())} runs, stated − realised "
                          f"{_mean_se(s[sel] - yw[sel])}")
        lo = np.array([r["interval"][0] for r in went])
        hi = np.array([r["interval"][1] for r in went])
        print(f"\nmean 5–95 % interval width {np.mean(hi - lo):.3f}; realised rate of runs whose "
              f"interval lies above 0.5: "
              f"{yw[lo > 0.5].mean() if (lo > 0.5).any() else float('nan'):.3f} "
              f"({int((lo > 0.5).sum())} runs)")  # fmt: skip
        for name, x in (("posterior (stated)", s), ("point models'", pt)):
            print(f"\n{name}, by decile:\n\n| decile | runs | mean stated | realised |")
            print("| --- | --- | --- | --- |")
            k = np.minimum((x * 10).astype(int), 9)
            for d in range(10):
                sel = k == d
                if sel.any():
                    print(f"| {d / 10:.1f}–{(d + 1) / 10:.1f} | {int(sel.sum())} | "
                          f"{x[sel].mean():.3f} | {yw[sel].mean():.3f} |")  # fmt: skip
    rules = list(by_rule)
    if len(rules) >= 2:
        a, b = by_rule[rules[0]], by_rule[rules[1]]
        common = sorted(set(a) & set(b))
        ya = np.array([a[i]["outcome"] == "success" for i in common])
        yb = np.array([b[i]["outcome"] == "success" for i in common])
        wins, losses = int((yb & ~ya).sum()), int((ya & ~yb).sum())
        p = binomtest(wins, wins + losses).pvalue if wins + losses else 1.0
        ca = np.mean([a[i]["cpu"] for i in common])
        cb = np.mean([b[i]["cpu"] for i in common])
        print(f"\n{rules[1]} against {rules[0]} on {len(common)} seeds: success "
              f"{yb.mean():.3f} vs {ya.mean():.3f}, wins–losses {wins}–{losses} (sign test "
              f"p = {p:.2g}); CPU per run {cb:.2f} s vs {ca:.2f} s ({cb / ca:.2f}×)")  # fmt: skip


if __name__ == "__main__":
    main()
