"""Fit the stated chance's held-out calibration (:mod:`mirl.planning.chance_calibration`) from
runs of ``bench_posterior_go.py``, or measure the shipped maps on other runs (those files, or
a sweep's ``results.sqlite``).

    python benchmarks/fit_chance_calibration.py --fit RUNS.jsonl ... [--protocol P] [--write]
    python benchmarks/fit_chance_calibration.py --evaluate RUNS.jsonl ... [--protocol P]

``--fit`` fits one map per method on every run where L went in the files given (each row names
its method, scenario, world, observability and view) and prints them; where the runs come from
two or more seed ranges, how strongly each map is held near the identity is chosen by leaving
one range out (:func:`~mirl.planning.chance_calibration.choose_prior_precision`); ``--write``
stores them in ``src/mirl/data/stated_chance_calibration.json`` as the maps of ``--protocol``
(``mirl-run``, ``mirl run``'s protocol, by default; ``fixed-observation`` for runs of
``bench_posterior_go.py --obs-steps 300``, the experiments' protocol), keeping the other
protocol's and the maps of methods not in the files; the maps apply in the worlds of the runs
they were fitted on. The runs it is fitted on must not be the runs it is reported on: fit on one
seed base, evaluate on another.

``--methods`` keeps the runs of the methods named (a sweep holds every method of its experiment,
the oracle's and the fixed p's among them, which have no map). A run that was stated through a
map and does not record its range before it is taken back through the map that stated it:
``--stated-through MAPS.json`` names that map's file (``git show
REV:src/mirl/data/stated_chance_calibration.json``), else the shipped one is taken to be it.

``--evaluate`` states each run's chance through the shipped map of its method (from the run's
averaged chance, so runs made before the map existed are measured the same way; a run made with
the map states exactly this, and one made with another map keeps its statement unless
``--stated-through`` names that map, when it is restated through the shipped one) and prints,
per method, scenario, world and observability: runs, success, timeouts, the mean stated chance
where L went against the realised rate with its standard error, the deciles with at least 20
runs whose realised rate is more than 0.10 from their mean stated chance, the Hosmer–Lemeshow
test of the deciles, and how often a calibrated statement would keep every such decile within
0.10 at these counts. ``--restate DIR`` writes the runs as stated there, for
``bench_posterior_go.py --panels``.
"""

from __future__ import annotations

import argparse
import json
import sqlite3
from collections import defaultdict
from functools import cache
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from mirl.planning.chance_calibration import (
    CALIBRATION_FILE,
    FIXED_OBSERVATION,
    MIRL_RUN,
    CalibratedProtocol,
    calibrate_chance,
    calibration_maps,
    calibration_protocols,
    choose_prior_precision,
    fit_calibration,
    maps_to_json,
)

TARGET = Path(__file__).resolve().parents[1] / "src" / "mirl" / "data" / CALIBRATION_FILE

# the options (those that differ from mirl run's) each protocol's runs were made under
PROTOCOL_OPTIONS = {MIRL_RUN: {}, FIXED_OBSERVATION: {"watch_until_seen": None}}


def _rows(files: list[str]) -> list[dict]:
    rows = []
    for name in files:
        if name.endswith(".sqlite"):
            rows += _sweep_rows(name)
            continue
        with open(name) as f:
            rows += [json.loads(line) for line in f]
    return rows


@cache
def _named(scenario: str) -> str:
    from mirl.world.scenario import load_scenario

    return load_scenario(scenario).name


def _scenario_name(r: dict) -> str:
    """The name of a row's scenario (a row keeps what the run was given: a name or a file)."""
    return _named(r["scenario"])


def _sweep_rows(path: str) -> list[dict]:
    """A sweep's runs (``mirl experiment … --out DIR``, its ``results.sqlite``) as rows of
    ``bench_posterior_go.py``: a method run with a p other than its default is named with it
    (it has no map), and the view is the scenario's at the run's observability."""
    from mirl.learning.options import DEFAULT_P
    from mirl.world.scenario import load_scenario

    con = sqlite3.connect(path)
    base = int(dict(con.execute("select key, value from meta").fetchall()).get("base_seed", 0))
    query = "select condition_key, method, scenario, observability, p, run, outcome, metrics "
    rows, views = [], {}
    for key, method, scenario, obs, p, i, outcome, metrics in con.execute(
        query + "from runs where error is null or error = ''"
    ):
        m = json.loads(metrics)
        if (scenario, obs) not in views:
            views[scenario, obs] = float(load_scenario(scenario).domain.visible_states(obs).mean())
        stated = m.get("predicted_success")
        lo, hi = m.get("predicted_success_lo"), m.get("predicted_success_hi")
        rows.append({
            "method": method if p is None or p == DEFAULT_P else f"{method} (p={p:g})",
            "scenario": scenario, "world": json.loads(key).get("world", "grid"),
            "observability": obs, "view": views[scenario, obs], "run": i, "base": base,
            "outcome": outcome,
            "stated": stated, "interval": None if lo is None else [lo, hi],
            "point": m.get("predicted_success_point"),
            "averaged": m.get("predicted_success_averaged"), "rule": json.loads(key)["go_rule"],
            "averaged_interval": (
                None if m.get("predicted_success_averaged_lo") is None
                else [m["predicted_success_averaged_lo"], m["predicted_success_averaged_hi"]]
            ),
        })  # fmt: skip
    return rows


def _averaged(r: dict) -> float:
    """The run's chance before any calibration (a run without a map states it as is)."""
    return r["averaged"] if r.get("averaged") is not None else r["stated"]


STATED_THROUGH: dict[str, dict] | None = None
"""The maps that stated the runs (``--stated-through``), by protocol; None: the maps shipped."""
STATED_THROUGH_FILE: str | None = None


def _maps_in(path: str) -> dict[str, dict]:
    """The maps of a calibration file (another revision's ``stated_chance_calibration.json``),
    by protocol and method."""
    from mirl.planning.chance_calibration import ChanceMap

    entries = json.loads(Path(path).read_text(encoding="utf-8"))["protocols"]
    return {
        name: {m: ChanceMap(**fields) for m, fields in entry["methods"].items()}
        for name, entry in entries.items()
    }


def _unmapped_interval(r: dict, protocol: str) -> tuple[float, float]:
    """The run's per-draw interval before any calibration: as the run recorded it, or for a
    mapped run that did not record it (made before the record kept it), taken back through its
    method's map — the one that mapped it: ``--stated-through``'s, or else the one shipped now
    (``protocol``'s, or ``mirl run``'s where that protocol has none for the method)."""
    if r.get("averaged") is None:
        return r["interval"][0], r["interval"][1]
    if r.get("averaged_interval") is not None:
        return r["averaged_interval"][0], r["averaged_interval"][1]
    maps = STATED_THROUGH or {p: calibration_maps(p) for p in (protocol, MIRL_RUN)}
    m = maps[protocol].get(r["method"]) or maps[MIRL_RUN][r["method"]]
    return m.unmapped_interval(r["stated"], tuple(r["interval"]), r["averaged"], r["view"])


def _as_stated(r: dict, protocol: str) -> dict:
    """The run as the shipped maps state it: ``stated`` and ``interval`` through its method's
    map of ``protocol`` where one applies (its world among the maps'), ``averaged`` the average
    they came from; the average, unmapped, where none does. A run that was mapped when it ran
    keeps its statement; one made in a world without maps gets its average back."""
    if r["stated"] is None:
        return r
    fitted = calibration_protocols()[protocol]
    applies = r["method"] in fitted.maps and fitted.applies(r["world"], _scenario_name(r))
    if r.get("averaged") is not None and STATED_THROUGH is not None:  # restated: raw, then mapped
        lo, hi = _unmapped_interval(r, protocol)
        r = {**r, "stated": r["averaged"], "interval": [lo, hi], "averaged": None,
             "averaged_interval": None}  # fmt: skip
    if r.get("averaged") is not None:  # mapped when it ran
        if applies:
            return r
        lo, hi = _unmapped_interval(r, protocol)
        return {
            **r, "stated": r["averaged"], "interval": [lo, hi], "averaged": None,
            "averaged_interval": None,
        }  # fmt: skip
    if not applies:
        return r
    mapped = calibrate_chance(r["method"], r["stated"], tuple(r["interval"]), r["view"], protocol)
    assert mapped is not None
    return {
        **r, "stated": mapped[0], "interval": list(mapped[1]), "averaged": r["stated"],
        "averaged_interval": list(r["interval"]),
    }  # fmt: skip


def fit(files: list[str], write: bool, protocol: str, methods: list[str] | None = None) -> None:
    by_method: dict[str, list[dict]] = defaultdict(list)
    for r in _rows(files):
        if methods is not None and r["method"] not in methods:
            continue
        if r["stated"] is not None and r["interval"] is not None:
            by_method[r["method"]].append(r)
    maps = {}
    for method, rs in sorted(by_method.items()):
        where = sorted({(r["scenario"], r["world"], r["observability"], r["base"]) for r in rs})
        fitted_on = "; ".join(f"{s} ({w}) at {o}, seeds run_seed({b}, i)" for s, w, o, b in where)
        data = (
            [_averaged(r) for r in rs],
            [hi - lo for lo, hi in (_unmapped_interval(r, protocol) for r in rs)],
            [r["view"] for r in rs], [r["outcome"] == "success" for r in rs],
        )  # fmt: skip
        precision, how_held = 1.0, ""
        if len({r["base"] for r in rs}) >= 2:  # shrink as far as maps carry across ranges
            precision, losses = choose_prior_precision(*data, [r["base"] for r in rs])
            how_held = (
                f"; held towards the identity with prior precision {precision:g}, chosen by "
                "leaving one seed range out (held-out log loss per run: "
                + ", ".join(f"{p:g}: {v:.4f}" for p, v in losses.items()) + ")"
            )
        maps[method] = fit_calibration(
            *data, prior_precision=precision,
            fitted_on=f"{len(rs)} runs where L went: {fitted_on}{how_held}",
        )  # fmt: skip
        print(method, maps[method])
    if write:
        how = (
            "python benchmarks/fit_chance_calibration.py --fit "
            + " ".join(f"{Path(f).parent.name}/{Path(f).name}" for f in files)
            + (" --methods " + " ".join(methods) if methods else "")
            + (f" --stated-through {Path(STATED_THROUGH_FILE).name}" if STATED_THROUGH_FILE else "")
            + f" --protocol {protocol} --write"
        )
        fitted = dict(calibration_protocols())
        worlds = {r["world"] for rs in by_method.values() for r in rs}
        scenarios = {_scenario_name(r) for rs in by_method.values() for r in rs}
        if protocol in fitted:  # the methods not refitted keep their maps
            before = fitted[protocol]
            maps = {**before.maps, **maps}
            how = how if set(maps) == set(by_method) else f"{before.how}; then {how}"
            worlds |= set(before.worlds)
            scenarios |= set(before.scenarios)
        fitted[protocol] = CalibratedProtocol(
            PROTOCOL_OPTIONS[protocol], maps, how, tuple(sorted(worlds)), tuple(sorted(scenarios))
        )
        TARGET.write_text(maps_to_json(fitted), encoding="utf-8")
        print("wrote", TARGET)


def evaluate(files: list[str], protocol: str) -> None:
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in _rows(files):
        groups[(r["method"], r["scenario"], r["world"], r["observability"])].append(r)
    print("| method | scenario | world | view | runs | success | timeouts | stated where L "
          "went (− realised ± s.e.) | averaged (− realised) | deciles ≥ 20 runs within 0.10 | "
          "Hosmer–Lemeshow p | P(every decile within 0.10), if calibrated |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for key, rs in sorted(groups.items()):
        went = [r for r in rs if r["stated"] is not None]
        if not went:  # a method that states nothing (Random)
            continue
        y = np.array([r["outcome"] == "success" for r in went], dtype=float)
        raw = np.array([_averaged(r) for r in went])
        stated = [_as_stated(r, protocol)["stated"] for r in went]
        s = np.array(stated)
        n = len(went)
        ok = tot = 0
        bad = []
        k = np.minimum((s * 10).astype(int), 9)
        for d in range(10):
            sel = k == d
            if sel.sum() >= 20:
                tot += 1
                gap = s[sel].mean() - y[sel].mean()
                ok += abs(gap) <= 0.10
                if abs(gap) > 0.10:
                    bad.append(f"{d / 10:.1f}–{(d + 1) / 10:.1f}: {sel.sum()} runs {gap:+.2f}")
        hl, by_chance = _decile_tests(s, y)
        success = np.mean([r["outcome"] == "success" for r in rs])
        timeouts = np.mean([r["outcome"] == "timeout" for r in rs])
        se = (s - y).std(ddof=1) / np.sqrt(n)
        print(f"| {key[0]} | {key[1]} | {key[2]} | {key[3]} | {len(rs)} | {success:.3f} | "
              f"{timeouts:.3f} | {s.mean():.3f} ({s.mean() - y.mean():+.3f} ± {se:.3f}) | "
              f"{raw.mean():.3f} ({raw.mean() - y.mean():+.3f}) | {ok} of {tot}"
              + (f" ({'; '.join(bad)})" if bad else "")
              + f" | {hl:.2f} | {by_chance:.2f} |")  # fmt: skip


def _decile_tests(s: np.ndarray, y: np.ndarray, draws: int = 20_000) -> tuple[float, float]:
    """The Hosmer–Lemeshow test of the deciles of the stated chance (df = deciles − 2), and
    how often every decile with at least 20 runs lands within 0.10 of its mean stated chance
    when the outcomes are drawn from the stated chances themselves (a calibrated statement)."""
    k = np.minimum((s * 10).astype(int), 9)
    groups = [k == d for d in range(10) if (k == d).any()]
    stat = sum(
        (y[g].sum() - s[g].sum()) ** 2 / max(s[g].sum() * (1 - s[g].mean()), 1e-9)
        for g in groups
    )
    p_hl = float(chi2.sf(stat, max(len(groups) - 2, 1)))
    big = [g for g in groups if g.sum() >= 20]
    rng = np.random.default_rng(0)
    sim = rng.random((draws, len(s))) < s
    ok = np.ones(draws, dtype=bool)
    for g in big:
        ok &= np.abs(sim[:, g].mean(axis=1) - s[g].mean()) <= 0.10
    return p_hl, float(ok.mean())


def restate(files: list[str], folder: str, protocol: str) -> None:
    """Write each file's runs into ``folder`` as the shipped maps state them (``stated`` and
    ``interval`` mapped, ``averaged`` the average they came from), for the reliability plots of
    ``bench_posterior_go.py --panels``; a sweep's runs go one file per method, world and view
    (``METHOD-WORLD-VIEW.jsonl``), those where L stated a chance."""
    Path(folder).mkdir(parents=True, exist_ok=True)
    for name in files:
        out: dict[str, list[str]] = defaultdict(list)
        for r in _rows([name]):
            r = _as_stated(r, protocol)
            if not name.endswith(".sqlite"):
                out[Path(name).name].append(json.dumps(r))
            elif r["stated"] is not None:
                label = r["method"].replace(" (p=", "-p").replace(")", "")
                out[f"{label}-{r['world']}-{r['observability']:g}.jsonl"].append(json.dumps(r))
        for file, lines in out.items():
            (Path(folder) / file).write_text("\n".join(lines) + "\n", encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fit", nargs="+", default=None, metavar="RUNS.jsonl")
    ap.add_argument("--write", action="store_true", help="store the fitted maps in mirl/data")
    ap.add_argument("--evaluate", nargs="+", default=None, metavar="RUNS.jsonl")
    ap.add_argument("--restate", default=None, metavar="DIR",
                    help="with --evaluate: write the runs as the shipped maps state them here")
    ap.add_argument("--protocol", default=MIRL_RUN, choices=sorted(PROTOCOL_OPTIONS),
                    help="the protocol the runs were made under")  # fmt: skip
    ap.add_argument("--methods", nargs="+", default=None, metavar="METHOD",
                    help="with --fit: only these methods' runs (default: every method's)")
    ap.add_argument("--stated-through", default=None, metavar="MAPS.json",
                    help="the calibration file whose maps stated the runs, where they do not "
                    "record their range before the map (git show REV:src/mirl/data/"
                    "stated_chance_calibration.json)")  # fmt: skip
    args = ap.parse_args()
    if args.stated_through:
        global STATED_THROUGH, STATED_THROUGH_FILE
        STATED_THROUGH = _maps_in(args.stated_through)
        STATED_THROUGH_FILE = args.stated_through
    if args.fit:
        fit(args.fit, args.write, args.protocol, args.methods)
    if args.evaluate:
        evaluate(args.evaluate, args.protocol)
        if args.restate:
            restate(args.evaluate, args.restate, args.protocol)


if __name__ == "__main__":
    main()
