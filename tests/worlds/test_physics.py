"""The physics world behind the contract: L's model of its motion, what damage means in it
(a wheel motor's strength), its ``[physics]`` section, ``simulate`` with L's camera's poses,
and what it refuses (misread headings, given patroller actions)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("mujoco")

from mirl.physics.config import scenario_physics  # noqa: E402
from mirl.world.faults import DriftSpec  # noqa: E402
from mirl.world.motion import transition_matrix  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from mirl.worlds import RunSetup  # noqa: E402
from mirl.worlds.physics import PhysicsRunWorld  # noqa: E402


@pytest.fixture(scope="module")
def healthy():
    return load_scenario("boyd2-healthy")


def test_the_physical_world_is_modelled_with_turns_that_need_no_wheel(healthy):
    """What the isolated pivots of tests/physics/test_patrol.py measure is what L's model of
    this world says: its ξ takes the wheels out of the turns, failed steps stay put, and the
    rest is the scenario's."""

    model = PhysicsRunWorld.modelled(healthy)
    subsets = model.feature_map.action_subsets
    assert subsets["turn_left"] == subsets["turn_right"] == ("navigation", "floor")
    assert subsets["forward"] == healthy.feature_map.action_subsets["forward"]
    assert model.robots == healthy.robots and model.map is not None
    assert healthy.error_model == "uniform" and model.error_model == "stop"
    # the patrollers follow the scenario's policies; only the model of their motion changes
    for sc in (healthy, load_scenario("boydright")):
        model = PhysicsRunWorld.modelled(sc)
        for i in range(len(sc.robots)):
            assert np.array_equal(model.true_policy(i), sc.true_policy(i))
            probs = sc.robots[i].feature_probabilities
            expected = transition_matrix(model.domain, probs, "stop")
            assert abs(model.true_transitions(i) - expected).max() == 0
            success = model.domain.success_probabilities(probs)[:, 1:3]  # the turns
            assert np.allclose(success, probs["navigation"] * probs["floor"])


def test_the_physical_world_states_how_far_a_weak_wheel_drifts_its_robot(healthy):
    """L's model of this world reads a robot's drift with the world's measured κ; a scenario
    that states its own keeps it."""
    cfg = scenario_physics(healthy)
    drift = PhysicsRunWorld.modelled(healthy).faults.drift
    assert healthy.faults.drift.per_gap is None
    assert (drift.per_gap, drift.spread) == (cfg.drift_per_gap, cfg.drift_spread)
    own = replace(healthy, faults=replace(healthy.faults, drift=DriftSpec(per_gap=0.1)))
    assert PhysicsRunWorld.modelled(own).faults.drift.per_gap == 0.1


def test_damage_is_a_wheel_motors_strength(healthy):
    weak = PhysicsRunWorld.apply_damage(healthy, "I", "right_wheel", 0.5)
    assert PhysicsRunWorld.damaged_parts(weak) == {"I": ("right_wheel",), "J": ()}
    assert scenario_physics(weak).strength("I", "right_wheel") == 0.5
    assert healthy.robots == weak.robots  # the grid probabilities are not what physics drives
    assert PhysicsRunWorld.damaged_parts(healthy) == {"I": (), "J": ()}
    with pytest.raises(ValueError, match="wheel motor's strength: 'floor' is not one of"):
        PhysicsRunWorld.apply_damage(healthy, "I", "floor", 0.5)
    with pytest.raises(ValueError, match="unknown robot 'K'"):
        PhysicsRunWorld.apply_damage(healthy, "K", "left_wheel", 0.5)


def test_damage_is_a_motor_weak_enough_to_change_the_robots_moves(healthy):
    """A motor is damaged when its wheel's success probability, measured in this world at its
    strength, lies below the healthy level by more than the margin: at 0.7 it is, at 0.8 its
    forward steps still succeed and it is weakened, not damaged."""
    from mirl.physics.calibration import damaged_wheels, weakened_wheels, wheel_success

    h, threshold = 0.95, healthy.faults.threshold("left_wheel")
    assert wheel_success(1.0, h) == h and wheel_success(0.0, h) == 0.0
    assert wheel_success(0.7, h) < threshold < wheel_success(0.8, h)
    strengths = [0.3, 0.5, 0.6, 0.7, 0.75, 0.8, 0.9, 1.0]
    assert np.all(np.diff([wheel_success(x, h) for x in strengths]) >= 0)
    for strength, damaged in ((0.6, True), (0.7, True), (0.8, False), (0.95, False)):
        weak = PhysicsRunWorld.apply_damage(healthy, "J", "left_wheel", strength)
        parts = PhysicsRunWorld.damaged_parts(weak)
        assert parts == damaged_wheels(weak)
        assert parts["J"] == (("left_wheel",) if damaged else ())
        assert weakened_wheels(weak)["J"] == (() if damaged else ("left_wheel",))
    # a scenario's own, stricter definition reads the same motor as damaged
    strict = replace(healthy, faults=replace(healthy.faults, margin=0.02))
    weak = PhysicsRunWorld.apply_damage(strict, "J", "left_wheel", 0.8)
    assert PhysicsRunWorld.damaged_parts(weak)["J"] == ("left_wheel",)


def test_its_section_is_read_and_checked(tmp_path):
    cfg = PhysicsRunWorld.read_section(load_scenario("boyd2"))
    assert cfg.strength("J", "left_wheel") == 0.6  # boyd2's [physics] table
    bad = tmp_path / "bad.toml"
    bad.write_text('map = "boyd2"\n[[robots]]\nstart = [8, 1, 3]\n[[robots]]\nstart = [0, 8, 0]\n'
                   "[physics]\nmax_sped = 1.0\n")  # fmt: skip
    sc = load_scenario(bad)  # the scenario keeps the table; the world reads it
    with pytest.raises(ValueError, match="bad.toml: physics.max_sped: unknown field"):
        PhysicsRunWorld.read_section(sc)


def test_simulate_records_the_cameras_poses_and_contacts(healthy):
    sim = PhysicsRunWorld.simulate(healthy, 6, seed=2, observability=1.0)
    assert sim.steps == 6 and sim.step_seconds == 2.0 and sim.poses is not None
    assert sim.conditions == "physics: all motors healthy"
    assert sim.report[0].startswith("contacts: ")
    assert len(sim.poses.observed) == len(sim.observations) > 0
    assert set(sim.poses.true.robot_names) == {"I", "J", "L"}
    assert len(sim.poses.true) == 3 * 5 * 20 and sim.poses.true_rate_hz == 10.0
    with pytest.raises(ValueError, match="`heading_noise` applies to the grid world"):
        PhysicsRunWorld.simulate(healthy, 6, seed=2, heading_noise=0.1)


def test_its_patrollers_take_no_given_actions(healthy):
    from mirl.planning.observer import observer_model

    setup = RunSetup(healthy, observer_model(healthy), 0.14, 0, np.random.SeedSequence(0))
    world = PhysicsRunWorld(setup)
    assert not PhysicsRunWorld.takes_patroller_actions
    with pytest.raises(NotImplementedError, match="takes no `patroller_actions`"):
        world.step(patroller_actions=np.zeros(2, dtype=int))
    assert world.t == 0 and len(world.true) == 1
    assert PhysicsRunWorld.version().startswith("mujoco.")


def test_a_simulation_outside_the_calibrated_cells_says_so(tmp_path):
    """Narrow cells (robots touch or wedge against walls) or many wall contacts get a note;
    the shipped 1 m cells with few contacts do not."""
    from importlib.resources import files

    from mirl.worlds.physics import CALIBRATED_CELL, WALL_CONTACTS_NOTED, out_of_calibration

    text = (files("mirl.data") / "scenarios" / "boyd2-healthy.toml").read_text()
    narrow = tmp_path / "narrow.toml"
    narrow.write_text(text.replace("\n[observer]", "\n[frame]\ncell_size = 0.75\n\n[observer]", 1))
    shipped, small = load_scenario("boyd2-healthy"), load_scenario(narrow)
    assert small.map.frame.cell_size < CALIBRATED_CELL <= shipped.map.frame.cell_size
    assert out_of_calibration(shipped, 20, 900) == ()
    (note,) = out_of_calibration(small, 20, 900)
    assert "0.75 m cells touched walls 20 times in 900 robot-steps" in note
    many = int(WALL_CONTACTS_NOTED * 900) + 1
    assert "calibrated on 1 m cells" in out_of_calibration(shipped, many, 900)[0]


def test_a_run_on_narrow_cells_carries_the_note_in_its_report_and_json(tmp_path):
    from importlib.resources import files

    from mirl.planning.observer import observer_model

    text = (files("mirl.data") / "scenarios" / "boyd2-healthy.toml").read_text()
    narrow = tmp_path / "narrow.toml"
    narrow.write_text(text.replace("\n[observer]", "\n[frame]\ncell_size = 0.75\n\n[observer]", 1))
    scenario = load_scenario(narrow)
    world = PhysicsRunWorld(
        RunSetup(scenario, observer_model(scenario), 0.14, 0, np.random.SeedSequence(0))
    )
    extras = world.extras()
    (note,) = extras.notes()
    assert "0.75 m cells" in note and extras.to_dict()["notes"] == [note]
    sim = PhysicsRunWorld.simulate(scenario, 3, seed=0)
    assert sim.report[1].startswith("note: robots 0.354 m across in 0.75 m cells")
