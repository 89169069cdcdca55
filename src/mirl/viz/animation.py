"""Animating one penetration run as a GIF (``mirl run --animate run.gif``): the map with the
cells L sees, the patrollers moving with their headings, L waiting at its door and then walking
to its goal, and the detection that ended the run, if any.

The drawing follows :mod:`mirl.viz.runs` (its colours, :func:`mirl.viz.maps.draw_map` for the
map, cell (r, c) at x = c, y = r). Patrollers are drawn from their true grid states, so a
physics-world run (``world="physics"``) animates the same way, on its grid trace. Only the
object API of matplotlib is used (no pyplot, no global backend).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mirl.experiments.records import RunResult
from mirl.viz.maps import MAP_COLORS, draw_map
from mirl.viz.runs import OBSERVER_COLOR, ROBOT_COLORS
from mirl.world.maps import HEADING_DELTAS
from mirl.world.scenario import Scenario

__all__ = ["DEFAULT_MAX_FRAMES", "animation_times", "save_run_animation"]

# 120 frames at 4 fps is a 30 s clip; at the default context the span of a run on boyd2 is
# about 50 steps, so only long trips on large maps are subsampled
DEFAULT_MAX_FRAMES = 120
DETECTION_COLOR = "#ff2222"
TRAIL = 6  # steps of each patroller's recent path drawn behind it
HOLD_SECONDS = 2.0  # the last frame (the outcome) stays this long before the GIF loops


def animation_times(result: RunResult, *, context: int = 40, max_frames: int = DEFAULT_MAX_FRAMES):
    """The time steps drawn, one per frame.

    Parameters
    ----------
    result : RunResult
        The run.
    context : int
        Steps shown before L's go time; when L never went (a timeout), the last ``context``
        steps of the run are shown instead.
    max_frames : int
        At most this many frames: a longer span is subsampled evenly, keeping its first and
        last step (the outcome).

    Returns
    -------
    numpy.ndarray
        Shape (n_frames,), increasing integer steps in ``[0, result.end_time]``.
    """
    if context < 0:
        raise ValueError(f"context must be at least 0, got {context}")
    if max_frames < 2:
        raise ValueError(f"max_frames must be at least 2, got {max_frames}")
    end = result.end_time
    start = end if result.go_time is None else result.go_time
    t0 = max(0, start - context)
    if end - t0 + 1 <= max_frames:
        return np.arange(t0, end + 1)
    # steps of the linspace exceed 1, so rounding keeps the times distinct
    return np.round(np.linspace(t0, end, max_frames)).astype(int)


def _phase(result: RunResult, t: int) -> str:
    if t >= result.end_time:
        return result.outcome
    if result.go_time is None or t < result.go_time:
        return "watching"
    return "going"


def _observer_cells(scenario: Scenario, result: RunResult, times: np.ndarray) -> np.ndarray:
    """L's (row, col) at each of ``times``, shape (len(times), 2): its start cell until it
    went, then the last entry of its path at or before t."""
    cells = np.tile(np.asarray(scenario.map.observer_start, dtype=float), (len(times), 1))
    path = result.observer_path
    if len(path):
        idx = np.searchsorted(path[:, 0], times, side="right") - 1
        went = idx >= 0
        cells[went] = path[idx[went], 1:3]
    return cells


def _figure(scenario: Scenario):
    from matplotlib.figure import Figure

    rows, cols = scenario.map.shape
    scale = 0.32 if max(rows, cols) <= 30 else 9.0 / max(rows, cols)
    width = max(cols * scale + 1.2, 4.2)  # room for the title and the legend below the map
    return Figure(figsize=(width, rows * scale + 2.4), dpi=90)


def _detection_artists(ax, result: RunResult, size: float) -> list[tuple[int, tuple]]:
    """Per detection, its step and (hidden) artists: a ring around L — the robot that saw it
    may share its cell, so nothing is drawn over them — and a dashed line from that robot."""
    seen = []
    for d in result.detections:
        (rr, cc, _), (lr, lc) = d.robot_state, d.observer_cell
        (line,) = ax.plot([cc, lc], [rr, lr], "--", color=DETECTION_COLOR, lw=2.0, zorder=9)
        (mark,) = ax.plot(lc, lr, "o", mfc="none", mec=DETECTION_COLOR, mew=3.0, ms=size * 3.2)
        mark.set_zorder(10)
        for artist in (line, mark):
            artist.set_visible(False)
        seen.append((d.t, (line, mark)))
    return seen


def save_run_animation(
    scenario: Scenario,
    result: RunResult,
    path: str | Path,
    *,
    fps: int = 4,
    context: int = 40,
    max_frames: int = DEFAULT_MAX_FRAMES,
) -> Path:
    """Write an animated GIF of one run and return its path.

    Each frame is one time step t: the map with the cells L sees at the run's observability,
    every patroller at its true state (a dot with an arrow along its heading, its last few
    steps trailing behind), L at its start cell while watching and then along its path, and a
    title with t and the phase (``watching``, ``going``, then the outcome). The detection that
    ended a run is marked from its step on. The same result always gives the same file.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario (map, domain, goal).
    result : RunResult
        The run, from :func:`mirl.experiments.episode.run_episode` (grid or physics world).
        Read: ``true_states`` (end_time + 1, N) state indices into ``scenario.domain.states``
        (rows (row, col, heading)); ``observer_path`` (n, 4) rows (t, row, col, heading) from
        the go time; ``go_time``, ``end_time``, ``outcome``, ``detections``, ``observability``.
    path : str or Path
        Where to write the GIF (parent folders are made).
    fps : int
        Frames per second; the last frame is held about two seconds longer.
    context : int
        Steps shown before L's go time, or the last steps of a run where L never went.
    max_frames : int
        At most this many frames (:func:`animation_times`); keeps a GIF small (about 0.1 MB on
        boyd2).

    Returns
    -------
    Path
        ``path``.
    """
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch, Patch

    if fps < 1:
        raise ValueError(f"fps must be at least 1, got {fps}")
    times = animation_times(result, context=context, max_frames=max_frames)
    path = Path(path)
    gridmap, dom = scenario.map, scenario.domain
    n = len(result.robot_names)

    fig = _figure(scenario)
    ax = fig.add_subplot(1, 1, 1)
    draw_map(ax, gridmap, gridmap.visible_mask(result.observability), legend=False)
    rows, cols = gridmap.shape
    size = max(5.0, 120.0 / max(rows, cols))  # robots stay visible on large maps
    handles: list = []
    if scenario.goal is not None:
        gr, gc = scenario.goal
        (goal,) = ax.plot(gc, gr, "*", color=MAP_COLORS["goal"], mec="k", mew=1, ms=size * 2.0)
        goal.set_label("goal")
        handles.append(goal)

    # one dot, arrow and trail per patroller, moved by update()
    states = dom.states[result.true_states[: result.end_time + 1]]  # (T, N, 3)
    offsets = (np.arange(n) - (n - 1) / 2) * 0.18  # side by side on a shared cell
    trails, dots, arrows = [], [], []
    for i, name in enumerate(result.robot_names):
        color = ROBOT_COLORS[i % len(ROBOT_COLORS)]
        (trail,) = ax.plot([], [], "-", color=color, lw=1.6, alpha=0.55, zorder=4)
        (dot,) = ax.plot([], [], "o", color=color, mec="k", mew=0.8, ms=size * 1.3, zorder=6)
        arrow = FancyArrowPatch(
            (0, 0), (0, 0), arrowstyle="-|>", mutation_scale=14, color=color, lw=2.0, zorder=7
        )
        ax.add_patch(arrow)
        trails.append(trail)
        dots.append(dot)
        arrows.append(arrow)
        handles.append(Line2D([], [], marker="o", color=color, mec="k", ms=6, label=name))
    handles.append(Patch(facecolor=MAP_COLORS["visible"], label="L sees"))

    observer = _observer_cells(scenario, result, times)
    (l_path,) = ax.plot([], [], "-", color=OBSERVER_COLOR, lw=3.0, alpha=0.9, zorder=5)
    (l_dot,) = ax.plot([], [], "s", color=OBSERVER_COLOR, mec="w", mew=1.0, ms=size * 1.2, zorder=8)
    l_dot.set_label("L")
    handles.append(l_dot)

    seen = _detection_artists(ax, result, size)
    if seen:
        handles.append(
            Line2D(
                [], [], marker="o", mfc="none", mec=DETECTION_COLOR, mew=2.0, ls="", label="seen"
            )
        )
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=3,
              fontsize="small", frameon=False, handletextpad=0.3, columnspacing=1.0)  # fmt: skip
    head = f"{scenario.name}, {result.method}, seed {result.seed}"
    title = ax.set_title(f"{head}\nt={result.end_time}: {result.outcome}", fontsize="medium")
    fig.tight_layout()
    # no layout engine from here on: with one, every saved frame is laid out twice
    fig.set_layout_engine(None)

    path_t = result.observer_path[:, 0] if len(result.observer_path) else np.empty(0)

    def update(k: int):
        t = int(times[k])
        for i in range(n):
            trail_rc = states[max(0, t - TRAIL) : t + 1, i, :2] + offsets[i]
            trails[i].set_data(trail_rc[:, 1], trail_rc[:, 0])
            r, c, h = states[t, i]
            y, x = r + offsets[i], c + offsets[i]
            dots[i].set_data([x], [y])
            dr, dc = HEADING_DELTAS[h] * 0.55
            arrows[i].set_positions((x, y), (x + dc, y + dr))
        walked = result.observer_path[path_t <= t]
        l_path.set_data(walked[:, 2], walked[:, 1])
        l_dot.set_data([observer[k, 1]], [observer[k, 0]])
        for t_seen, artists in seen:
            for artist in artists:
                artist.set_visible(t >= t_seen)
        phase = _phase(result, t)
        title.set_text(f"{head}\nt={t}: {phase}")
        return [*trails, *dots, *arrows, l_path, l_dot, title]

    anim = FuncAnimation(fig, update, frames=len(times), blit=False, repeat=False)
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(path, writer=_holding_writer(PillowWriter, fps))
    return path


def _holding_writer(pillow_writer, fps: int):
    """A ``PillowWriter`` whose last frame lasts ``HOLD_SECONDS`` longer, so the outcome is
    seen before the GIF loops (rendering the last frame again for it would cost a render each)."""

    class HoldingWriter(pillow_writer):
        def finish(self):
            frames = self._frames  # PillowWriter's grabbed frames (RGB or RGBA images)
            step = int(1000 / self.fps)
            durations = [step] * (len(frames) - 1) + [step + int(HOLD_SECONDS * 1000)]
            frames[0].save(
                self.outfile,
                save_all=True,
                append_images=frames[1:],
                duration=durations,
                loop=0,
            )

    return HoldingWriter(fps=fps)
