"""The MuJoCo world of a grid map: floor, walls as boxes, robots.

Wall cells (every non-free cell, plus a one-cell border around the map) become boxes; runs of
wall cells are merged into rectangles (greedily: maximal horizontal runs, then stacked while the
next row has the same run), so boyd2's 136 wall cells are a handful of boxes and a 60 × 60
office stays small. Cell (r, c)'s centre is at the map frame's ``cell_centre(r, c)``
(:class:`mirl.world.maps.MapFrame`).
"""

from __future__ import annotations

import numpy as np

from mirl.physics.robot import KOBUKI, Kobuki, actuator_mjcf, robot_mjcf
from mirl.world.maps import MapFrame

__all__ = ["wall_rectangles", "world_mjcf"]


def wall_rectangles(wall: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover the True cells of ``wall`` with disjoint rectangles, inclusive.

    Parameters
    ----------
    wall : ndarray of bool, shape (rows, cols)
        The wall cells.

    Returns
    -------
    list of (int, int, int, int)
        (r0, c0, r1, c1) of each rectangle, corners inclusive; together they cover exactly the
        wall cells.
    """
    wall = np.asarray(wall, dtype=bool).copy()
    rows, cols = wall.shape
    out = []
    for r in range(rows):
        c = 0
        while c < cols:
            if not wall[r, c]:
                c += 1
                continue
            c1 = c
            while c1 + 1 < cols and wall[r, c1 + 1]:
                c1 += 1
            r1 = r
            while (
                r1 + 1 < rows
                and wall[r1 + 1, c : c1 + 1].all()
                and (
                    (c == 0 or not wall[r1 + 1, c - 1])
                    and (c1 + 1 == cols or not wall[r1 + 1, c1 + 1])
                )
            ):
                r1 += 1
            wall[r : r1 + 1, c : c1 + 1] = False
            out.append((r, c, r1, c1))
            c = c1 + 1
    return out


def world_mjcf(
    free: np.ndarray,
    frame: MapFrame,
    robots: list[tuple[str, float, float, float, float, float]],
    *,
    timestep: float = 0.01,
    kobuki: Kobuki = KOBUKI,
    wall_height: float = 0.5,
) -> str:
    """MJCF of the map whose free cells are ``free``, with robots.

    Parameters
    ----------
    free : ndarray of bool, shape (rows, cols)
        The free cells; every other cell, and a one-cell border, is wall.
    frame : MapFrame
        The map's frame (cell centres, cell size).
    robots : list of (str, float, float, float, float, float)
        (name, x, y, yaw, left strength, right strength) of each robot; yaw in radians.
    timestep : float, default 0.01
        MuJoCo's integration step, seconds.
    kobuki : Kobuki, default KOBUKI
        The robots' dimensions and motors.
    wall_height : float, default 0.5
        Metres.

    Returns
    -------
    str
        The ``<mujoco>`` model.
    """
    free = np.asarray(free, dtype=bool)
    wall = np.pad(~free, 1, constant_values=True)  # border; padded index = cell + 1
    cs = frame.cell_size
    geoms = []
    for i, (r0, c0, r1, c1) in enumerate(wall_rectangles(wall)):
        x0, y0 = frame.cell_centre(r0 - 1, c0 - 1)
        x1, y1 = frame.cell_centre(r1 - 1, c1 - 1)
        sx, sy = (c1 - c0 + 1) * cs / 2, (r1 - r0 + 1) * cs / 2
        geoms.append(
            f'<geom name="wall{i}" type="box" pos="{(x0 + x1) / 2:.4f} {(y0 + y1) / 2:.4f} '
            f'{wall_height / 2}" size="{sx:.4f} {sy:.4f} {wall_height / 2}" contype="2" group="1" '
            'conaffinity="2" friction="0.1 0.005 0.0001" rgba="0.55 0.55 0.6 1"/>'
        )
    rows, cols = free.shape
    cx, cy = frame.cell_centre((rows - 1) / 2, (cols - 1) / 2)
    colours = ["0.85 0.3 0.25 1", "0.25 0.45 0.85 1", "0.3 0.7 0.35 1", "0.8 0.6 0.2 1"]
    bodies = [
        robot_mjcf(n, x, y, np.degrees(yaw), colours[i % len(colours)], kobuki)
        for i, (n, x, y, yaw, _, _) in enumerate(robots)
    ]
    acts = [actuator_mjcf(n, lw, rw, kobuki) for (n, _, _, _, lw, rw) in robots]
    return f"""<mujoco model="mirl">
  <option timestep="{timestep}" integrator="implicitfast" cone="pyramidal" jacobian="sparse">
    <flag warmstart="enable"/>
  </option>
  <size memory="{8 + 2 * len(robots)}M"/>
  <worldbody>
    <geom name="floor" type="plane" pos="{cx:.3f} {cy:.3f} 0"
          size="{(cols + 2) * cs / 2:.3f} {(rows + 2) * cs / 2:.3f} 0.1" contype="1" conaffinity="1"
          friction="1 0.005 0.0001" rgba="0.9 0.9 0.88 1"/>
    {chr(10).join("    " + g for g in geoms)}
    {"".join(bodies)}
  </worldbody>
  <actuator>
    {chr(10).join("    " + a for a in acts)}
  </actuator>
</mujoco>
"""
