"""Paired comparison of two fig4a sweeps run on the same seeds (run i of every condition uses
run_seed(base seed, i)): the published protocol against the adaptive rule with re-learning
(the default), per condition; and the calibration of the stated P(success) per decile.

    mirl experiment fig4a --runs 200 --workers 2 --go-rule value --learn-once \
        --out results/published
    mirl experiment fig4a --runs 200 --workers 2 --out results/adaptive
    python benchmarks/paired_go_rule.py results/published/results.sqlite \
        results/adaptive/results.sqlite

Either argument may also be a JSON-lines file of runs ({"m", "d", "p", "i", "outcome", "ps",
"cpu"} per line). Prints markdown tables: success, detected and timed-out rates of both, wins
(only the second succeeded) – losses (only the first), the two-sided sign test p, the CPU-time
ratio of a run; then the stated probability against the realised success per decile.
"""

from __future__ import annotations

import json
import sqlite3
import sys
from collections import defaultdict
from math import comb


def load(path: str) -> dict[tuple, dict]:
    runs: dict[tuple, dict] = {}
    if path.endswith(".sqlite"):
        con = sqlite3.connect(path)
        rows = con.execute(
            "select method, observability, p, run, outcome, metrics, timings from runs "
            "where error is null or error = ''"
        )
        for m, d, p, i, outcome, metrics, timings in rows:
            mt = json.loads(metrics or "{}")
            tm = json.loads(timings or "{}")
            runs[(m, float(d), p, int(i))] = {
                "outcome": outcome, "ps": mt.get("predicted_success"), "cpu": tm.get("cpu"),
            }  # fmt: skip
        return runs
    for line in open(path):
        r = json.loads(line)
        runs[(r["m"], float(r["d"]), r["p"], int(r["i"]))] = r
    return runs


def sign_test(wins: int, losses: int) -> float:
    n = wins + losses
    if n == 0:
        return 1.0
    k = min(wins, losses)
    return min(1.0, 2 * sum(comb(n, j) for j in range(k + 1)) / 2**n)


def rates(rows: list[dict]) -> str:
    n = len(rows)
    return " / ".join(f"{sum(r['outcome'] == o for r in rows) / n:.2f}" for o in
                      ("success", "detected", "timeout"))  # fmt: skip


def main(first: str, second: str, figure: str | None = None) -> None:
    a, b = load(first), load(second)
    by_cond: dict[tuple, list[tuple]] = defaultdict(list)
    for key in sorted(set(a) & set(b), key=str):
        by_cond[key[:3]].append(key)
    print("| method | view | n | first: success / detected / timeout | second | wins–losses "
          "| sign test p | CPU ratio |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for cond, keys in sorted(by_cond.items(), key=lambda kv: (kv[0][1], str(kv[0]))):
        ra, rb = [a[k] for k in keys], [b[k] for k in keys]
        wins = sum(
            x["outcome"] != "success" and y["outcome"] == "success"
            for x, y in zip(ra, rb, strict=True)
        )
        losses = sum(
            x["outcome"] == "success" and y["outcome"] != "success"
            for x, y in zip(ra, rb, strict=True)
        )
        ca = [x["cpu"] for x in ra if x.get("cpu")]
        cb = [y["cpu"] for y in rb if y.get("cpu")]
        ratio = (sum(cb) / len(cb)) / (sum(ca) / len(ca)) if ca and cb else float("nan")
        name = cond[0] if cond[2] is None else f"{cond[0]} (p={cond[2]:g})"
        print(f"| {name} | {cond[1]:g} | {len(keys)} | {rates(ra)} | {rates(rb)} | "
              f"{wins}–{losses} | {sign_test(wins, losses):.3f} | {ratio:.2f} |")  # fmt: skip
    calibration(b, figure)


def _name(key: tuple) -> str:
    m, d, p = key[:3]
    return (m if p is None else f"{m} (p={p:g})") + f" {d:g}"


def calibration(b: dict[tuple, dict], figure: str | None = None) -> None:
    """The stated P(success) of the runs where L went against their realised success: per
    decile, pooled, and per condition (mean stated, realised ± one binomial s.e.)."""
    went = [(k, r) for k, r in b.items() if r.get("ps") is not None]
    print()
    print(f"calibration of the second ({len(went)} runs where L went and stated a probability)")
    print()
    print("| stated | runs | mean stated | realised success |")
    print("| --- | --- | --- | --- |")
    deciles = []
    for lo in range(10):
        rows = [
            r for _, r in went if lo / 10 <= r["ps"] < (lo + 1) / 10 or (lo == 9 and r["ps"] >= 1)
        ]
        if rows:
            ms = sum(r["ps"] for r in rows) / len(rows)
            ok = sum(r["outcome"] == "success" for r in rows) / len(rows)
            deciles.append((ms, ok, len(rows)))
            print(f"| {lo / 10:.1f}–{(lo + 1) / 10:.1f} | {len(rows)} | {ms:.3f} | {ok:.3f} |")
    groups: dict[str, list[dict]] = defaultdict(list)
    for key, r in went:
        groups["all"].append(r)
        groups[_name(key)].append(r)
    print()
    print("| runs of | went | mean stated | realised success ± s.e. | difference |")
    print("| --- | --- | --- | --- | --- |")
    for name, rows in sorted(groups.items(), key=lambda kv: (kv[0] != "all", kv[0])):
        n = len(rows)
        ms = sum(r["ps"] for r in rows) / n
        ok = sum(r["outcome"] == "success" for r in rows) / n
        se = (ok * (1 - ok) / n) ** 0.5
        print(f"| {name} | {n} | {ms:.3f} | {ok:.3f} ± {se:.3f} | {ms - ok:+.3f} |")
    if figure and deciles:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5.2, 4.6))
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
        curves = {"every method": [r for _, r in went]}
        for method in ("oracle", "mirl-t"):
            curves[method] = [r for k, r in went if k[0] == method]
        for (name, rows), colour in zip(curves.items(), ("C0", "C2", "C3"), strict=False):
            points = _deciles(rows)
            if not points:
                continue
            ms, ok, n = (list(v) for v in zip(*points, strict=True))
            err = [(o * (1 - o) / k) ** 0.5 for o, k in zip(ok, n, strict=True)]
            ax.errorbar(ms, ok, yerr=err, fmt="o-", color=colour, capsize=3, ms=4,
                        label=f"{name} ({len(rows)} runs)")  # fmt: skip
        ax.set_xlabel("stated P(success) when L went (decile means)")
        ax.set_ylabel("realised success (± 1 s.e.)")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_title("Calibration of the stated chance", fontsize=10)
        ax.legend(loc="upper left", fontsize=8)
        fig.tight_layout()
        fig.savefig(figure, dpi=120)
        print(f"\nfigure: {figure}")


def _deciles(rows: list[dict]) -> list[tuple[float, float, int]]:
    out = []
    for lo in range(10):
        sel = [r for r in rows if lo / 10 <= r["ps"] < (lo + 1) / 10 or (lo == 9 and r["ps"] >= 1)]
        if sel:
            ms = sum(r["ps"] for r in sel) / len(sel)
            ok = sum(r["outcome"] == "success" for r in sel) / len(sel)
            out.append((ms, ok, len(sel)))
    return out


if __name__ == "__main__":
    args = sys.argv[1:]
    fig = None
    if "--figure" in args:
        i = args.index("--figure")
        fig = args[i + 1]
        del args[i : i + 2]
    main(args[0], args[1], fig)
