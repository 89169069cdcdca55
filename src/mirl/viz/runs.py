"""Drawing one penetration run: the map with the cells L sees, the patrollers' true paths while L
was moving, L's path and the detection events; beside it the go values of the executed plan.

The map panel is the run's world's drawing, named by its row of :data:`mirl.worlds.WORLDS`
(:func:`draw_run`, the grid trace, unless the world draws itself, as the physics world does with
:func:`mirl.viz.physics_run.draw_physical_run`). Only matplotlib's object API is used (no
pyplot), like :mod:`mirl.viz.maps`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mirl._registry import resolve
from mirl.experiments.records import RunResult
from mirl.viz.maps import MAP_COLORS, draw_map
from mirl.world.scenario import Scenario
from mirl.worlds.registry import get_world

__all__ = ["ROBOT_COLORS", "draw_run", "run_figure", "save_run_png"]

ROBOT_COLORS = ("#1f77b4", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf")
OBSERVER_COLOR = "#111111"


def _span(result: RunResult, context: int) -> tuple[int, int]:
    """Time span drawn: L's trip (from ``context`` steps before it left), or the last
    ``context`` steps when L never went."""
    if result.go_time is None:
        return max(0, result.end_time - context), result.end_time
    return max(0, result.go_time - context), result.end_time


def draw_run(ax, scenario: Scenario, result: RunResult, *, context: int = 0):
    """Draw a grid run on ``ax`` (cell (r, c) at x = c, y = r).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The map panel.
    scenario : Scenario
        The run's scenario.
    result : RunResult
        The run.
    context : int, default 0
        Steps drawn before L left (at least 40 when L never left).

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    gridmap = scenario.map
    draw_map(ax, gridmap, gridmap.visible_mask(result.observability), legend=False)
    dom = scenario.domain
    t0, t1 = _span(result, context if result.go_time is not None else max(context, 40))
    n = len(result.robot_names)
    handles = []
    if scenario.goal is not None:  # the run's goal, apart from the map's other goal rooms
        gr, gc = scenario.goal
        size = max(10.0, 240.0 / max(gridmap.shape))
        (goal,) = ax.plot(gc, gr, "*", color=MAP_COLORS["goal"], mec="k", mew=1, ms=size, zorder=6)
        goal.set_label(f"L's goal {(gr, gc)}")
        handles.append(goal)
    for i, name in enumerate(result.robot_names):
        states = result.true_states[t0 : t1 + 1, i]
        rc = dom.states[states][:, :2].astype(float)
        off = (i - (n - 1) / 2) * 0.18  # side by side where both patrol the same cells
        color = ROBOT_COLORS[i % len(ROBOT_COLORS)]
        (line,) = ax.plot(rc[:, 1] + off, rc[:, 0] + off, "-", color=color, lw=1.6, alpha=0.8)
        ax.plot(rc[0, 1] + off, rc[0, 0] + off, "o", color=color, ms=5)
        h = dom.states[states[-1], 2]
        dr, dc = ((0, 1), (-1, 0), (0, -1), (1, 0))[h]
        ax.annotate(
            "",
            xy=(rc[-1, 1] + off + 0.45 * dc, rc[-1, 0] + off + 0.45 * dr),
            xytext=(rc[-1, 1] + off, rc[-1, 0] + off),
            arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.5},
        )
        line.set_label(f"{name} (t={t0}…{t1})")
        handles.append(line)
    if len(result.observer_path):
        p = result.observer_path
        (line,) = ax.plot(p[:, 2], p[:, 1], "-", color=OBSERVER_COLOR, lw=3.0, alpha=0.9)
        ax.plot(p[-1, 2], p[-1, 1], "s", color=OBSERVER_COLOR, ms=6)
        line.set_label(f"L (left t={result.go_time}) — {result.outcome}")
        handles.append(line)
    for d in result.detections:
        (mark,) = ax.plot(
            d.observer_cell[1], d.observer_cell[0], "X", color="#ff2222", ms=14, mec="k", zorder=5
        )
        rr, cc, _ = d.robot_state
        ax.plot([cc, d.observer_cell[1]], [rr, d.observer_cell[0]], "--", color="#ff2222", lw=1.5)
        mark.set_label(f"seen by {d.robot} at t={d.t}")
        handles.append(mark)
    ax.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.1),
        fontsize="small",
        frameon=False,
    )
    ax.set_title(f"{scenario.name}, {result.method}, seed {result.seed}", fontsize="medium")
    return ax


def draw_go_values(ax, result: RunResult):
    """The executed (or last) plan's value of leaving at each go time, with the decision."""
    plan = result.plan
    if plan is None:
        ax.text(0.5, 0.5, "no plan (random baseline)", ha="center", va="center")
        ax.set_axis_off()
        return ax
    t = plan.t0 + np.arange(len(plan.go_values))
    ax.plot(t, plan.go_values, "-", color="#333333", lw=1.5, label="value of going at t")
    ax.axhline(0.0, color="0.6", lw=1)
    if result.go_time is not None:
        ax.axvline(result.go_time, color="#2ca02c", lw=1.5, label=f"went at t={result.go_time}")
    ax.set_xlabel("go time t")
    from matplotlib.ticker import MaxNLocator  # here: drawing is the only user of matplotlib

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # steps: no 145.5 on short plans
    ax.set_ylabel("value of L's start state")
    ax.set_title(f"plan made at t={plan.t0} ({len(result.attempts)} rounds)", fontsize="medium")
    ax.legend(fontsize="small", frameon=False)
    return ax


def run_figure(scenario: Scenario, result: RunResult, *, context: int | None = None):
    """A new ``Figure`` with the map panel and the go-value panel.

    The map panel is the drawing of the run's world (its row's ``drawing`` in
    :data:`mirl.worlds.WORLDS`).

    Parameters
    ----------
    scenario : Scenario
        The run's scenario.
    result : RunResult
        The run.
    context : int, optional
        Steps drawn before L left; None: that drawing's default.

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure.
    axes : (matplotlib.axes.Axes, matplotlib.axes.Axes)
        The map and go-value panels.
    """
    from matplotlib.figure import Figure

    rows, cols = scenario.map.shape
    scale = 0.32 if max(rows, cols) <= 30 else 9.0 / max(rows, cols)
    fig = Figure(figsize=(cols * scale + 6.0, max(rows * scale + 2.0, 4.5)))
    grid = fig.add_gridspec(1, 2, width_ratios=[cols * scale + 1.0, 4.5])
    ax_map = fig.add_subplot(grid[0, 0])
    ax_val = fig.add_subplot(grid[0, 1])
    draw = resolve(get_world(result.world).drawing)
    draw(ax_map, scenario, result, **({} if context is None else {"context": context}))
    draw_go_values(ax_val, result)
    fig.tight_layout()
    return fig, (ax_map, ax_val)


def save_run_png(scenario: Scenario, result: RunResult, path: str | Path) -> Path:
    """Write the run's figure (:func:`run_figure`).

    Parameters
    ----------
    scenario : Scenario
        The run's scenario.
    result : RunResult
        The run.
    path : str or Path
        The file; the format follows the suffix (``.png`` by default).

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    fig, _ = run_figure(scenario, result)
    path.parent.mkdir(parents=True, exist_ok=True)
    # "tight" takes in the legend under the map, which tight_layout leaves out: with a team,
    # L and detections its last entries fell off the bottom of the image
    fig.savefig(path, format=path.suffix.lstrip(".").lower() or "png", dpi=130, bbox_inches="tight")
    return path
