"""Paired comparison of two fig4a sweeps run on the same seeds (run i of every condition uses
run_seed(base seed, i)): the published protocol against the adaptive rule with re-learning,
per condition; and the calibration of the stated P(success) per decile.

    mirl experiment fig4a --runs 200 --workers 2 --out results/published
    mirl experiment fig4a --runs 200 --workers 2 --go-rule adaptive --relearn \
        --out results/adaptive
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


def main(first: str, second: str) -> None:
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
    went = [r for r in b.values() if r.get("ps") is not None]
    print()
    print(f"calibration of the second ({len(went)} runs where L went and stated a probability)")
    print()
    print("| stated | runs | mean stated | realised success |")
    print("| --- | --- | --- | --- |")
    for lo in range(10):
        rows = [r for r in went if lo / 10 <= r["ps"] < (lo + 1) / 10 or (lo == 9 and r["ps"] >= 1)]
        if rows:
            ms = sum(r["ps"] for r in rows) / len(rows)
            ok = sum(r["outcome"] == "success" for r in rows) / len(rows)
            print(f"| {lo / 10:.1f}–{(lo + 1) / 10:.1f} | {len(rows)} | {ms:.3f} | {ok:.3f} |")
    if went:
        ms = sum(r["ps"] for r in went) / len(went)
        ok = sum(r["outcome"] == "success" for r in went) / len(went)
        print(f"| all | {len(went)} | {ms:.3f} | {ok:.3f} |")
    per_method: dict[str, list[dict]] = defaultdict(list)
    for key, r in b.items():
        if r.get("ps") is not None:
            per_method[f"{key[0]} {key[1]:g}"].append(r)
    for name, rows in sorted(per_method.items()):
        ms = sum(r["ps"] for r in rows) / len(rows)
        ok = sum(r["outcome"] == "success" for r in rows) / len(rows)
        print(f"| {name} | {len(rows)} | {ms:.3f} | {ok:.3f} |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
