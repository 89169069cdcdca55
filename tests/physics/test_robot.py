"""The Kobuki-sized robot: its mass, its bodies and joints, and a motor's strength scaling its
gain and torque limit (a dead motor has neither)."""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mirl.physics.robot import KOBUKI, Kobuki, actuator_mjcf, robot_mjcf  # noqa: E402
from mirl.physics.world import world_mjcf  # noqa: E402
from mirl.world.maps import MapFrame  # noqa: E402


def _model(left: float, right: float, k: Kobuki = KOBUKI):
    free = np.ones((3, 3), bool)
    return mujoco.MjModel.from_xml_string(
        world_mjcf(free, MapFrame(), [("R", 1.0, -1.0, 0.0, left, right)], kobuki=k)
    )


def test_the_mass_is_the_base_and_both_wheels():
    assert KOBUKI.mass == pytest.approx(2.2 + 2 * 0.1)
    model = _model(1.0, 1.0)
    root = model.body("R").id
    subtree = model.body_subtreemass[root]
    assert subtree == pytest.approx(KOBUKI.mass + 0.002, abs=1e-6)  # two casters of 1 g


def test_the_body_names_its_joints_and_geoms_after_the_robot():
    xml = robot_mjcf("Q", 0.0, 0.0, 90.0, "1 0 0 1")
    for part in ('name="Q_root"', 'name="Q_base"', 'name="Q_left"', 'name="Q_right"'):
        assert part in xml
    assert 'euler="0 0 90.000"' in xml


@pytest.mark.parametrize("left, right", [(1.0, 1.0), (0.6, 1.0), (1.0, 0.25)])
def test_a_motors_strength_scales_its_gain_and_its_torque_limit(left, right):
    model = _model(left, right)
    for side, s in (("left", left), ("right", right)):
        act = model.actuator(f"R_{side}_motor")
        assert act.gainprm[0] == pytest.approx(KOBUKI.motor_gain * s)
        assert act.forcerange[1] == pytest.approx(KOBUKI.torque_limit * s)
        assert act.forcelimited


def test_a_dead_motor_has_no_gain_and_no_force_limit():
    xml = actuator_mjcf("R", left=0.0)
    assert 'kv="0"' in xml and xml.count("forcelimited") == 1  # only the right motor's
    model = _model(0.0, 1.0)
    assert model.actuator("R_left_motor").gainprm[0] == 0.0
