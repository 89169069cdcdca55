"""The MuJoCo world of a grid map: walls as few disjoint boxes covering exactly the wall
cells, robots where they are put, and the options given."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

mujoco = pytest.importorskip("mujoco")

from mirl.physics.world import wall_rectangles, world_mjcf  # noqa: E402
from mirl.world.maps import MapFrame  # noqa: E402


@settings(max_examples=80, deadline=None)
@given(st.integers(1, 9), st.integers(1, 9), st.integers(0, 2**81 - 1))
def test_the_rectangles_cover_exactly_the_wall_cells_once(rows, cols, bits):
    wall = np.array([(bits >> k) & 1 for k in range(rows * cols)], bool).reshape(rows, cols)
    cover = np.zeros((rows, cols), int)
    for r0, c0, r1, c1 in wall_rectangles(wall):
        assert 0 <= r0 <= r1 < rows and 0 <= c0 <= c1 < cols
        cover[r0 : r1 + 1, c0 : c1 + 1] += 1
    np.testing.assert_array_equal(cover, wall.astype(int))


def test_a_solid_block_is_one_box():
    assert wall_rectangles(np.ones((3, 5), bool)) == [(0, 0, 2, 4)]
    assert wall_rectangles(np.zeros((3, 5), bool)) == []


def test_the_model_has_the_walls_floor_and_robots_where_they_were_put():
    free = np.array([[1, 1, 1], [0, 1, 0]], bool)
    frame = MapFrame(cell_size=2.0, origin_x=10.0, origin_y=-5.0)
    robots = [("A", 10.0, -5.0, 0.0, 1.0, 1.0), ("B", 14.0, -5.0, np.pi / 2, 0.6, 1.0)]
    model = mujoco.MjModel.from_xml_string(world_mjcf(free, frame, robots, timestep=0.005))
    assert model.opt.timestep == 0.005
    walls = [model.geom(g) for g in range(model.ngeom) if model.geom(g).name.startswith("wall")]
    assert len(walls) == len(wall_rectangles(np.pad(~free, 1, constant_values=True)))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.body("A").xpos[:2], [10.0, -5.0], atol=1e-9)
    np.testing.assert_allclose(data.body("B").xpos[:2], [14.0, -5.0], atol=1e-9)
    quat = data.body("B").xquat  # yaw π/2 about z
    np.testing.assert_allclose(quat, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-6)
    # every box covers wall cells only, and together they cover them all (the padded grid)
    wall = np.pad(~free, 1, constant_values=True)
    cover = np.zeros(wall.shape, int)
    for g in walls:
        (x, y, _), (sx, sy, _) = g.pos, g.size
        r0, c0 = frame.cell_coordinates(x - sx + 1.0, y + sy - 1.0)  # the top-left cell's centre
        r1, c1 = frame.cell_coordinates(x + sx - 1.0, y - sy + 1.0)
        rows = slice(int(round(r0)) + 1, int(round(r1)) + 2)
        cols = slice(int(round(c0)) + 1, int(round(c1)) + 2)
        cover[rows, cols] += 1
    np.testing.assert_array_equal(cover, wall.astype(int))
