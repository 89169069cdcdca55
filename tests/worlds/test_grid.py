"""The grid world behind the contract: its run is the simulator's, L's moves fail on a stream of
their own, detection is L's model's rule, patrollers take given actions through their true
transition functions, and ``simulate`` is the grid simulator's record."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.planning.observer import observer_model
from mirl.simulation.grid import PatrolSimulator, simulate
from mirl.world.domain import ACTIONS
from mirl.world.scenario import load_scenario
from mirl.worlds import RunSetup
from mirl.worlds.grid import GridRunWorld


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def _world(sc, seed=0, noise=1, observability=None) -> GridRunWorld:
    degree = sc.observability if observability is None else observability
    return GridRunWorld(
        RunSetup(sc, observer_model(sc), degree, seed, np.random.SeedSequence(noise))
    )


def test_a_run_is_the_simulators_from_random_starts(boyd2):
    world = _world(boyd2, seed=4)
    sim = PatrolSimulator(boyd2)
    obs, info = sim.reset(seed=4, options={"random_starts": True})
    for _ in range(30):
        np.testing.assert_array_equal(world.true[-1], info["states"])
        seen = np.full(2, -1)
        seen[obs[:, 0]] = boyd2.domain.state_index(obs[:, 1], obs[:, 2], obs[:, 3])
        np.testing.assert_array_equal(world.seen[-1], seen)
        world.step()
        obs, _, _, _, info = sim.step()
    assert world.seen_lateral is None and world.extras() is None


def test_ls_moves_fail_on_its_own_stream_and_change_no_patroller(boyd2):
    """L's failures come from the setup's noise stream: another stream moves L differently and
    the patrollers exactly the same; L fails about as often as its model says."""
    model = observer_model(boyd2)
    paths, trues = [], []
    for noise in (1, 2):
        w = _world(boyd2, seed=3, noise=noise)
        failed = moves = 0
        path = []
        for a in np.tile([0, 1, 2], 300):
            before = w.observer_state()
            w.step(int(a))
            if model.domain.intended[before, a] != before:  # a move that can fail visibly
                moves += 1
                failed += w.observer_state() == before
            path.append(w.observer_state())
        mean, sd = moves * model.failure, np.sqrt(moves * model.failure * (1 - model.failure))
        assert abs(failed - mean) <= 4 * sd, (failed, moves)
        paths.append(path)
        trues.append(np.asarray(w.true))
    np.testing.assert_array_equal(trues[0], trues[1])
    assert paths[0] != paths[1]


def test_detection_is_ls_models_rule_and_the_goal_its_goal_cells(boyd2):
    model = observer_model(boyd2)
    w = _world(boyd2, seed=0)
    for _ in range(200):
        w.step(0)
        seen = model.seen_by(w.true[-1], w.observer_state())
        got = w.detections()
        assert [d.robot for d in got] == [boyd2.robot_names[i] for i in np.flatnonzero(seen)]
        assert all(d.t == w.t for d in got)
        assert w.at_goal() == bool(model.goal[w.observer_state()])


def test_given_actions_move_patrollers_by_their_true_transition_functions(boyd2):
    """Every robot told ``forward`` from the same state many times lands where its true T row
    says, within four standard errors."""
    T = [boyd2.true_transitions(i) for i in range(2)]
    A = len(ACTIONS)
    w = _world(boyd2, seed=5)
    start = w.true[-1].copy()
    landed = [[], []]
    for _ in range(2000):
        w.sim.states[:] = start  # back to the same states, the simulator's own stream going on
        w.step(patroller_actions=np.zeros(2, dtype=int))
        for i in range(2):
            landed[i].append(int(w.true[-1][i]))
    for i in range(2):
        row = T[i][[int(start[i]) * A]].toarray().ravel()
        freq = np.bincount(landed[i], minlength=len(row)) / len(landed[i])
        se = np.sqrt(row * (1 - row) / len(landed[i]))
        assert (np.abs(freq - row) <= 4 * se + 1e-12).all()


def test_refused_patroller_actions_move_nobody(boyd2):
    w = _world(boyd2)
    for bad in ([0, 0, 0], [0, 4], [0.0, 1.0], [-1, 0]):
        with pytest.raises(ValueError, match="one per robot"):
            w.step(0, patroller_actions=np.asarray(bad))
        assert w.t == 0 and len(w.true) == len(w.seen) == 1
        assert w.observer_state() == observer_model(boyd2).start_state


def test_simulate_is_the_grid_simulators_record(boyd2):
    got = GridRunWorld.simulate(boyd2, 120, seed=3, heading_noise=0.1, random_starts=True)
    want = simulate(boyd2, 120, seed=3, heading_noise=0.1, random_starts=True)
    for f in ("t", "robot", "row", "col", "heading"):
        np.testing.assert_array_equal(getattr(got.observations, f), getattr(want.observations, f))
        np.testing.assert_array_equal(getattr(got.truth, f), getattr(want.truth, f))
    meetings = f"interactions: {want.interactions} ({want.interactions_seen} seen by L)"
    assert got.report == (meetings,)
    assert got.poses is None and got.step_seconds is None and got.conditions == ""
    np.testing.assert_allclose(got.observed_share(), want.observed_share())


def test_damage_is_a_success_probability(boyd2):
    damaged = GridRunWorld.apply_damage(boyd2, "I", "floor", 0.5)
    assert damaged.robots[0].feature_probabilities["floor"] == 0.5
    assert "floor" in GridRunWorld.damaged_parts(damaged)["I"]
    assert GridRunWorld.damaged_parts(boyd2) == {"I": (), "J": ("left_wheel",)}
    assert GridRunWorld.modelled(boyd2) is boyd2 and GridRunWorld.version() == ""
    assert GridRunWorld.read_section(boyd2) is None
    with pytest.raises(ValueError, match="unknown transition feature 'wheel'"):
        GridRunWorld.apply_damage(boyd2, "I", "wheel", 0.5)
