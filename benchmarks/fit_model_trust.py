"""The weight a verdict gives L's motion models on a record that fails the model check,
measured on held-out atlas runs.

    python benchmarks/fit_model_trust.py --seed 1000 --workers 2 --out DIR
    python benchmarks/fit_model_trust.py --out DIR --report

A record that fails a check (:mod:`mirl.learning.model_check`) gets a verdict from L's models'
draws at weight w and the prior's at 1 - w (:data:`mirl.learning.verdicts.MODEL_TRUST`), so a
statement's confidence is ``w * untempered + (1 - w) * prior``, its probability under the
models alone (``verdict.fit.untempered``) and under the prior. w is the probability that L's
models are right about a record that does not fit them: a rate of the world, not of the models,
so it is measured, on runs the published atlas does not hold — the atlas's design points (all
of them, or its first ``--points``, a random sample of its shuffled design) at another base seed
(``--seed``; the published atlas is base seed 0). Every record that fails a check enters with
its statement's truth; w is the maximum of their Bernoulli likelihood (the log score, a proper
scoring rule), with a 90 % bootstrap interval over runs. Each statement is held fixed as w
moves (the statement is chosen from the mixture, so a far w can choose another; the atlas
re-run on the chosen w measures that).

The runs are stored as ``mirl experiment atlas`` stores them, and ``--resume`` extends an
interrupted sweep; the weight the runs were made with is kept in ``DIR/trust.json``.
``--beyond FILE`` measures the same on ``benchmarks/atlas_beyond.py``'s JSON lines (design
points the atlas does not have), run at the current weight:

    python benchmarks/atlas_beyond.py --seeds 1,2,3,4 --out beyond.jsonl
    python benchmarks/fit_model_trust.py --beyond beyond.jsonl
"""

from __future__ import annotations

import argparse
import json
import sqlite3
from dataclasses import replace
from pathlib import Path

import numpy as np

from mirl.experiments.atlas import DATA_PATHS
from mirl.experiments.conditions import get_experiment
from mirl.experiments.sweep import run_experiment
from mirl.learning.verdicts import MODEL_TRUST
from mirl.viz.verdicts import VerdictItem, expected_calibration_error


def _stored_metrics(out: Path) -> list[dict]:
    """The stored runs' metrics: a sweep's store, or atlas_beyond.py's JSON lines."""
    if out.is_file():
        return [json.loads(line) for line in out.read_text().splitlines() if line.strip()]
    con = sqlite3.connect(f"file:{out / 'results.sqlite'}?mode=ro", uri=True)
    return [json.loads(text) for (text,) in con.execute("SELECT metrics FROM runs")]


def misfit_verdicts(out: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per verdict on a record that failed a check: its run, its truth, its confidence, and
    its probability under L's models alone."""
    run, right, conf, models = [], [], [], []
    for i, m in enumerate(_stored_metrics(out)):
        for key in m:
            if not key.startswith("untempered."):
                continue
            _, path, robot = key.split(".")
            assert path in DATA_PATHS
            run.append(i)
            right.append(int(m[f"right.{path}.{robot}"]))
            conf.append(float(m[f"confidence.{path}.{robot}"]))
            models.append(float(m[key]))
    return tuple(np.array(v) for v in (run, right, conf, models))  # type: ignore[return-value]


GRID = np.linspace(0.0, 1.0, 1001)


def best_weight(right: np.ndarray, models: np.ndarray, prior: np.ndarray) -> float:
    """The w in [0, 1] (steps of 0.001) of the largest Bernoulli log-likelihood."""
    c = np.clip(GRID[:, None] * models + (1 - GRID[:, None]) * prior, 1e-6, 1 - 1e-6)
    ll = (right * np.log(c) + (1 - right) * np.log1p(-c)).sum(axis=1)
    return float(GRID[int(np.argmax(ll))])


def ece(conf: np.ndarray, right: np.ndarray) -> float:
    """The reports' expected calibration error (its bins) of statements at ``conf`` that are
    ``right`` (:func:`mirl.viz.verdicts.expected_calibration_error`)."""
    return expected_calibration_error(
        [VerdictItem("", 0.0, None, "", 0, (), float(c), (), bool(r))
         for c, r in zip(conf, right, strict=True)]
    )  # fmt: skip


def report(out: Path, used: float) -> None:
    run, right, conf, models = misfit_verdicts(out)
    prior = (conf - used * models) / (1 - used)
    w = best_weight(right, models, prior)
    rng = np.random.default_rng(0)
    runs = np.unique(run)
    boot = []
    for _ in range(1000):
        pick = rng.choice(runs, len(runs))
        idx = np.concatenate([np.flatnonzero(run == r) for r in pick])
        boot.append(best_weight(right[idx], models[idx], prior[idx]))
    lo, hi = np.quantile(boot, [0.05, 0.95])
    print(f"{len(runs)} runs with a record that fails a check, {len(right)} verdicts "
          f"(made at w = {used}); right {right.mean():.3f}")  # fmt: skip
    print(f"maximum-likelihood w = {w:.3f} (90% bootstrap interval over runs {lo:.3f}-{hi:.3f})")
    for x in sorted({used, w}):
        c = x * models + (1 - x) * prior
        print(f"  at w = {x:.3f}: mean stated {c.mean():.3f}, ECE {ece(c, right):.3f}, "
              f"stated >= 0.9: {int((c >= 0.9).sum())} ({int(((c >= 0.9) & (right == 0)).sum())} "
              f"false)")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, help="the design's first points (default: all)")
    ap.add_argument("--seed", type=int, default=1000, help="base seed (default 1000)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--report", action="store_true", help="only report what --out holds")
    ap.add_argument("--beyond", type=Path, help="report atlas_beyond.py's JSON lines instead")
    args = ap.parse_args()
    if args.beyond is not None:  # run at the current weight, as the probe records nothing else
        report(args.beyond, MODEL_TRUST)
        return
    if args.out is None:
        ap.error("--out is required without --beyond")
    out = Path(args.out)
    if not args.report:
        if args.seed == 0:
            ap.error("--seed: 0 is the published atlas's base seed; hold it out")
        atlas = get_experiment("atlas")
        args.points = len(atlas.conditions) if args.points is None else args.points
        if not 1 <= args.points <= len(atlas.conditions):
            ap.error(f"--points: between 1 and {len(atlas.conditions)}, got {args.points}")
        sample = replace(atlas, conditions=atlas.conditions[: args.points])
        out.mkdir(parents=True, exist_ok=True)
        trust = out / "trust.json"
        if trust.exists() and json.loads(trust.read_text())["model_trust"] != MODEL_TRUST:
            ap.error(f"{trust}: its runs were made at another MODEL_TRUST")
        trust.write_text(json.dumps({"model_trust": MODEL_TRUST}) + "\n")
        run_experiment(
            sample, str(out),
            {"workers": args.workers, "resume": args.resume, "base_seed": args.seed},
        )  # fmt: skip
    report(out, json.loads((out / "trust.json").read_text())["model_trust"])


if __name__ == "__main__":
    main()
