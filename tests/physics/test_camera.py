"""Cameras: a cone and a ray to the target, L's view (a door camera and overhead cells) and the
patrollers' cameras looking for L once it has left its room."""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mirl.physics.camera import (  # noqa: E402
    Cone,
    ObserverCamera,
    PatrollerCameras,
    line_of_sight,
    observer_camera,
)
from mirl.physics.config import PhysicsConfig  # noqa: E402
from mirl.physics.world import world_mjcf  # noqa: E402
from mirl.world.maps import parse_map  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402

# a room for L (0, 0) opening on a hallway; a wall block in the hallway's middle row
MAP = parse_map("L....\n.###.\n....G\n")


@pytest.fixture(scope="module")
def world():
    model = mujoco.MjModel.from_xml_string(world_mjcf(MAP.free, MAP.frame, []))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def xy(r, c):
    x, y = MAP.frame.cell_centre(r, c)
    return float(x), float(y)


def test_a_wall_between_blocks_the_ray_and_open_floor_does_not(world):
    model, data = world
    assert line_of_sight(model, data, *xy(0, 1), *xy(0, 4))  # along the top row
    assert not line_of_sight(model, data, *xy(0, 2), *xy(2, 2))  # through the wall block
    assert line_of_sight(model, data, *xy(0, 2), *xy(0, 2))  # a point sees itself


def test_the_overhead_cells_are_seen_and_the_cone_needs_a_clear_ray(world):
    model, data = world
    overhead = np.zeros(MAP.shape, bool)
    overhead[2, 0] = True
    camera = ObserverCamera((*xy(0, 0), 0.0), Cone(60.0, 10.0), overhead)
    px, py = (np.array(v) for v in zip(xy(0, 3), xy(2, 4), xy(2, 0), strict=True))
    # (0, 3) ahead in the cone; (2, 4) in the cone (27° off its axis) but behind the wall
    # block; (2, 0) outside the cone, on an overhead cell
    assert camera.cone.inside(*camera.pose, px, py).tolist() == [True, True, False]
    assert camera.sees(model, data, MAP.frame, px, py).tolist() == [True, False, True]
    blind = ObserverCamera(None, None, np.zeros(MAP.shape, bool))
    assert not blind.sees(model, data, MAP.frame, px, py).any()


def test_l_seen_everywhere_is_watched_from_overhead_only():
    sc = load_scenario("boyd2")
    cam = observer_camera(sc, PhysicsConfig(), sc.map.frame, 1.0)
    assert cam.pose is None and cam.cone is None
    np.testing.assert_array_equal(cam.overhead, sc.map.visible_mask(1.0))


def test_a_configured_camera_pose_and_range_are_used():
    sc = load_scenario("boyd2")
    cfg = PhysicsConfig(camera_pose=(1.0, 2.0, 90.0), camera_range=3.0)
    cam = observer_camera(sc, cfg, sc.map.frame, 0.14)
    assert cam.pose == pytest.approx((1.0, 2.0, np.pi / 2))
    assert cam.cone.range == 3.0 and cam.cone.fov_deg == cfg.camera_fov_deg


def test_patrollers_look_for_l_only_once_it_is_out_of_its_room(world):
    model, data = world
    cameras = PatrollerCameras(Cone(57.0, 6.0), MAP, n=1)
    patroller = (*xy(0, 4), np.pi)  # at the top row's end, facing west towards L's door
    in_room = np.array([patroller, (*xy(0, 0), 0.0)])
    cameras.look(model, data, in_room, step=3)
    assert cameras.sightings == [] and not cameras.observer_out
    out = np.array([patroller, (*xy(0, 1), 0.0)])
    cameras.look(model, data, out, step=4)
    assert cameras.observer_out
    (sighting,) = cameras.sightings
    assert sighting.step == 4 and sighting.robot == 0
    assert sighting.observer_pose == pytest.approx((*xy(0, 1), 0.0))
    behind = np.array([(*xy(0, 4), 0.0), (*xy(0, 1), 0.0)])  # facing away
    cameras.look(model, data, behind, step=5)
    assert len(cameras.sightings) == 1
