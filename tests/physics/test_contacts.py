"""Contact events: a pair counts once when it starts touching, robot–robot and robot–wall
apart, and again only after it has come apart."""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mirl.physics.contacts import ContactLog  # noqa: E402
from mirl.physics.robot import KOBUKI  # noqa: E402
from mirl.physics.world import world_mjcf  # noqa: E402
from mirl.world.maps import parse_map  # noqa: E402

MAP = parse_map("L.....\n######\n.....G\n")  # the hallway's top row, a wall row below it


def _world():
    x0, y0 = MAP.frame.cell_centre(0, 1)
    x0, y0 = float(x0), float(y0)
    robots = [("A", x0, y0, 0.0, 1.0, 1.0), ("B", x0 + 2, y0, 0.0, 1.0, 1.0)]
    model = mujoco.MjModel.from_xml_string(world_mjcf(MAP.free, MAP.frame, robots))
    data = mujoco.MjData(model)
    return model, data, ContactLog(model, ["A", "B"])


def _place(model, data, name, x, y):
    adr = model.jnt_qposadr[model.joint(f"{name}_root").id]
    data.qpos[adr : adr + 3] = [x, y, KOBUKI.wheel_radius]
    data.qpos[adr + 3 : adr + 7] = [1, 0, 0, 0]
    data.qvel[:] = 0
    mujoco.mj_forward(model, data)


def test_robots_apart_on_the_floor_make_no_event():
    model, data, log = _world()
    mujoco.mj_forward(model, data)
    log.update(data, 0)
    assert (log.contacts, log.wall_contacts, log.pairs) == (0, 0, [])


def test_a_pair_touching_counts_once_and_again_after_coming_apart():
    model, data, log = _world()
    x, y = (float(v) for v in MAP.frame.cell_centre(0, 2))
    _place(model, data, "A", x, y)
    _place(model, data, "B", x + 2 * KOBUKI.base_radius - 0.01, y)  # bases overlap by 1 cm
    for step in range(3):
        log.update(data, step)
    assert log.contacts == 1 and log.pairs == [(0, 0, 1)]
    _place(model, data, "B", x + 1.0, y)  # apart
    log.update(data, 3)
    _place(model, data, "B", x + 2 * KOBUKI.base_radius - 0.01, y)
    log.update(data, 4)
    assert log.contacts == 2 and log.pairs[-1] == (4, 0, 1)
    assert log.wall_contacts == 0


def test_a_robot_against_a_wall_is_a_wall_event_not_a_pair():
    model, data, log = _world()
    x, y = (float(v) for v in MAP.frame.cell_centre(0, 3))
    cell = MAP.frame.cell_size
    _place(model, data, "A", x, y - cell / 2 - KOBUKI.base_radius + 0.01)  # into the wall row
    log.update(data, 7)
    log.update(data, 8)
    assert log.wall_contacts == 1 and log.contacts == 0 and log.pairs == []
    assert np.isfinite(data.qpos).all()
