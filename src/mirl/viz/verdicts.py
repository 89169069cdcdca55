"""The calibration of the fault verdicts (``mirl experiment verdicts``): a reliability diagram of
verdict confidence against how often the verdict is right, its table, the expected calibration
error, the confident-and-wrong and false-alarm rates, and the verdict rates per damaged
(robot, wheel), world and view (docs/design.md, "Fault verdicts").

A verdict is right when the part it names is damaged; when one of its candidates is ("cannot
tell which"); or, naming none, when no part is. The truth is the world's
(:meth:`~mirl.worlds.contract.World.damaged_parts` of the world's class): on the grid a success
probability below the scenario's damage threshold, in the physics world a motor weaker than a
healthy one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from mirl.learning.verdicts import parse_also_field
from mirl.viz.aggregate import Group

__all__ = [
    "VerdictItem",
    "verdict_items",
    "EDGES",
    "reliability_table",
    "expected_calibration_error",
    "verdicts_markdown",
]

EDGES = (0.0, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99, 1.0)
"""Confidence bins of the reliability diagram (the last bin includes 1)."""
CONFIDENT = 0.9
"""A verdict at least this confident counts as confident."""


@dataclass(frozen=True)
class VerdictItem:
    """One robot's verdict in one run.

    Parameters
    ----------
    world : str
        The world the run ran in (``"grid"``, ``"physics"``).
    observability : float
        The run's observability d, the share of the map the observer sees.
    damage : str or None
        The condition's damaged part as ``"ROBOT:FEATURE"``; None for a healthy condition.
    robot : str
        The robot the verdict is about.
    run : int
        The run's index within its condition.
    verdict : tuple of str
        The parts the verdict names: one part, several candidates ("cannot tell which"), or
        none ("no part is damaged").
    confidence : float
        The verdict's confidence, in [0, 1].
    truth : tuple of str
        The robot's truly damaged parts (empty for a healthy robot).
    right : bool
        Whether the verdict is right (see the module's docstring).
    also : tuple of (str, float), default ()
        The parts the verdict says are damaged besides those it names, each with its
        probability of damage (:attr:`~mirl.learning.verdicts.Verdict.also`).
    """

    world: str
    observability: float
    damage: str | None  # the condition's damaged "ROBOT:FEATURE"
    robot: str
    run: int
    verdict: tuple[str, ...]  # the parts named (none: "no part is damaged")
    confidence: float
    truth: tuple[str, ...]
    right: bool
    also: tuple[tuple[str, float], ...] = ()  # damaged besides the parts named, with P

    @property
    def confident_wrong(self) -> bool:
        """A confident verdict naming damage that is not there."""
        return self.confidence >= CONFIDENT and bool(self.verdict) and not self.right

    @property
    def confident_false(self) -> bool:
        """A confident statement naming no damaged part: a part that is not damaged, candidates
        without a damaged one, or "no part" of a damaged robot (the calibration atlas's
        measure; unlike :attr:`confident_wrong`, it counts a confident "no part" too); or a
        part said damaged besides the parts named, at a probability of at least 0.9, that is
        not."""
        wrong_besides = any(p >= CONFIDENT and f not in self.truth for f, p in self.also)
        return (self.confidence >= CONFIDENT and not self.right) or wrong_besides

    @property
    def false_alarm(self) -> bool:
        """A healthy robot confidently said to be damaged."""
        return not self.truth and bool(self.verdict) and self.confidence >= CONFIDENT


def verdict_items(gs: Sequence[Group]) -> list[VerdictItem]:
    """Every stored verdict of every run of ``gs``.

    Parameters
    ----------
    gs : sequence of Group
        The experiment's conditions and their stored rows; a row holds
        ``confidence.ROBOT``, ``verdict.ROBOT``, ``truth.ROBOT`` and ``right.ROBOT`` for each
        robot with a verdict, and ``also.ROBOT`` where it says parts are damaged besides.

    Returns
    -------
    list of VerdictItem
        One item per robot with a verdict per row, in the groups' and rows' order, robots by
        name; none for a robot L never saw move (``unseen.ROBOT``), whose confidence is the
        prior's.
    """
    out = []
    for g in gs:
        c = g.condition
        for row in g.rows:
            robots = sorted(k.split(".", 1)[1] for k in row if k.startswith("confidence."))
            for robot in robots:
                if row.get(f"unseen.{robot}"):  # never seen moving: no verdict to score
                    continue
                named = str(row.get(f"verdict.{robot}") or "")
                truth = str(row.get(f"truth.{robot}") or "")
                out.append(
                    VerdictItem(
                        c.world, c.observability, c.damage, robot, int(row.get("run", 0)),
                        tuple(named.split(",")) if named else (),
                        float(row[f"confidence.{robot}"]),
                        tuple(truth.split(",")) if truth else (),
                        bool(row[f"right.{robot}"]),
                        parse_also_field(row.get(f"also.{robot}")),
                    )
                )  # fmt: skip
    return out


def reliability_table(
    items: Sequence[VerdictItem], edges: Sequence[float] = EDGES
) -> list[tuple[float, float, int, float, float]]:
    """Per confidence bin with verdicts: (low, high, n, mean confidence, share right).

    Parameters
    ----------
    items : sequence of VerdictItem
        The verdicts.
    edges : sequence of float, default EDGES
        The bins' edges, increasing; a bin holds [low, high), the last [low, high].

    Returns
    -------
    list of tuple of (float, float, int, float, float)
        One row per bin holding at least one verdict, in the edges' order: its edges, the
        number of verdicts, their mean confidence and the share of them that is right.
    """
    conf = np.array([i.confidence for i in items])
    right = np.array([i.right for i in items], dtype=float)
    rows = []
    for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        last = k == len(edges) - 2
        sel = (conf >= lo) & ((conf <= hi) if last else (conf < hi))
        if sel.any():
            rows.append((lo, hi, int(sel.sum()), float(conf[sel].mean()), float(right[sel].mean())))
    return rows


def expected_calibration_error(
    items: Sequence[VerdictItem], edges: Sequence[float] = EDGES
) -> float:
    """Σ_b (n_b / n) |share right_b − mean confidence_b| over the bins (Naeini et al. 2015).

    Parameters
    ----------
    items : sequence of VerdictItem
        The verdicts.
    edges : sequence of float, default EDGES
        The bins' edges, as for :func:`reliability_table`.

    Returns
    -------
    float
        The expected calibration error, in [0, 1]; NaN when no verdict falls in a bin.
    """
    rows = reliability_table(items, edges)
    n = sum(r[2] for r in rows)
    return float(sum(r[2] * abs(r[4] - r[3]) for r in rows) / n) if n else float("nan")


def _share(flags: Sequence[bool]) -> str:
    flags = list(flags)
    if not flags:
        return "–"
    return f"{np.mean(flags):.3f} ({sum(flags)}/{len(flags)})"


def _reliability_figure(items: Sequence[VerdictItem], figdir: Path) -> str:
    fig = Figure(figsize=(5.2, 4.6), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], ":", color="gray", label="perfect calibration")
    worlds = sorted({i.world for i in items})
    for k, world in enumerate([None, *worlds]):
        sel = [i for i in items if world is None or i.world == world]
        rows = reliability_table(sel)
        conf = [r[3] for r in rows]
        acc = [r[4] for r in rows]
        n = [r[2] for r in rows]
        label = f"all ({len(sel)})" if world is None else f"{world} ({len(sel)})"
        ax.plot(conf, acc, "-o" if world is None else "--s", color=f"C{k}", label=label, ms=4)
        if world is None:
            for x, y, m in zip(conf, acc, n, strict=True):
                ax.annotate(str(m), (x, y), textcoords="offset points", xytext=(4, -10), fontsize=7)
    ax.set_xlim(0.4, 1.01)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("verdict confidence (bin mean)")
    ax.set_ylabel("share of verdicts that are right")
    ax.set_title("Fault verdicts: reliability (numbers: verdicts per bin)", fontsize=9)
    ax.legend(fontsize=8, loc="lower right")
    figdir.mkdir(parents=True, exist_ok=True)
    for ext in ("png", "svg"):
        fig.savefig(figdir / f"verdicts.{ext}", dpi=150 if ext == "png" else None)
    return "figures/verdicts.png"


def _kind(item: VerdictItem, wheel: str) -> str:
    if item.verdict == (wheel,):
        return "wheel"
    if wheel in item.verdict:
        return "among"
    return "none" if not item.verdict else "other"


def rates_markdown(items: Sequence[VerdictItem]) -> str:
    """Per world, view and damaged (robot, wheel): how often the damaged robot's verdict names
    the wheel, names it among candidates, names no part or names another part."""
    lines = [
        "| world | d | damaged | n | the wheel | among candidates | no part | another part | "
        "mean confidence | other robot: no part |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    keys = sorted({(i.world, i.observability, i.damage or "") for i in items})
    for world, d, damage in keys:
        sel = [i for i in items if (i.world, i.observability, i.damage or "") == (world, d, damage)]
        if not damage:
            healthy = _share([not i.verdict for i in sel])
            lines.append(
                f"| {world} | {d:g} | none | {len({i.run for i in sel})} | – | – | {healthy} | – | "
                f"{np.mean([i.confidence for i in sel]):.2f} | – |"
            )
            continue
        robot, wheel = damage.split(":")
        own = [i for i in sel if i.robot == robot]
        other = [i for i in sel if i.robot != robot]
        kinds = [_kind(i, wheel) for i in own]
        cells = [_share([k == x for k in kinds]) for x in ("wheel", "among", "none", "other")]
        lines.append(
            f"| {world} | {d:g} | {robot}'s {wheel.replace('_', ' ')} | {len(own)} | "
            + " | ".join(cells)
            + f" | {np.mean([i.confidence for i in own]):.2f} | "
            f"{_share([not i.verdict for i in other])} |"
        )
    return "\n".join(lines)


def verdicts_markdown(gs: list[Group], figdir: Path) -> str:
    """The experiment's section of ``report.md``.

    Writes the reliability diagram as ``verdicts.png`` and ``verdicts.svg`` into ``figdir``
    when there are verdicts.

    Parameters
    ----------
    gs : list of Group
        The experiment's conditions and their stored rows.
    figdir : pathlib.Path
        The directory the figures go to (created if missing).

    Returns
    -------
    str
        The section's Markdown: the diagram, its table, the calibration measures per world and
        the verdict rates per damaged part; a one-line note when no verdicts were stored.
    """
    items = verdict_items(gs)
    if not items:
        return "No verdicts were stored for these runs."
    png = _reliability_figure(items, figdir)
    runs = {(i.world, i.observability, i.damage, i.run) for i in items}
    wrong_runs = {(i.world, i.observability, i.damage, i.run) for i in items if i.confident_wrong}
    healthy = [i for i in items if not i.truth]
    lines = [
        f"![reliability of the fault verdicts]({png})",
        "",
        "| confidence | verdicts | mean confidence | share right |",
        "| --- | --- | --- | --- |",
        *(
            f"| {lo:.2f}–{hi:.2f} | {n} | {c:.3f} | {a:.3f} |"
            for lo, hi, n, c, a in reliability_table(items)
        ),
        "",
        "| measure | all | " + " | ".join(sorted({i.world for i in items})) + " |",
        "| --- | --- |" + " --- |" * len({i.world for i in items}),
    ]
    worlds = sorted({i.world for i in items})

    def by_world(fn) -> str:
        return " | ".join([fn(items), *(fn([i for i in items if i.world == w]) for w in worlds)])

    lines += [
        "| expected calibration error (target ≤ 0.05) | "
        + by_world(lambda s: f"{expected_calibration_error(s):.3f}")
        + " |",
        f"| confident (≥ {CONFIDENT:g}) and wrong, per robot verdict (target ≤ 0.05) | "
        + by_world(lambda s: _share([i.confident_wrong for i in s]))
        + " |",
        f"| healthy robot confidently (≥ {CONFIDENT:g}) called damaged (target ≤ 0.05) | "
        + by_world(lambda s: _share([i.false_alarm for i in s if not i.truth]))
        + " |",
        "",
        f"Runs with a confident-and-wrong verdict on either robot: {len(wrong_runs)} of "
        f"{len(runs)} ({len(wrong_runs) / len(runs):.3f}); healthy robots: {len(healthy)}.",
        "",
        "Verdict rates for the damaged robot (and how often the other, healthy robot gets "
        '"no part is damaged"):',
        "",
        rates_markdown(items),
    ]
    return "\n".join(lines)
