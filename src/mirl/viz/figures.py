"""The paper's figures (Fig. 3, 4a–c, Table 1) and their markdown sections, drawn from stored
experiment results; :func:`mirl.viz.report.write_report` assembles them into ``report.md``.

Each section function draws its figure to ``figures/*.png|svg`` and returns its markdown with
each result beside the paper's numbers. Figures use matplotlib's object API (no pyplot state),
so they can be drawn from worker threads and tests.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from scipy import stats

from mirl._registry import Registry
from mirl.experiments.conditions import EXPERIMENTS, Condition
from mirl.viz.aggregate import FIG4A_PAPER, PAPER_NAMES, TABLE1_PAPER, Group, method_name
from mirl.viz.atlas import atlas_markdown
from mirl.viz.verdicts import verdicts_markdown

__all__ = [
    "fig3",
    "fig3_markdown",
    "fig4a_markdown",
    "ttest",
    "fig4bc_markdown",
    "table1_markdown",
    "outcomes_markdown",
    "Section",
    "SECTIONS",
]


def _fmt(x: float, se: float | None = None, digits: int = 2) -> str:
    if x != x:
        return "–"
    return f"{x:.{digits}f}" if se is None else f"{x:.{digits}f} ± {se:.{digits}f}"


def _save(fig: Figure, figdir: Path, stem: str) -> str:
    figdir.mkdir(parents=True, exist_ok=True)
    for ext in ("png", "svg"):
        fig.savefig(figdir / f"{stem}.{ext}", dpi=150 if ext == "png" else None)
    return f"figures/{stem}.png"


# ---------------------------------------------------------------------------------------------
# Fig. 3


# Fig. 3's methods and how each is drawn: mIRL*/T+Int against its upper bound Known R/T
FIG3_STYLES = {"mirl-t": ("-", "o"), "known-r-t": ("--", "s")}
FIG3_LEARNER = "mirl-t"


def fig3(gs: list[Group], figdir: Path) -> str:
    """Draw Fig. 3: behaviour accuracy and success rate against observability, per method and
    record length.

    Parameters
    ----------
    gs : list of Group
        The finished runs of each condition of the experiment.
    figdir : Path
        The folder the figures are written into (created if missing).

    Returns
    -------
    str
        The figure's path as the report links it (``figures/fig3.png``; an SVG beside it).
    """
    methods = [m for m in FIG3_STYLES if any(g.condition.method == m for g in gs)]
    steps = sorted({g.condition.obs_steps for g in gs})
    fig = Figure(figsize=(7.5, 8.5), layout="constrained")
    top, bottom = fig.subplots(2, 1)
    colors = {n: f"C{k}" for k, n in enumerate(steps)}
    for mi, m in enumerate(methods):
        for n in steps:
            sel = sorted(
                (g for g in gs if g.condition.method == m and g.condition.obs_steps == n),
                key=lambda g: g.condition.observability,
            )
            if not sel:
                continue
            x = np.array([g.condition.observability for g in sel]) + 0.006 * (mi * 2 - 1)
            ms = np.array([g.mean_std("behavior_accuracy") for g in sel])
            top.errorbar(
                x,
                ms[:, 0],
                yerr=ms[:, 1],
                color=colors[n],
                capsize=3,
                ls=FIG3_STYLES[m][0],
                marker=FIG3_STYLES[m][1],
                label=f"{PAPER_NAMES[m]}, {n} steps",
            )
    top.set_xlabel("degree of observability")
    top.set_ylabel("learned behavior accuracy")
    lows = [ln.get_ydata().min() for ln in top.get_lines() if len(ln.get_ydata())]
    top.set_ylim(max(0.0, min(lows, default=0.0) - 0.15), 1.02)  # accuracies crowd near 1
    top.legend(fontsize=7, ncol=2)
    top.set_title("Behavior accuracy vs observability and observing time (bars: 1 std)")
    acc, succ, r_text = _accuracy_success(gs)
    for m, (_, marker) in FIG3_STYLES.items():
        idx = [i for i, g in enumerate(gs) if g.condition.method == m]
        if idx:
            bottom.scatter(acc[idx], succ[idx], marker=marker, label=PAPER_NAMES[m])
    if len(acc) >= 2 and np.ptp(acc) > 0:
        slope, icept = np.polyfit(acc, succ, 1)
        xs = np.linspace(acc.min(), acc.max(), 2)
        bottom.plot(xs, slope * xs + icept, "k:", lw=1)
    bottom.set_xlabel("mean learned behavior accuracy (one point per condition)")
    bottom.set_ylabel("success rate")
    bottom.set_title(f"Success vs accuracy: {r_text}")
    bottom.legend(fontsize=8)
    return _save(fig, figdir, "fig3")


def _accuracy_success(gs: list[Group]) -> tuple[np.ndarray, np.ndarray, str]:
    pts = [(g.mean_std("behavior_accuracy")[0], g.rate("success")) for g in gs]
    pts = [(a, s) for a, s in pts if a == a]
    acc = np.array([a for a, _ in pts])
    succ = np.array([s for _, s in pts])
    if len(acc) < 3 or np.ptp(acc) == 0 or np.ptp(succ) == 0:
        return acc, succ, "correlation undefined"
    r, p = stats.pearsonr(acc, succ)
    return acc, succ, f"Pearson r = {r:.2f} (p = {p:.2g}, {len(acc)} conditions)"


def fig3_markdown(gs: list[Group], figdir: Path) -> str:
    """Fig. 3's section of the report: the figure, its table and the accuracy–success correlation.

    Parameters
    ----------
    gs : list of Group
        The finished runs of each condition of the experiment.
    figdir : Path
        The folder the figures are written into (created if missing).

    Returns
    -------
    str
        Markdown.
    """
    png = fig3(gs, figdir)
    degrees = sorted({g.condition.observability for g in gs})
    head = "| method | steps | " + " | ".join(f"d = {d:g}" for d in degrees) + " |"
    lines = [
        f"![Fig. 3]({png})",
        "",
        "Behavior accuracy (mean ± std) / success rate:",
        "",
        head,
        "|" + " --- |" * (len(degrees) + 2),
    ]
    by = {(g.condition.method, g.condition.obs_steps, g.condition.observability): g for g in gs}
    for m in FIG3_STYLES:
        for n in sorted({g.condition.obs_steps for g in gs}):
            cells = []
            for d in degrees:
                g = by.get((m, n, d))
                cells.append(
                    "–"
                    if g is None
                    else f"{_fmt(*g.mean_std('behavior_accuracy'))} / {_fmt(g.rate('success'))}"
                )
            if any(c != "–" for c in cells):
                lines.append(f"| {PAPER_NAMES[m]} | {n} | " + " | ".join(cells) + " |")
    _, succ, r_text = _accuracy_success(gs)
    best = max(
        (g for g in gs if g.condition.method == FIG3_LEARNER),
        key=lambda g: g.rate("success"),
        default=None,
    )
    lines += ["", f"Accuracy vs success: {r_text}."]
    if best is not None:
        c = best.condition
        lines.append(
            f"Best mIRL*/T+Int success: **{best.rate('success'):.2f}** "
            f"(d = {c.observability:g}, {c.obs_steps} steps, n = {best.n}); "
            "paper: up to **0.60**."
        )
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Fig. 4a


def fig4a_markdown(gs: list[Group], figdir: Path) -> str:
    """Fig. 4a's section: outcome rates per method and observability, against mIRL*/T+Int and the
    paper's ordering.

    Parameters
    ----------
    gs : list of Group
        The finished runs of each condition of the experiment.
    figdir : Path
        The folder the figures are written into (created if missing).

    Returns
    -------
    str
        Markdown with the figure and its table.
    """
    degrees = sorted({g.condition.observability for g in gs})
    fig = Figure(figsize=(9, 3.6 * len(degrees)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(degrees), 1))
    for ax, d in zip(axes, degrees, strict=True):
        sel = [g for g in gs if g.condition.observability == d]
        x = np.arange(len(sel))
        outcomes = (("success", "success"), ("detected", "detected"), ("timeout", "timed out"))
        for k, (outcome, label) in enumerate(outcomes):
            rates = [g.rate(outcome) for g in sel]
            xs = x + (k - 1) * 0.27
            ax.bar(xs, rates, 0.27, yerr=[g.rate_se(outcome) for g in sel], capsize=2, label=label)
            _mark_zeros(ax, xs, rates)
        ax.set_xticks(
            x, [method_name(g.condition) for g in sel], rotation=25, ha="right", fontsize=8
        )
        ax.set_ylim(0, 1.2)  # room for the legend above the bars
        ax.set_ylabel("rate")
        ax.set_title(f"J's left wheel damaged, observability {d:g} (bars: ±1 s.e.)")
        ax.legend(fontsize=8, ncol=3, loc="upper center")
    png = _save(fig, figdir, "fig4a")
    lines = [
        f"![Fig. 4a]({png})",
        "",
        "| method | d | n | success | detected | timed out | vs mIRL*/T+Int | paper |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for g in sorted(gs, key=lambda g: g.condition.observability):
        c = g.condition
        ref = next((h for h in gs if h.condition == Condition("mirl-t", c.scenario,
                    c.observability, c.obs_steps)), None)  # fmt: skip
        lines.append(
            f"| {method_name(c)} | {c.observability:g} | {g.n} | "
            f"{_fmt(g.rate('success'), g.rate_se('success'))} | {_fmt(g.rate('detected'))} | "
            f"{_fmt(g.rate('timeout'))} | {_paired(ref, g)} | {FIG4A_PAPER.get(c.method, '')} |"
        )
    return "\n".join(lines + ["", PAIRED_NOTE])


def _mark_zeros(ax, xs, values) -> None:
    """Write "0" where a bar has zero height, so an empty slot reads as a measured zero."""
    for x, v in zip(xs, values, strict=True):
        if v == 0:
            ax.text(x, 0.01, "0", ha="center", va="bottom", fontsize=7, color="dimgray")


def _p_text(p: float, n: int) -> str:
    """A t-test's p for a table or title; says why when there is none (never 'p = nan')."""
    if p == p:
        return f"p = {p:.2g}"
    return "no test (fewer than 2 runs)" if n < 2 else "no test (no spread in the values)"


PAIRED_NOTE = (
    "*vs mIRL\\*/T+Int*: runs with the same seed see the same patrol (common random numbers), "
    "so methods are compared run by run: W–L counts the seeds where mIRL\\*/T+Int succeeded and "
    "this method did not (W) and the reverse (L); p is the exact two-sided sign test."
)


def _paired(ref: Group | None, g: Group) -> str:
    """Paired wins–losses of ``ref`` over ``g`` on shared seeds, with a sign test."""
    if ref is None or ref is g:
        return ""
    other = {r["run"]: r["outcome"] == "success" for r in g.rows}
    pairs = [(r["outcome"] == "success", other[r["run"]]) for r in ref.rows if r["run"] in other]
    w = sum(a and not b for a, b in pairs)
    lost = sum(b and not a for a, b in pairs)
    p = stats.binomtest(w, w + lost, 0.5).pvalue if w + lost else 1.0
    return f"{w}–{lost} (p = {p:.2g})"


# ---------------------------------------------------------------------------------------------
# Fig. 4b / 4c


def _features(gs: list[Group]) -> tuple[list[str], list[str]]:
    keys = {k for g in gs for r in g.rows for k in r if k.startswith("fp.")}
    robots = sorted({k.split(".")[1] for k in keys})
    order = ["left_wheel", "right_wheel", "navigation", "floor"]
    feats = sorted(
        {k.split(".", 2)[2] for k in keys},
        key=lambda f: (f not in order, order.index(f) if f in order else 0, f),
    )
    return robots, feats


def _true_probabilities(scenario: str) -> dict[str, dict[str, float]]:
    try:
        from mirl.world.scenario import load_scenario

        s = load_scenario(scenario)
        return {r.name: dict(r.feature_probabilities) for r in s.robots}
    except (ValueError, OSError):
        return {}


def ttest(g: Group, robot: str, a: str, b: str) -> tuple[float, float, int]:
    """Two-tailed Student's t-test (the paper's) of ``robot``'s learned ``a`` vs ``b``.

    Parameters
    ----------
    g : Group
        The runs.
    robot : str
        The robot's name.
    a : str
        A transition feature.
    b : str
        Another.

    Returns
    -------
    t : float
        The statistic; NaN with fewer than two values each or both samples constant.
    p : float
        Its two-tailed p-value (NaN likewise).
    n : int
        The smaller sample's size.
    """
    x, y = g.values(f"fp.{robot}.{a}"), g.values(f"fp.{robot}.{b}")
    if min(len(x), len(y)) < 2 or (np.ptp(x) == 0 and np.ptp(y) == 0):
        return float("nan"), float("nan"), min(len(x), len(y))
    with warnings.catch_warnings():  # near-constant samples: scipy warns, the answer stands
        warnings.simplefilter("ignore", RuntimeWarning)
        t, p = stats.ttest_ind(x, y)
    return float(t), float(p), min(len(x), len(y))


def fig4bc_markdown(gs: list[Group], figdir: Path, stem: str) -> str:
    """Fig. 4b's or 4c's section: the learned transition-feature probabilities per robot, their
    t-tests and the fault verdicts' rates.

    Parameters
    ----------
    gs : list of Group
        The finished runs of each condition of the experiment.
    figdir : Path
        The folder the figures are written into (created if missing).
    stem : {"fig4b", "fig4c"}
        The figure's file name.

    Returns
    -------
    str
        Markdown.
    """
    robots, feats = _features(gs)
    if not feats:
        return "No learned feature probabilities were stored for these runs."
    cols = min(len(gs), 2)
    nrows = -(-len(gs) // cols)
    fig = Figure(figsize=(5.0 * cols, 3.8 * nrows), layout="constrained")
    grid = np.atleast_1d(fig.subplots(nrows, cols, sharey=True, squeeze=False)).ravel()
    for ax in grid[len(gs) :]:
        ax.set_visible(False)
    axes = grid[: len(gs)]
    lines = [
        f"![Fig. {stem[3:]}](figures/{stem}.png)",
        "",
        "Learned probabilities, mean ± std over runs (the runs' spread, as the paper's bars):",
        "",
        "| method | d | n | robot | " + " | ".join(feats) + " |",
        "| --- | --- | --- | --- |" + " --- |" * len(feats),
    ]
    tests: list[str] = []
    interval_lines: list[str] = []
    verdict_lines: list[str] = []
    for ax, g in zip(axes, gs, strict=True):
        c = g.condition
        truth = _true_probabilities(c.scenario)
        x = np.arange(len(feats))
        w = 0.8 / max(len(robots), 1)
        for k, robot in enumerate(robots):
            ms = np.array([g.mean_std(f"fp.{robot}.{f}") for f in feats])
            xs = x + (k - (len(robots) - 1) / 2) * w
            ax.bar(
                xs,
                ms[:, 0],
                w,
                yerr=ms[:, 1],
                capsize=2,
                label=robot,
                color=f"C{k}",
                error_kw={"ecolor": "dimgray", "elinewidth": 1},
            )
            spans = _mean_intervals(g, robot, feats)
            if spans is not None:  # the runs' mean 95 % interval, beside the runs' spread
                # the interval need not contain the mean estimate (docs/design.md, "Fault
                # verdicts"), so it is drawn as a span of its own, not as error bars
                ax.vlines(xs + w * 0.3, spans[:, 0], spans[:, 1], color="black", lw=0.9,
                          label="mean 95 % interval" if k == 0 else None)  # fmt: skip
                for edge in (0, 1):
                    ax.hlines(spans[:, edge], xs + w * 0.2, xs + w * 0.4, color="black", lw=0.9)
                cells = " | ".join(f"{lo:.2f}–{hi:.2f}" for lo, hi in spans)
                interval_lines.append(
                    f"| {method_name(c)} | {c.observability:g} | {g.n} | {robot} | {cells} |"
                )
            true = [truth.get(robot, {}).get(f, np.nan) for f in feats]
            ax.scatter(
                xs, true, marker="D", s=22, color="red", zorder=5, label="true" if k == 0 else None
            )
            cells = " | ".join(_fmt(mean, sd, digits=3) for mean, sd in ms[: len(feats)])
            lines.append(f"| {method_name(c)} | {c.observability:g} | {g.n} | {robot} | {cells} |")
        verdict_lines += _verdict_rates(g, method_name(c), robots)
        t, p, n = ttest(g, "J", "left_wheel", "right_wheel")
        tests.append(
            f"- {method_name(c)}, d = {c.observability:g}: J left vs right wheel "
            + (f"t = {_fmt(t)}, " if t == t else "")
            + f"{_p_text(p, n)} (n = {n})"
        )
        ax.set_xticks(x, [f.replace("_", " ") for f in feats], rotation=20, fontsize=8)
        ax.set_ylim(0.4, 1.02)
        ax.set_title(
            f"{method_name(c)}, d = {c.observability:g}\nJ left vs right: {_p_text(p, n)}",
            fontsize=9,
        )
        ax.legend(fontsize=7, loc="lower left")
    for ax in grid[::cols]:
        ax.set_ylabel("learned probability (mean ± std)")
    _save(fig, figdir, stem)
    if interval_lines:
        lines += [
            "",
            "Each run's 95 % interval of each probability, averaged over runs (the single run's "
            "uncertainty, where the table above gives the runs' spread):",
            "",
            "| method | d | n | robot | " + " | ".join(feats) + " |",
            "| --- | --- | --- | --- |" + " --- |" * len(feats),
            *interval_lines,
        ]
    if verdict_lines:
        lines += [
            "",
            'Each run\'s verdict (docs/design.md, "Fault verdicts"): the share of runs naming '
            "each part, naming several it cannot tell apart, or none:",
            "",
            "| method | d | robot | verdicts (share of runs, mean confidence) |",
            "| --- | --- | --- | --- |",
            *verdict_lines,
        ]
    return "\n".join(lines + ["", "Two-tailed Student's t-tests over runs:", "", *tests])


def _mean_intervals(g: Group, robot: str, feats: list[str]) -> np.ndarray | None:
    """(F, 2): each feature's stored 95 % interval averaged over the runs; None if unstored."""
    spans = [[r.get(f"ci.{robot}.{f}") for r in g.rows] for f in feats]
    if any(v is None for row in spans for v in row) or not g.rows:
        return None
    return np.array([np.mean(np.asarray(row, dtype=float), axis=0) for row in spans])


def _verdict_rates(g: Group, label: str, robots: list[str]) -> list[str]:
    """Per robot: how often each verdict was given (stored ``verdict.<robot>``)."""
    out = []
    for robot in robots:
        given = [
            (str(r.get(f"verdict.{robot}") or "no part"), float(r[f"confidence.{robot}"]))
            for r in g.rows
            if r.get(f"confidence.{robot}") is not None
        ]
        if not given:
            continue
        kinds = sorted({v for v, _ in given}, key=lambda v: -sum(x == v for x, _ in given))
        cells = "; ".join(
            f"{v.replace(',', ' or ').replace('_', ' ')} {sum(x == v for x, _ in given)}/"
            f"{len(given)} ({np.mean([c for x, c in given if x == v]):.2f})"
            for v in kinds
        )
        out.append(f"| {label} | {g.condition.observability:g} | {robot} | {cells} |")
    return out


# ---------------------------------------------------------------------------------------------
# Table 1


TABLE1_ROWS = (("mirl-t", "mIRL*/T+Int"), ("mirl", "mIRL*+Int (p=0.9)"), ("random", "Random"))
TABLE1_SCENARIOS = (("boyd2", "J's left wheel damaged"), ("boyd2-healthy", "no damaged wheels"))


def table1_figure(gs: list[Group], figdir: Path) -> str:
    """Table 1 as bars: success rate (± 1 s.e.) per method and scenario, the paper's as marks."""
    by = {(g.condition.method, g.condition.scenario): g for g in gs}
    fig = Figure(figsize=(7.5, 3.8), layout="constrained")
    ax = fig.subplots()
    x = np.arange(len(TABLE1_ROWS))
    for k, (s, label) in enumerate(TABLE1_SCENARIOS):
        groups = [by.get((m, s)) for m, _ in TABLE1_ROWS]
        rates = [np.nan if g is None else g.rate("success") for g in groups]
        ses = [0.0 if g is None else g.rate_se("success") for g in groups]
        xs = x + (k - 0.5) * 0.38
        ax.bar(xs, rates, 0.38, yerr=ses, capsize=2, label=f"ours: {label}", color=f"C{k}")
        _mark_zeros(ax, xs, rates)
        paper = [TABLE1_PAPER[(m, s)] for m, _ in TABLE1_ROWS]
        ax.scatter(xs, paper, marker="D", s=24, color="red", zorder=5,
                   label="paper (10 physical runs)" if k == 0 else None)  # fmt: skip
    ax.set_xticks(x, [label for _, label in TABLE1_ROWS])
    ax.set_ylim(0, 1.2)
    ax.set_ylabel("success rate")
    ax.set_title("Table 1: success with and without J's damaged wheel (bars: ±1 s.e.)")
    ax.legend(fontsize=8, ncol=3, loc="upper center")
    return _save(fig, figdir, "table1")


def table1_markdown(gs: list[Group], figdir: Path) -> str:
    """Table 1's section: success with and without J's damaged wheel, beside the paper's.

    Parameters
    ----------
    gs : list of Group
        The finished runs of each condition of the experiment.
    figdir : Path
        The folder the figures are written into (created if missing).

    Returns
    -------
    str
        Markdown with the figure and its table.
    """
    png = table1_figure(gs, figdir)
    by = {(g.condition.method, g.condition.scenario): g for g in gs}
    lines = [
        f"![Table 1]({png})",
        "",
        "| method | J's left wheel damaged: ours | paper | no damaged wheels: ours | paper |",
        "| --- | --- | --- | --- | --- |",
    ]
    for m, label in TABLE1_ROWS:
        cells = []
        for s, _ in TABLE1_SCENARIOS:
            g = by.get((m, s))
            ours = "–" if g is None else f"{_fmt(g.rate('success'))} {_wilson(g)} (n={g.n})"
            cells += [ours, f"{TABLE1_PAPER[(m, s)]:.2f} (n=10)"]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    verdicts = [
        line
        for g in gs
        for line in _verdict_rates(
            g, f"{method_name(g.condition)}, {g.condition.scenario}", ["I", "J"]
        )
    ]
    lines += ["", "Ours: success rate [95 % Wilson interval] over n runs."]
    if verdicts:
        lines += [
            "",
            'Each run\'s fault verdict (docs/design.md, "Fault verdicts"), for the methods '
            "that learn feature probabilities:",
            "",
            "| method, scenario | d | robot | verdicts (share of runs, mean confidence) |",
            "| --- | --- | --- | --- |",
            *verdicts,
        ]
    return "\n".join(lines)


def _wilson(g: Group, z: float = 1.96) -> str:
    """The 95 % Wilson score interval of the success rate (Wilson 1927)."""
    n, p = g.n, g.rate("success")
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return f"[{max(centre - half, 0):.2f}, {min(centre + half, 1):.2f}]"


def outcomes_markdown(gs: list[Group]) -> str:
    """The table of outcomes of every condition (the section of experiments without their own).

    Parameters
    ----------
    gs : list of Group
        The finished runs of each condition.

    Returns
    -------
    str
        A markdown table.
    """
    lines = [
        "| condition | n | success | detected | timed out | accuracy | go time |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for g in gs:
        c = g.condition
        lines.append(
            f"| {method_name(c)}, {c.scenario}, d={c.observability:g}, {c.obs_steps} steps | "
            f"{g.n} | {_fmt(g.rate('success'))} | {_fmt(g.rate('detected'))} | "
            f"{_fmt(g.rate('timeout'))} | {_fmt(*g.mean_std('behavior_accuracy'))} | "
            f"{_fmt(g.mean_std('go_time')[0], digits=1)} |"
        )
    return "\n".join(lines)


@dataclass(frozen=True)
class Section:
    """The report's section of one experiment.

    A section is called as its ``write``.

    Parameters
    ----------
    name : str
        The experiment's name, in :data:`~mirl.experiments.conditions.EXPERIMENTS`.
    write : callable
        ``write(groups, figdir)`` draws the section's figures into ``figdir`` and returns its
        markdown.
    """

    name: str
    write: Callable[[list[Group], Path], str]

    def __call__(self, groups: list[Group], figdir: Path) -> str:
        return self.write(groups, figdir)


def _check_section(section: Section) -> None:
    """A section belongs to an experiment of :data:`~mirl.experiments.conditions.EXPERIMENTS`."""
    if section.name not in EXPERIMENTS:
        raise ValueError(f"report section '{section.name}': {EXPERIMENTS.unknown(section.name)}")


SECTIONS: Registry[Section] = Registry(
    "report section",
    (
        Section("fig3", fig3_markdown),
        Section("fig4a", fig4a_markdown),
        Section("fig4b", lambda gs, d: fig4bc_markdown(gs, d, "fig4b")),
        Section("fig4c", lambda gs, d: fig4bc_markdown(gs, d, "fig4c")),
        Section("table1", table1_markdown),
        Section("verdicts", verdicts_markdown),
        Section("atlas", atlas_markdown),
    ),
    check=_check_section,
)
"""The report's own section of each experiment that has one, by the experiment's name (the
others get the table of outcomes alone)."""
