"""Drawing a physical-world run (``mirl run --world physics --plot``): the map, the robots'
continuous paths (true poses at the control rate) while L was out (and a little before), L's
camera cone at its door, and at a detection the cone of the patroller that saw L.

Map-frame metres are drawn in cell units over :func:`mirl.viz.maps.draw_map` (cell (r, c) at
x = c, y = r), through the map frame.
"""

from __future__ import annotations

import numpy as np

from mirl.viz.maps import draw_map
from mirl.viz.runs import OBSERVER_COLOR, ROBOT_COLORS

__all__ = ["draw_physical_run"]


def _to_cells(frame, x, y):
    r, c = frame.cell_coordinates(x, y)
    return np.asarray(c), np.asarray(r)


def _cone(ax, frame, x, y, yaw, fov_deg, rng, color, label):
    from matplotlib.patches import Polygon

    a = yaw + np.radians(np.linspace(-fov_deg / 2, fov_deg / 2, 24))
    px = np.concatenate([[x], x + rng * np.cos(a)])
    py = np.concatenate([[y], y + rng * np.sin(a)])
    c, r = _to_cells(frame, px, py)
    poly = Polygon(np.column_stack([c, r]), closed=True, fc=color, ec=color, alpha=0.18, lw=1.0,
                   label=label)  # fmt: skip
    ax.add_patch(poly)
    return poly


def draw_physical_run(ax, scenario, result, *, context: int = 10):
    """Draw a physics-world run on ``ax``; the physics row's drawing in :data:`mirl.worlds.WORLDS`.

    The robots' true tracks, L's camera cone and the patrollers' sightings, from ``context``
    steps before L left.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The map panel.
    scenario : Scenario
        The run's scenario.
    result : RunResult
        The run; its ``extras`` is a :class:`~mirl.worlds.physics.PhysicsExtras`.
    context : int, default 10
        Steps drawn before L left.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    colors, observer_color = ROBOT_COLORS, OBSERVER_COLOR
    world = result.extras.world
    gm = scenario.map
    frame = gm.frame
    draw_map(ax, gm, gm.visible_mask(result.observability), legend=False)
    step_s = world.cfg.step_seconds
    t_end = result.end_time
    t_start = max(0, (result.go_time if result.go_time is not None else t_end - 40) - context)
    times, poses = world.tick_poses()
    handles = []
    if len(times):
        sel = (times >= t_start * step_s) & (times <= t_end * step_s + 1e-9)
        for i, name in enumerate(result.robot_names):
            c, r = _to_cells(frame, poses[sel, i, 0], poses[sel, i, 1])
            color = colors[i % len(colors)]
            (line,) = ax.plot(c, r, "-", color=color, lw=1.4, alpha=0.85,
                              label=f"{name} (t={t_start}…{t_end})")  # fmt: skip
            if len(c):
                ax.plot(c[-1], r[-1], "o", color=color, ms=5)
            handles.append(line)
        if world.has_observer and result.go_time is not None:
            lsel = times >= result.go_time * step_s
            c, r = _to_cells(frame, poses[lsel, -1, 0], poses[lsel, -1, 1])
            (line,) = ax.plot(c, r, "-", color=observer_color, lw=2.6,
                              label=f"L (left t={result.go_time}) — {result.outcome}")  # fmt: skip
            handles.append(line)
    camera = world.camera
    if camera.cone is not None and camera.pose is not None:
        cx, cy, cyaw = camera.pose
        handles.append(
            _cone(ax, frame, cx, cy, cyaw, camera.cone.fov_deg, camera.cone.range, "#2ca02c",
                  f"L's camera ({camera.cone.fov_deg:g}°, {camera.cone.range:.1f} m)")
        )  # fmt: skip
    for s in world.sightings[:1]:
        x, y, yaw = s.robot_pose
        cone = world.patroller_cameras.cone
        handles.append(
            _cone(ax, frame, x, y, yaw, cone.fov_deg, cone.range, "#ff2222",
                  f"{result.robot_names[s.robot]}'s camera saw L at {s.time:.1f} s")
        )  # fmt: skip
        c, r = _to_cells(frame, s.observer_pose[0], s.observer_pose[1])
        ax.plot(c, r, "X", color="#ff2222", ms=14, mec="k", zorder=5)
    rows, cols = gm.shape
    ax.set_xlim(-0.5, cols - 0.5)
    ax.set_ylim(rows - 0.5, -0.5)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize="small",
              frameon=False)  # fmt: skip
    ax.set_title(
        f"{scenario.name}, {result.method}, seed {result.seed} (physics; "
        f"{world.contacts} robot contacts)",
        fontsize="medium",
    )
    return ax
