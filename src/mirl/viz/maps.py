"""Drawing grid maps: matplotlib axes (for figures) and plain text (for ``mirl show-map``).

Coordinates: every drawing helper puts cell ``(row, col)`` at its centre ``x = col``,
``y = row`` with row 0 at the top, so later layers (patroller paths, L's path) can be plotted on
the same axes with ``ax.plot(cols, rows)``. Only the object API (``matplotlib.figure.Figure``) is
used, so importing this module never switches the global matplotlib backend.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from mirl.world.maps import GridMap

__all__ = [
    "MAP_COLORS",
    "TEXT_LEGEND",
    "draw_map",
    "draw_metres",
    "draw_routes",
    "map_figure",
    "map_to_text",
    "save_map_png",
]

MAP_COLORS = {
    "wall": "#2b2b2b",
    "hallway": "#f2f2ee",
    "room": "#cfe3f7",  # L-only cells (L's room, goal rooms)
    "visible": "#f6c85f",  # hallway cells L sees
    "grid": "#bdbdbd",
    "start": "#1f5fbf",
    "goal": "#2ca02c",
}

TEXT_LEGEND = (
    "; . hallway  # wall  L L's start  G/g goal (hallway/room)  o/O visible to L (hallway/goal)"
)


def _rgb(hex_color: str) -> np.ndarray:
    h = hex_color.lstrip("#")
    return np.array([int(h[i : i + 2], 16) / 255.0 for i in (0, 2, 4)])


def _checked_mask(gridmap: GridMap, visible_mask: np.ndarray | None) -> np.ndarray:
    if visible_mask is None:
        return np.zeros(gridmap.shape, dtype=bool)
    mask = np.asarray(visible_mask, dtype=bool)
    if mask.shape != gridmap.shape:
        raise ValueError(
            f"visible_mask has shape {mask.shape}, map {gridmap.name} is {gridmap.shape}"
        )
    return mask & gridmap.patroller  # only patroller cells can be seen


def draw_map(ax, gridmap: GridMap, visible_mask: np.ndarray | None = None, *, legend: bool = True):
    """Draw ``gridmap`` on matplotlib axes ``ax``.

    Walls dark, hallway light, L-only rooms pale blue, cells in ``visible_mask`` amber; L's start
    is a blue triangle, goals green stars. Cell ``(r, c)`` is centred at ``x = c, y = r`` with
    row 0 at the top and square cells.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    gridmap : GridMap
        The map.
    visible_mask : ndarray of bool, shape (rows, cols), optional
        Cells shaded as visible to L.
    legend : bool, default True
        Draw the legend beside the map.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.

    Raises
    ------
    ValueError
        A mask of another shape than the map's.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    rows, cols = gridmap.shape
    visible = _checked_mask(gridmap, visible_mask)
    img = np.empty((rows, cols, 3))
    img[:] = _rgb(MAP_COLORS["wall"])
    img[gridmap.patroller] = _rgb(MAP_COLORS["hallway"])
    img[gridmap.observer_only] = _rgb(MAP_COLORS["room"])
    img[visible] = _rgb(MAP_COLORS["visible"])
    ax.imshow(
        img,
        origin="upper",
        extent=(-0.5, cols - 0.5, rows - 0.5, -0.5),
        interpolation="nearest",
        zorder=0,
    )
    if max(rows, cols) <= 40:  # cell borders help on small maps, clutter large ones
        ax.set_xticks(np.arange(-0.5, cols, 1.0), minor=True)
        ax.set_yticks(np.arange(-0.5, rows, 1.0), minor=True)
        ax.grid(which="minor", color=MAP_COLORS["grid"], linewidth=0.4)
        ax.tick_params(which="minor", length=0)
    # about 5 cells on small maps; on large ones (real floor plans, 100+ cells a side) no smaller
    # than a legible symbol, outlined to stand out on the amber view and the routes
    size = max(9.0, 160.0 / max(rows, cols))
    if not gridmap.marked:  # placeholders only: nothing of L's to draw
        ax.set_xlim(-0.5, cols - 0.5)
        ax.set_ylim(rows - 0.5, -0.5)
        ax.set_aspect("equal")
        ax.set_xlabel("col")
        ax.set_ylabel("row")
        return ax
    sr, sc = gridmap.observer_start
    ax.plot(
        [sc], [sr], marker="^", color=MAP_COLORS["start"], markersize=size, linestyle="",
        markeredgecolor="white", markeredgewidth=0.8, zorder=5,
    )  # fmt: skip
    if gridmap.goals:
        gr, gc = np.asarray(gridmap.goals).T
        ax.plot(
            gc,
            gr,
            marker="*",
            color=MAP_COLORS["goal"],
            markersize=size * 1.3,
            linestyle="",
            markeredgecolor="black",
            markeredgewidth=0.6,
            zorder=5,
        )
    ax.set_xlim(-0.5, cols - 0.5)
    ax.set_ylim(rows - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("col")
    ax.set_ylabel("row")
    if legend:
        handles = [
            Patch(facecolor=MAP_COLORS["hallway"], edgecolor="0.5", label="hallway"),
            Patch(facecolor=MAP_COLORS["wall"], label="wall"),
            Patch(facecolor=MAP_COLORS["room"], edgecolor="0.5", label="L's rooms"),
            Line2D([], [], marker="^", color=MAP_COLORS["start"], linestyle="", label="L start"),
            Line2D([], [], marker="*", color=MAP_COLORS["goal"], linestyle="", label="goal"),
        ]
        if visible.any():
            handles.insert(3, Patch(facecolor=MAP_COLORS["visible"], label="visible to L"))
        ax.legend(
            handles=handles,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            fontsize="small",
            frameon=False,
        )
    return ax


def draw_metres(ax, gridmap: GridMap) -> None:
    """Axes in metres of the map frame (top and right, beside the cells' own) and the frame's origin
    as RViz draws it (x red, y green, 1 m) where it lies on the grid.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes the map is drawn on.
    gridmap : GridMap
        The map, whose frame places the metres.
    """
    f = gridmap.frame
    top = ax.secondary_xaxis(
        "top",
        functions=(
            lambda c: f.origin_x + c * f.cell_size,
            lambda x: (x - f.origin_x) / f.cell_size,
        ),
    )
    right = ax.secondary_yaxis(
        "right",
        functions=(
            lambda r: f.origin_y - r * f.cell_size,
            lambda y: (f.origin_y - y) / f.cell_size,
        ),
    )
    top.set_xlabel("x (m)")
    right.set_ylabel("y (m)")
    r0, c0 = f.cell_coordinates(0.0, 0.0)
    rows, cols = gridmap.shape
    if -0.5 <= r0 <= rows - 0.5 and -0.5 <= c0 <= cols - 0.5:
        unit = 1.0 / f.cell_size
        head = 0.15 * unit
        ax.arrow(c0, r0, unit, 0, color="#d62728", width=0.02 * unit, head_width=head, zorder=4)
        ax.arrow(c0, r0, 0, -unit, color="#2ca02c", width=0.02 * unit, head_width=head, zorder=4)


def draw_routes(ax, routes: Mapping[str, np.ndarray]) -> None:
    """Each patroller's route as a line with its name at the start.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes the map is drawn on.
    routes : mapping of str to ndarray of shape (k, 2)
        Each patroller's cells, in order.
    """
    for i, (name, cells) in enumerate(routes.items()):
        cells = np.asarray(cells, dtype=float)
        if len(cells) == 0:
            continue
        offset = 0.12 * (i - (len(routes) - 1) / 2)  # routes over the same cells side by side
        line = ax.plot(
            cells[:, 1] + offset, cells[:, 0] + offset, linewidth=1.5, zorder=2,
            label=f"{name}'s patrol",
        )[0]  # fmt: skip
        ax.plot(
            [cells[0, 1]], [cells[0, 0]], marker="o", color=line.get_color(), linestyle="",
            zorder=3,
        )  # fmt: skip
        ax.annotate(name, (cells[0, 1], cells[0, 0]), xytext=(3, 3), textcoords="offset points",
                    color=line.get_color(), fontsize="small", zorder=4)  # fmt: skip


def map_figure(
    gridmap: GridMap,
    visible_mask: np.ndarray | None = None,
    *,
    legend: bool = True,
    routes: Mapping[str, np.ndarray] | None = None,
    metres: bool = False,
):
    """A new ``Figure`` (no pyplot, no global backend) with the map drawn.

    Parameters
    ----------
    gridmap : GridMap
        The map.
    visible_mask : ndarray of bool, shape (rows, cols), optional
        Cells shaded as visible to L.
    legend : bool, default True
        Draw the legend beside the map.
    routes : mapping of str to ndarray of shape (k, 2), optional
        Patrollers' routes drawn as lines.
    metres : bool, default False
        Add axes in metres of the map frame and its origin (:func:`draw_metres`).

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure.
    ax : matplotlib.axes.Axes
        Its map axes.
    """
    from matplotlib.figure import Figure

    rows, cols = gridmap.shape
    scale = 0.3 if max(rows, cols) <= 30 else 9.0 / max(rows, cols)
    extra = 0.6 if metres else 0.0
    fig = Figure(
        figsize=(cols * scale + (2.2 if legend else 0.8) + extra, rows * scale + 0.8 + extra)
    )
    ax = fig.add_subplot(1, 1, 1)
    draw_map(ax, gridmap, visible_mask, legend=legend)
    if routes:
        draw_routes(ax, routes)
        shown = ax.get_legend()
        if shown is not None:  # the routes join the legend: which line is which patroller
            lines = [ln for ln in ax.get_lines() if str(ln.get_label()).endswith("'s patrol")]
            ax.legend(
                handles=[*shown.legend_handles, *lines],
                loc="upper left",
                bbox_to_anchor=(1.01, 1.0),
                fontsize="small",
                frameon=False,
            )
    if metres:
        draw_metres(ax, gridmap)
        shown = ax.get_legend()
        if shown is not None:  # clear of the metre axis on the right
            shown.set_bbox_to_anchor((1.16, 1.0))
    title = gridmap.name
    if visible_mask is not None:
        n = int(_checked_mask(gridmap, visible_mask).sum())
        title += f" — {n}/{gridmap.n_patroller_cells} cells visible"
    ax.set_title(title, fontsize="medium")
    fig.tight_layout()
    return fig, ax


def save_map_png(
    gridmap: GridMap,
    path: str | Path,
    observability: float | None = None,
    *,
    routes: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write the map as an image, with axes in metres of its frame.

    Parameters
    ----------
    gridmap : GridMap
        The map.
    path : str or Path
        The file; the format follows the suffix (``.png`` default, ``.svg``…).
    observability : float, optional
        A degree in [0, 1]: shades the cells L sees at that degree.
    routes : mapping of str to ndarray of shape (k, 2), optional
        Patrollers' routes drawn as lines.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    mask = None if observability is None else gridmap.visible_mask(observability)
    fig, _ = map_figure(gridmap, mask, routes=routes, metres=True)
    fmt = path.suffix.lstrip(".").lower() or "png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, format=fmt, dpi=150)
    return path


def map_to_text(gridmap: GridMap, visible_mask: np.ndarray | None = None) -> str:
    """Plain-text map (``.#LGg`` as in the map format) with visible cells as ``o``.

    A visible hallway goal is ``O``; a ``;`` legend line (a comment in the map format) follows.

    Parameters
    ----------
    gridmap : GridMap
        The map.
    visible_mask : ndarray of bool, shape (rows, cols), optional
        Cells shaded as visible to L.

    Returns
    -------
    str
        The map's lines and the legend.
    """
    visible = _checked_mask(gridmap, visible_mask)
    chars = np.array([list(line) for line in gridmap.to_text().split("\n")])
    chars[visible & (chars == ".")] = "o"
    chars[visible & (chars == "G")] = "O"
    lines = ["".join(row) for row in chars]
    legend = TEXT_LEGEND
    if visible_mask is not None:
        n, total = int(visible.sum()), gridmap.n_patroller_cells
        # a percentage: a share written as 0.13 read as a second, different observability
        legend += f"\n; visible: {n} of {total} patroller cells ({100 * n / max(total, 1):.0f} %)"
    return "\n".join([*lines, legend])
