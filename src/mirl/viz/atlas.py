"""The calibration atlas's section of ``report.md`` (``mirl experiment atlas``): the fault
verdicts per value of each axis and per world × data path × fault, against their targets, the
cells and verdicts that miss most, and what each command cost (docs/design.md, "The calibration
atlas").

The scoring is :mod:`mirl.viz.verdicts`'s: a verdict is right when it names a damaged part
(alone or among its candidates) or "no part" of a healthy robot; a statement is *confidently
false* when it is not right at a confidence of at least 0.9, or when a part it says is damaged
besides those it names is not, at a probability of at least 0.9
(:attr:`VerdictItem.confident_false`); the expected calibration error is
:func:`~mirl.viz.verdicts.expected_calibration_error`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mirl.experiments.atlas import DATA_PATHS, POSE_PATHS, fault_kind, parse_damage
from mirl.experiments.conditions import EXPERIMENTS, Condition
from mirl.learning.verdicts import NEVER_SEEN, parse_also_field
from mirl.viz.aggregate import Group
from mirl.viz.verdicts import (
    CONFIDENT,
    VerdictItem,
    expected_calibration_error,
    reliability_table,
)

__all__ = [
    "AtlasVerdict", "Measures", "TARGETS", "atlas_items", "atlas_markdown", "estimate_cpu",
    "measures",
]  # fmt: skip

TARGETS = {
    "false overall": 0.02,  # confidently false, share of all verdicts
    "false per row": 0.05,  # … of a row's, in every row with at least MIN_ROW verdicts
    "ece overall": 0.05,
    "ece per row": 0.10,
    "named": 0.90,  # full view, strength ≤ 0.6 or the grid's 0.7: damaged part named
    "alone": 0.70,  # … named alone, where the data carry poses
    "healthy": 0.97,  # healthy robots without a confidently false statement, per data path
}
"""The atlas's targets."""
MIN_ROW = 20
"""Rows with fewer verdicts are reported but not held to the per-row targets."""
STRONG = 0.7
"""Full-view damage at most this strong (a motor strength ≤ 0.6, the grid's 0.7) must be named."""


@dataclass(frozen=True)
class AtlasVerdict:
    """One robot's verdict from one data path of one atlas run.

    Parameters
    ----------
    base : VerdictItem
        World, view, damage, robot, run, verdict, confidence, truth and whether it is right.
    path : str
        The data path it was learned from, a key of :data:`~mirl.experiments.atlas.DATA_PATHS`.
    scenario : str
        The run's scenario.
    length : int
        The record's length, steps.
    kind : str
        The run's kind of damage, one of :data:`~mirl.experiments.atlas.FAULT_KINDS`.
    strength : float or None
        The damaged parts' value; None without damage.
    fit : str or None
        The verdict's model check: "ok", why it failed, or None when none was made.
    seen : int
        Steps L saw the robot.
    commands : (str, str)
        The simulation and the learning that gave it.
    """

    base: VerdictItem  # world, view, damage, robot, run, verdict, confidence, truth, right
    path: str  # a key of DATA_PATHS
    scenario: str
    length: int
    kind: str  # one of mirl.experiments.atlas.FAULT_KINDS
    strength: float | None  # the damaged parts' value; None without damage
    fit: str | None  # the verdict's model check: "ok", why it failed, or None (none made)
    seen: int  # steps L saw the robot
    commands: tuple[str, str]  # the simulation and the learning that gave it

    @property
    def damaged(self) -> bool:
        """Whether some part of the robot is really damaged."""
        return bool(self.base.truth)

    @property
    def stated(self) -> bool:
        """Whether L states a verdict: not for a robot it never saw move, whose confidence is
        the prior's probability that no part is damaged (:data:`~mirl.learning.verdicts.
        NEVER_SEEN`), a number of the prior's and the design's share of damaged robots, not a
        statement about the robot."""
        return self.fit != NEVER_SEEN

    @property
    def named_alone(self) -> bool:
        """Whether the verdict names damaged parts only: one part, a damaged one, or (with two
        damaged) exactly those ("one of J's wheels is weak (or both)")."""
        return bool(self.base.verdict) and set(self.base.verdict) <= set(self.base.truth)

    @property
    def named_among(self) -> bool:
        """Whether the verdict names a damaged part among parts that are not damaged."""
        return not self.named_alone and any(p in self.base.truth for p in self.base.verdict)


def atlas_items(gs: Sequence[Group]) -> list[AtlasVerdict]:
    """Every verdict of every stored atlas run.

    Parameters
    ----------
    gs : sequence of Group
        The stored runs by design point.

    Returns
    -------
    list of AtlasVerdict
        One per run, data path and robot with a verdict.
    """
    out = []
    for g in gs:
        c = g.condition
        faults = parse_damage(c.damage)
        strength = faults[0].value if faults else None
        for row in g.rows:
            robots = sorted(k.split(".", 1)[1] for k in row if k.startswith("truth."))
            for path in DATA_PATHS:
                for robot in robots:
                    conf = row.get(f"confidence.{path}.{robot}")
                    if conf is None:
                        continue
                    named = str(row.get(f"verdict.{path}.{robot}") or "")
                    truth = str(row.get(f"truth.{robot}") or "")
                    base = VerdictItem(
                        c.world, c.observability, c.damage, robot, int(row["run"]),
                        tuple(named.split(",")) if named else (), float(conf),
                        tuple(truth.split(",")) if truth else (),
                        bool(row[f"right.{path}.{robot}"]),
                        parse_also_field(row.get(f"also.{path}.{robot}")),
                    )  # fmt: skip
                    fit = row.get(f"fit.{path}.{robot}")
                    out.append(
                        AtlasVerdict(
                            base, path, c.scenario, c.obs_steps, fault_kind(faults), strength,
                            None if fit is None else str(fit), int(row.get(f"seen.{robot}", 0)),
                            (str(row.get("command.simulate", "")),
                             str(row.get(f"command.learn.{path}", ""))),
                        )
                    )  # fmt: skip
    return out


@dataclass(frozen=True)
class Measures:
    """What the atlas reports of a set of verdicts.

    Parameters
    ----------
    n : int
        Verdicts L states (robots it saw move).
    false : int
        Confidently false statements.
    ece : float
        The expected calibration error of the verdicts L states.
    damaged : int
        Verdicts on damaged robots.
    alone : int
        Of those, naming a damaged part alone.
    among : int
        Of those, naming one among candidates.
    healthy : int
        Verdicts on healthy robots.
    healthy_ok : int
        Of those, without a confidently false statement.
    checked : int
        Verdicts with a model check.
    misfit : int
        Of those, whose check failed.
    unseen : int
        Robots L never saw move: no verdict, in none of the counts above but the damaged
        and healthy robots'.
    """

    n: int
    false: int  # confidently false statements
    ece: float
    damaged: int  # verdicts on damaged robots
    alone: int  # … naming a damaged part alone
    among: int  # … naming one among candidates
    healthy: int  # verdicts on healthy robots
    healthy_ok: int  # … without a confidently false statement
    checked: int  # verdicts with a model check
    misfit: int  # … whose check failed
    unseen: int = 0  # robots L never saw move: no verdict

    @property
    def false_share(self) -> float:
        """The share of confidently false statements (NaN for no verdict)."""
        return self.false / self.n if self.n else float("nan")


def measures(items: Sequence[AtlasVerdict]) -> Measures:
    """The atlas's measures of ``items``.

    Parameters
    ----------
    items : sequence of AtlasVerdict
        The verdicts.

    Returns
    -------
    Measures
        Counts, shares and the calibration error.
    """
    damaged = [a for a in items if a.damaged]
    healthy = [a for a in items if not a.damaged]
    stated = [a for a in items if a.stated]
    checked = [a for a in stated if a.fit is not None]
    return Measures(
        n=len(stated),
        false=sum(a.base.confident_false for a in stated),
        ece=expected_calibration_error([a.base for a in stated]),
        damaged=len(damaged),
        alone=sum(a.named_alone for a in damaged),
        among=sum(a.named_among for a in damaged),
        healthy=len(healthy),
        healthy_ok=sum(not a.base.confident_false for a in healthy),
        checked=len(checked),
        misfit=sum(a.fit != "ok" for a in checked),
        unseen=len(items) - len(stated),
    )


def _share(k: int, n: int, target: float | None = None, above: bool = False) -> str:
    """``k/n`` as a share with its counts; bold when it misses ``target`` (a ceiling, or a floor
    with ``above``)."""
    if not n:
        return "–"
    s = k / n
    text = f"{s:.3f} ({k}/{n})"
    missed = target is not None and (s < target if above else s > target)
    return f"**{text}**" if missed else text


def _cells(m: Measures, held: bool) -> list[str]:
    """A row's measure cells; ``held``: the row is held to the per-row targets."""
    ece = "–" if m.ece != m.ece else f"{m.ece:.3f}"
    if held and m.ece == m.ece and m.ece > TARGETS["ece per row"]:
        ece = f"**{ece}**"
    named = (
        "–"
        if not m.damaged
        else f"{(m.alone + m.among) / m.damaged:.3f} ({m.alone / m.damaged:.3f} / "
        f"{m.among / m.damaged:.3f}; {m.damaged})"
    )
    return [
        str(m.n),
        _share(m.false, m.n, TARGETS["false per row"] if held else None),
        ece,
        named,
        _share(m.healthy_ok, m.healthy),
        _share(m.misfit, m.checked),
        str(m.unseen),
    ]


_HEAD = [
    "verdicts", f"confidently false (≥ {CONFIDENT:g})", "ECE",
    "damaged robots: part named (alone / among candidates; n)",
    "healthy robots: no confident false statement", "model check failed",
    "never seen moving (no verdict)",
]  # fmt: skip


Rows = Iterable[tuple[Sequence[str], Sequence[AtlasVerdict]]]


def _table(keys: Sequence[str], rows: Rows) -> str:
    lines = [
        "| " + " | ".join([*keys, *_HEAD]) + " |",
        "| " + " | ".join(["---"] * (len(keys) + len(_HEAD))) + " |",
    ]
    for key, sel in rows:
        m = measures(sel)
        lines.append("| " + " | ".join([*key, *_cells(m, m.n >= MIN_ROW)]) + " |")
    return "\n".join(lines)


def _strength(a: AtlasVerdict) -> str:
    return "none" if a.strength is None else f"{a.strength:g}"


AXES: Mapping[str, Callable[[AtlasVerdict], Any]] = {
    "world": lambda a: a.base.world,
    "data path": lambda a: DATA_PATHS[a.path],
    "fault": lambda a: a.kind,
    "strength": _strength,
    "view": lambda a: f"{a.base.observability:g}",
    "record length": lambda a: a.length,
    "scenario": lambda a: a.scenario,
}
"""The atlas's axes, each as the value an item has on it."""


def _by(items: Sequence[AtlasVerdict], *keys: Callable[[AtlasVerdict], Any]):
    """Items grouped by the values of ``keys``, in sorted order of the values."""
    groups: dict[tuple[Any, ...], list[AtlasVerdict]] = {}
    for a in items:
        groups.setdefault(tuple(k(a) for k in keys), []).append(a)
    return sorted(groups.items(), key=lambda kv: tuple(map(_order, kv[0])))


def _order(value: Any) -> tuple[int, Any]:
    path_rank = {label: k for k, label in enumerate(DATA_PATHS.values())}
    if value in path_rank:
        return (0, path_rank[value])
    return (1, value) if isinstance(value, int | float) else (2, str(value))


def _strong_full_view(a: AtlasVerdict) -> bool:
    return a.base.observability == 1.0 and a.strength is not None and a.strength <= STRONG


def targets_markdown(items: Sequence[AtlasVerdict]) -> str:
    """The targets and whether the atlas meets them."""
    m = measures(items)
    cross = (AXES["world"], AXES["data path"], AXES["fault"])
    held_rows = [
        sel
        for keys in (*([k] for k in AXES.values()), cross)
        for _, sel in _by(items, *keys)
        if measures(sel).n >= MIN_ROW
    ]
    false_rows = sum(measures(s).false_share > TARGETS["false per row"] for s in held_rows)
    ece_rows = sum(measures(s).ece > TARGETS["ece per row"] for s in held_rows)
    lines = [
        "| target | measured |",
        "| --- | --- |",
        f"| confidently false ≤ {TARGETS['false overall']:.0%} overall | "
        f"{_share(m.false, m.n, TARGETS['false overall'])} |",
        f"| ECE ≤ {TARGETS['ece overall']:g} overall | "
        + (f"**{m.ece:.3f}**" if m.ece > TARGETS["ece overall"] else f"{m.ece:.3f}")
        + " |",
        f"| confidently false ≤ {TARGETS['false per row']:.0%} in every row with ≥ {MIN_ROW} "
        f"verdicts (per axis value, per world × data path × fault) | {false_rows} of "
        f"{len(held_rows)} rows miss |",
        f"| ECE ≤ {TARGETS['ece per row']:g} in every such row | "
        f"{ece_rows} of {len(held_rows)} rows miss |",
    ]
    strong = [a for a in items if _strong_full_view(a) and a.damaged]
    for (world, path), sel in _by(strong, AXES["world"], lambda a: a.path):
        s = measures(sel)
        alone = (
            f"; alone {_share(s.alone, s.damaged, TARGETS['alone'], above=True)} "
            f"(≥ {TARGETS['alone']:.0%})"
            if path in POSE_PATHS
            else f"; alone {_share(s.alone, s.damaged)}"
        )
        lines.append(
            f"| full view, strength ≤ 0.6 or 0.7, {world}, {DATA_PATHS[path]}: damaged part "
            f"named ≥ {TARGETS['named']:.0%}"
            + (f", alone ≥ {TARGETS['alone']:.0%}" if path in POSE_PATHS else "")
            + f" | {_share(s.alone + s.among, s.damaged, TARGETS['named'], above=True)}{alone} |"
        )
    for (path,), sel in _by([a for a in items if not a.damaged], lambda a: a.path):
        s = measures(sel)
        lines.append(
            f"| healthy robots, {DATA_PATHS[path]}: no confident false statement ≥ "
            f"{TARGETS['healthy']:.0%} | "
            f"{_share(s.healthy_ok, s.healthy, TARGETS['healthy'], above=True)} |"
        )
    return "\n".join(lines)


def _worst_cells(items: Sequence[AtlasVerdict], k: int = 12, least: int = 4) -> str:
    """The cells world × data path × scenario × view × fault with at least ``least`` verdicts,
    by their share of confidently false statements."""
    keys = (AXES["world"], AXES["data path"], AXES["scenario"], AXES["view"], AXES["fault"])
    cells = [(key, sel) for key, sel in _by(items, *keys) if len(sel) >= least]
    cells.sort(key=lambda kv: (-measures(kv[1]).false_share, -len(kv[1])))
    cells = [kv for kv in cells[:k] if measures(kv[1]).false]
    if not cells:
        return f"No cell with {least} verdicts or more has a confidently false statement."
    return _table(
        ["world", "data path", "scenario", "view", "fault"],
        [([str(x) for x in key], sel) for key, sel in cells],
    )


def _worst_verdicts(items: Sequence[AtlasVerdict], k: int = 10) -> str:
    """The most confident false statements, each with the commands that reproduce it."""
    wrong = sorted((a for a in items if a.base.confident_false), key=lambda a: -a.base.confidence)
    if not wrong:
        return "No statement is confidently false."
    lines = []
    for a in wrong[:k]:
        said = " or ".join(a.base.verdict) or "no part"
        if a.base.also:
            said += "; besides, " + ", ".join(f"{f} at {p:.2f}" for f, p in a.base.also)
        truth = ", ".join(a.base.truth) or "none"
        lines += [
            f"- {a.base.world}, {DATA_PATHS[a.path]}, {a.scenario}, view {a.base.observability:g}"
            f", {a.length} steps, {a.base.damage}: {a.base.robot} said **{said}** at "
            f"{a.base.confidence:.3f} (damaged: {truth}; seen on {a.seen} steps"
            + (f"; model check: {a.fit}" if a.fit is not None else "")
            + ")",
            f"  `{a.commands[0]}` then `{a.commands[1]}`",
        ]
    return "\n".join(lines)


def _figure(items: Sequence[AtlasVerdict], figdir: Path) -> str:
    """Reliability diagrams, one panel per world, one line per data path."""
    worlds = sorted({a.base.world for a in items})
    fig = Figure(figsize=(4.6 * len(worlds), 4.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(worlds)))
    for ax, world in zip(axes, worlds, strict=True):
        ax.plot([0, 1], [0, 1], ":", color="gray", label="perfect calibration")
        for k, path in enumerate(DATA_PATHS):
            sel = [a.base for a in items if a.base.world == world and a.path == path and a.stated]
            rows = reliability_table(sel)
            if rows:
                # the pose CSV and the MCAP file often agree: dashes keep both lines visible
                style = ("-o", "--s", ":^")[k % 3]
                ax.plot([r[3] for r in rows], [r[4] for r in rows], style, ms=4, color=f"C{k}",
                        label=f"{DATA_PATHS[path]} ({len(sel)})")  # fmt: skip
        ax.set_xlim(0.4, 1.01)
        ax.set_ylim(0.0, 1.02)
        ax.set_xlabel("verdict confidence (bin mean)")
        ax.set_ylabel("share of verdicts that are right")
        ax.set_title(f"{world} world", fontsize=9)
        ax.legend(fontsize=8, loc="lower right")
    figdir.mkdir(parents=True, exist_ok=True)
    for ext in ("png", "svg"):
        fig.savefig(figdir / f"atlas.{ext}", dpi=150 if ext == "png" else None)
    return "figures/atlas.png"


def _column_mean(rows: Sequence[Mapping[str, Any]]) -> Callable[..., float]:
    """The mean over ``rows`` of the sum of some columns (missing: 0)."""

    def mean(*cols: str) -> float:
        return float(np.mean([sum(float(r.get(c) or 0) for c in cols) for r in rows]))

    return mean


def costs_markdown(gs: Sequence[Group]) -> str:
    """CPU seconds of each command per run, and per verdict, by world × scenario × length."""
    groups: dict[tuple[Any, ...], list[Mapping[str, Any]]] = {}
    for g in gs:
        c = g.condition
        groups.setdefault((c.world, c.scenario, c.obs_steps), []).extend(g.rows)
    lines = [
        "| world | scenario | length | runs | simulations (both) | learn: "
        + " | learn: ".join(DATA_PATHS.values())
        + " | CPU per verdict |",
        "| --- | --- | --- | --- | --- | --- |" + " --- |" * len(DATA_PATHS),
    ]
    total = 0.0
    for (world, scenario, length), rows in sorted(groups.items()):
        mean = _column_mean(rows)
        cpu = [sum(float(v) for k, v in r.items() if k.startswith("time.") and v) for r in rows]
        verdicts = sum(1 for r in rows for k in r if k.startswith("confidence."))
        total += sum(cpu)
        lines.append(
            f"| {world} | {scenario} | {length} | {len(rows)} | "
            f"{mean('time.simulate', 'time.simulate-mcap'):.1f} | "
            + " | ".join(f"{mean(f'time.learn.{p}'):.1f}" for p in DATA_PATHS)
            + f" | {sum(cpu) / max(verdicts, 1):.2f} |"
        )
    lines += ["", f"CPU of these runs: {total / 3600:.2f} h (the table: seconds per run, mean)."]
    design = EXPERIMENTS["atlas"].conditions if "atlas" in EXPERIMENTS else ()
    estimate = estimate_cpu(gs, design)
    if estimate is not None:
        lines.append(
            f"Estimated CPU of all {len(design)} design points, one run each: "
            f"{estimate / 3600:.1f} h (per world and scenario, CPU per run linear in the record "
            "length, fitted to these runs)."
        )
    return "\n".join(lines)


def estimate_cpu(gs: Sequence[Group], design: Sequence[Condition]) -> float | None:
    """CPU seconds that one run of each of ``design``'s points would take, from the stored runs.

    Per (world, scenario), CPU per run fitted by least squares as linear in the record length;
    where the runs have one length, the line through their mean with the slope per robot and step
    of the world's runs.

    Parameters
    ----------
    gs : sequence of Group
        The stored runs.
    design : sequence of Condition
        The design points to estimate.

    Returns
    -------
    float or None
        The total; None when a (world, scenario) of ``design`` has no stored run.
    """
    runs: dict[tuple[str, str], list[tuple[int, int, float]]] = {}
    for g in gs:
        c = g.condition
        for r in g.rows:
            cpu = sum(float(v) for k, v in r.items() if k.startswith("time.") and v)
            robots = sum(k.startswith("truth.") for k in r)
            runs.setdefault((c.world, c.scenario), []).append((c.obs_steps, robots, cpu))
    lines: dict[tuple[str, str], tuple[float, float]] = {}  # (intercept, slope)
    for (world, scenario), rs in runs.items():
        x = np.array([n for n, _, _ in rs], dtype=float)
        y = np.array([t for _, _, t in rs])
        if len(set(x)) > 1:
            slope, intercept = np.polyfit(x, y, 1)
        else:
            pooled = [(n * k, t) for (w, _), more in runs.items() if w == world for n, k, t in more]
            px = np.array([a for a, _ in pooled], dtype=float)
            per_robot_step = np.polyfit(px, [t for _, t in pooled], 1)[0] if len(set(px)) > 1 else 0
            slope = per_robot_step * rs[0][1]
            intercept = y.mean() - slope * x.mean()
        lines[(world, scenario)] = (float(intercept), float(slope))
    total = 0.0
    for c in design:
        if (c.world, c.scenario) not in lines:
            return None
        intercept, slope = lines[(c.world, c.scenario)]
        total += max(intercept + slope * c.obs_steps, 0.0)
    return total


def _agreement(items: Sequence[AtlasVerdict]) -> str:
    """How often the pose CSV's and the MCAP file's verdicts (the same poses) agree."""
    by_key = {(a.base.damage, a.base.world, a.scenario, a.length, a.base.observability,
               a.base.run, a.base.robot, a.path): a for a in items}  # fmt: skip
    first, second = POSE_PATHS
    pairs = [(a, by_key.get((*key[:-1], second))) for key, a in by_key.items() if key[-1] == first]
    both = [(a, b) for a, b in pairs if b is not None]
    same = sum(
        a.base.verdict == b.base.verdict and abs(a.base.confidence - b.base.confidence) < 1e-3
        for a, b in both
    )
    return (
        f"The pose CSV and the MCAP file hold the same poses: their verdicts agree (parts and "
        f"confidence within 0.001) on {same} of {len(both)} robots."
    )


def _refusals(gs: Sequence[Group]) -> str:
    counts: dict[str, int] = {}
    first: dict[str, str] = {}
    for g in gs:
        for r in g.rows:
            for p in DATA_PATHS:
                msg = r.get(f"refused.{p}")
                if msg:
                    counts[p] = counts.get(p, 0) + 1
                    first.setdefault(p, str(msg))
    if not counts:
        return "`mirl learn` refused no file."
    return "`mirl learn` refused " + "; ".join(
        f"{n} {DATA_PATHS[p]} files (first: {first[p]})" for p, n in counts.items()
    ) + "."


def atlas_markdown(gs: list[Group], figdir: Path) -> str:
    """The atlas's section of ``report.md``.

    Parameters
    ----------
    gs : list of Group
        The stored atlas runs by design point.
    figdir : Path
        The folder the figure is written into.

    Returns
    -------
    str
        Markdown: the figure, the measures per axis and per cell, and against the targets.
    """
    items = atlas_items(gs)
    if not items:
        return "No verdicts were stored for these runs."
    png = _figure(items, figdir)
    per_axis = _table(
        ["axis", "value"],
        [([name, str(key[0])], sel) for name, fn in AXES.items() for key, sel in _by(items, fn)],
    )
    per_cell = _table(
        ["world", "data path", "fault"],
        [
            ([str(x) for x in key], sel)
            for key, sel in _by(items, AXES["world"], AXES["data path"], AXES["fault"])
        ],
    )
    per_strength = _table(
        ["world", "data path", "strength"],
        [
            ([str(x) for x in key], sel)
            for key, sel in _by(items, AXES["world"], AXES["data path"], AXES["strength"])
        ],
    )
    runs = sum(g.n for g in gs)
    m = measures(items)
    counted = expected_calibration_error([a.base for a in items])
    return "\n".join(
        [
            f"{m.n} verdicts from {runs} runs of {len(gs)} design points, "
            f"{len(DATA_PATHS)} data paths each. Bold: a target missed (rows with at least "
            f"{MIN_ROW} verdicts).",
            "",
            f"Robots L never saw move have no verdict ({m.unseen} robot-paths): they are left "
            "out of the verdicts, the confidently false statements and the calibration, and "
            "counted in the damaged and healthy robots' columns (a damaged one is not named). "
            "Their `confidence` is the prior's probability that no part is damaged; counted as "
            f"verdicts at it, the ECE would be {counted:.3f}.",
            "",
            f"![reliability of the atlas's verdicts]({png})",
            "",
            "**Targets**",
            "",
            targets_markdown(items),
            "",
            "**Per value of each axis**",
            "",
            per_axis,
            "",
            "**Per world × data path × fault**",
            "",
            per_cell,
            "",
            per_strength,
            "",
            "**The cells with the most confidently false statements**",
            "",
            _worst_cells(items),
            "",
            "**The most confident false statements**",
            "",
            _worst_verdicts(items),
            "",
            _agreement(items) + " " + _refusals(gs),
            "",
            "**CPU seconds per run** (each command a fresh process)",
            "",
            costs_markdown(gs),
        ]
    )
