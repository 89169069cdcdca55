"""`report.md` beside the paper's numbers: every experiment found in a directory, its figures and
tables, and the sweep's throughput."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from mirl.experiments.conditions import (
    EXPERIMENTS,
    Condition,
    StoreError,
    episode_run,
    experiment_names,
)
from mirl.experiments.store import load_results
from mirl.experiments.sweep import split_version
from mirl.learning.methods import METHODS
from mirl.viz.aggregate import PAPER, Row, groups
from mirl.viz.figures import SECTIONS, outcomes_markdown
from mirl.worlds import DEFAULT_WORLD

__all__ = ["WrittenReport", "write_report", "write_report_and_figures", "report_markdown"]

# ---------------------------------------------------------------------------------------------
# Report


def _versions(rows: list[Row]) -> tuple[list[str], list[str]]:
    """mirl's fingerprints of the rows, and what else some rows depend on (a world's release:
    :func:`mirl.experiments.sweep.split_version`), so a store holding both worlds is not one of
    mixed code."""
    code, extras = set(), set()
    for r in rows:
        version, extra = split_version(str(r["version"]))
        code.add(version)
        extras.add(extra)
    return sorted(code), sorted(extras - {""})


def _throughput(sessions: list[dict]) -> str:
    done = [s for s in sessions if s["finished"] and s["seconds"] > 0]
    if not done:
        return "no timed sessions"
    parts = []
    for w in sorted({s["workers"] for s in done}):
        sel = [s for s in done if s["workers"] == w]
        n, sec = sum(s["finished"] for s in sel), sum(s["seconds"] for s in sel)
        workers = f"{w} worker" + "s" * (w != 1)
        parts.append(f"{60 * n / sec:.1f} runs/min on {workers} ({n} runs in {sec / 60:.1f} min)")
    return "; ".join(parts)


def report_markdown(
    meta: dict[str, str], rows: list[Row], sessions: list[dict], figdir: Path
) -> str:
    """One experiment's section: header facts, its figure/table beside the paper, outcomes.

    Parameters
    ----------
    meta : dict of str to str
        The store's ``meta`` (its ``experiment`` and ``base_seed``).
    rows : list of dict
        The stored runs, flat (:func:`~mirl.experiments.store.load_results`).
    sessions : list of dict
        The sweep's invocations, for its throughput.
    figdir : Path
        Where the section's figures are drawn.

    Returns
    -------
    str
        The section, Markdown.
    """
    name = meta.get("experiment", "?")
    gs = groups(rows)
    if name in EXPERIMENTS:  # the experiment's own order: methods as the paper lists them
        rank = {c.key: k for k, c in enumerate(EXPERIMENTS[name].conditions)}

        # physical-world runs and runs under another protocol rank as their listed twins
        def listed(c: Condition) -> str:
            return replace(c, world=DEFAULT_WORLD, go_rule=None, relearn=False).key

        gs.sort(key=lambda g: rank.get(listed(g.condition), len(rank)))
    errors = sum(r["outcome"] == "error" for r in rows)
    ns = [g.n for g in gs] or [0]
    versions, depends = _versions(rows)
    head = [
        f"## {name}",
        "",
        f"{len(rows)} runs over {len(gs)} conditions, {_span(ns)} finished runs per "
        f"condition ({errors} failed runs excluded); base seed {meta.get('base_seed')}; mirl "
        f"{', '.join(versions)}"
        + (" (**rows from different code versions**)" if len(versions) > 1 else "")
        + (f" and {', '.join(depends)} (the rows of a world that depends on it)" if depends else "")
        + f". Throughput: {_throughput(sessions)}."
        + _missing(meta, len(rows)),
        "",
    ]
    protocols = sorted({g.condition.protocol for g in gs if g.condition.method in METHODS})
    if protocols and name in EXPERIMENTS and EXPERIMENTS[name].run_function is episode_run:
        head += [f"L decided by {' and '.join(protocols)}.", ""]
    if name in PAPER:
        head += [f"**Paper:** {PAPER[name]}", ""]
    body = SECTIONS[name](gs, figdir) if name in SECTIONS and gs else ""
    tail = [
        "",
        "<details><summary>Outcomes per condition</summary>",
        "",
        outcomes_markdown(gs),
        "",
        "</details>",
        "",
    ]
    return "\n".join(head + [body] + tail)


def _missing(meta: Mapping[str, str], stored: int) -> str:
    """The sentence saying how many runs the sweep was asked for and does not hold (an
    interrupted sweep), or nothing."""
    planned = int(meta.get("planned_runs", 0))
    if stored >= planned:
        return ""
    return (
        f" **{planned - stored} of the {planned} runs the sweep was asked for are missing**: "
        "it was interrupted (`mirl experiment NAME --resume --out DIR` finishes it)."
    )


def _span(ns: list[int]) -> str:
    return str(min(ns)) if min(ns) == max(ns) else f"{min(ns)}–{max(ns)}"


def _databases(path: Path) -> list[Path]:
    if (path / "results.sqlite").exists():
        return [path / "results.sqlite"]
    found = sorted(path.glob("*/results.sqlite"))
    rank = {n: k for k, n in enumerate(experiment_names(include_hidden=True))}
    return sorted(found, key=lambda p: (rank.get(p.parent.name, len(rank)), p.parent.name))


@dataclass(frozen=True)
class WrittenReport:
    """What :func:`write_report_and_figures` wrote.

    Parameters
    ----------
    report : Path
        The ``report.md``.
    figures : tuple of Path
        Every figure file drawn (each figure as PNG and SVG), in the report's order.
    """

    report: Path
    figures: tuple[Path, ...]


def write_report(directory: str | Path) -> Path:
    """Draw the figures of every experiment under ``directory`` and write its report.md; the
    report's path (:func:`write_report_and_figures` also says which figures it drew).

    Parameters
    ----------
    directory : str or Path
        An experiment's results directory, or a directory whose sub-directories hold
        experiments.

    Returns
    -------
    Path
        The ``report.md`` written.
    """
    return write_report_and_figures(directory).report


# a figure a section shows: ![caption](figures/NAME.png)
IMAGE = re.compile(r"!\[[^\]]*\]\(figures/([^)/]+)\.png\)")


def _drawn(markdown: str, figdir: Path) -> list[Path]:
    """The figure files a section drew: each figure it shows, in every format it was saved in
    (the files of ``figdir`` that share the figure's name)."""
    return [p for stem in IMAGE.findall(markdown) for p in sorted(figdir.glob(f"{stem}.*"))]


def write_report_and_figures(directory: str | Path) -> WrittenReport:
    """Draw the figures of every experiment under ``directory`` and write its report.md.

    Parameters
    ----------
    directory : str or Path
        An experiment's results directory (its ``results.sqlite``, or the database itself), or a
        directory whose sub-directories hold experiments.

    Returns
    -------
    WrittenReport
        The report's path and the figure files drawn.

    Raises
    ------
    StoreError
        No ``results.sqlite`` there, or a file that is no experiment's results directory.
    """
    root = Path(directory)
    if root.is_file() and root.name == "results.sqlite":
        root = root.parent  # the database itself names its directory
    elif root.exists() and not root.is_dir():
        raise StoreError(f"{root}: a file, not an experiment's results directory")
    elif not root.exists():
        raise StoreError(f"{root}: no such directory")
    dbs = _databases(root) if root.is_dir() else []
    if not dbs:
        raise StoreError(f"{root}: no results.sqlite here or in its sub-directories")
    sections = [
        "# mirl experiment report",
        "",
        "Each result beside the paper's (Bogert & Doshi, Sec. 4). Rates are shares of "
        "finished runs; ± is one standard error unless marked std.",
        "",
        "Methods — the paper's name, the CLI's `--method`, and what each does:",
        "",
        "| paper | CLI | what it does |",
        "| --- | --- | --- |",
        *(
            f"| {m.paper_name} | `{m.name}` | {m.description} |".replace("*", "\\*")
            for m in METHODS.values()
        ),
        "",
    ]
    drawn: list[Path] = []
    for db in dbs:
        meta, rows, sessions = load_results(db)
        figdir = db.parent / "figures"
        md = report_markdown(meta, rows, sessions, figdir)
        drawn += _drawn(md, figdir)
        if db.parent != root:  # each experiment's figures stay beside its database
            md = md.replace("](figures/", f"]({db.parent.relative_to(root).as_posix()}/figures/")
        sections.append(md)
    out = root / "report.md"
    out.write_text("\n".join(sections), encoding="utf-8")
    return WrittenReport(out, tuple(drawn))
