"""The grid simulator: seeding, what L sees, perception noise, the true dynamics' success rates,
interactions resolved by the played equilibrium, random starts, and the gymnasium-style API."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mirl.simulation.grid import PatrolSimulator, SimulationResult, patrol_cycle, simulate
from mirl.world.domain import ACTIONS
from mirl.world.scenario import load_scenario

FWD, LEFT, RIGHT, STOP = (ACTIONS.index(a) for a in ("forward", "turn_left", "turn_right", "stop"))
EAST, NORTH, WEST, SOUTH = range(4)
Z = 4.5  # sampling-error bound in standard deviations


def rows(traj) -> list[tuple[int, int, int, int, int]]:
    return list(
        zip(
            traj.t.tolist(),
            traj.robot.tolist(),
            traj.row.tolist(),
            traj.col.tolist(),
            traj.heading.tolist(),
            strict=True,
        )
    )


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def test_same_seed_same_run_different_seed_different_run(boyd2):
    a = simulate(boyd2, 400, seed=7, observability=0.5, heading_noise=0.1)
    b = simulate(boyd2, 400, seed=7, observability=0.5, heading_noise=0.1)
    c = simulate(boyd2, 400, seed=8, observability=0.5, heading_noise=0.1)
    assert rows(a.truth) == rows(b.truth)
    assert rows(a.observations) == rows(b.observations)
    np.testing.assert_array_equal(a.true_states, b.true_states)
    assert (a.interactions, a.interactions_seen) == (b.interactions, b.interactions_seen)
    assert not np.array_equal(a.true_states, c.true_states)


def test_truth_shape_and_start(boyd2):
    res = simulate(boyd2, 50, seed=0)
    assert isinstance(res, SimulationResult)
    assert len(res.truth) == 100 and res.truth.horizon == 50
    assert res.true_states.shape == (50, 2)
    first = rows(res.truth)[:2]
    assert first == [(0, 0, 0, 8, WEST), (0, 1, 16, 8, WEST)]
    with pytest.raises(ValueError, match="steps"):
        simulate(boyd2, 0)


@pytest.mark.parametrize("degree", [0.0, 0.14, 0.5, 1.0])
def test_observations_are_the_truth_on_visible_cells(boyd2, degree):
    res = simulate(boyd2, 1500, seed=3, observability=degree)
    visible = boyd2.map.visible_mask(degree)
    truth = rows(res.truth)
    expected = [r for r in truth if visible[r[2], r[3]]]
    assert rows(res.observations) == expected
    assert set(rows(res.observations)) <= set(truth)
    if degree == 1.0:
        assert rows(res.observations) == truth
    if degree == 0.0:
        assert len(res.observations) == 0
    # observed share per robot agrees with the rows
    share = res.observed_share()
    for i in range(2):
        assert share[i] == pytest.approx(sum(r[1] == i for r in expected) / 1500)


def test_heading_noise_changes_only_headings_at_the_requested_rate(boyd2):
    eps, steps = 0.2, 3000
    clean = simulate(boyd2, steps, seed=11, observability=0.6)
    noisy = simulate(boyd2, steps, seed=11, observability=0.6, heading_noise=eps)
    # perception noise does not change the world: same true run, same observed (t, robot, cell)
    assert rows(noisy.truth) == rows(clean.truth)
    a, b = rows(clean.observations), rows(noisy.observations)
    assert len(a) == len(b) > 1000
    assert [r[:4] for r in a] == [r[:4] for r in b]
    changed = sum(x[4] != y[4] for x, y in zip(a, b, strict=True))
    n = len(a)
    assert abs(changed / n - eps) <= Z * math.sqrt(eps * (1 - eps) / n)
    # a misread heading is one of the three other headings, each about equally often
    shifts = np.array([(y[4] - x[4]) % 4 for x, y in zip(a, b, strict=True) if x[4] != y[4]])
    counts = np.bincount(shifts, minlength=4)[1:]
    assert np.all(np.abs(counts / changed - 1 / 3) <= Z * math.sqrt(2 / 9 / changed))


def test_heading_noise_bounds(boyd2):
    with pytest.raises(ValueError, match="heading_noise"):
        PatrolSimulator(boyd2, heading_noise=1.5)


def test_forward_success_rate_matches_feature_product(boyd2):
    """Long seeded run: forwards of a robot far from the other succeed with Π_τ p_τ; failures
    land on the other actions' intended states uniformly (Eq. 5's uniform model)."""
    d = boyd2.domain
    sim = PatrolSimulator(boyd2)
    sim.reset(seed=2024)
    trials = np.zeros(2, int)
    success = np.zeros(2, int)
    fail_to = np.zeros((2, 4), int)
    for _ in range(25_000):
        before = sim.states.copy()
        _, _, _, _, info = sim.step()
        if info["interaction"]:
            continue
        cells = d.states[before, :2]
        if np.abs(cells[0] - cells[1]).sum() <= 2:
            continue
        for i in range(2):
            s = before[i]
            if info["actions"][i] != FWD or d.intended[s, FWD] == s:
                continue
            trials[i] += 1
            nxt = info["states"][i]
            if nxt == d.intended[s, FWD]:
                success[i] += 1
            else:
                (hit,) = [a for a in (LEFT, RIGHT, STOP) if d.intended[s, a] == nxt]
                fail_to[i, hit] += 1
    for i, robot in enumerate(boyd2.robots):
        p = math.prod(robot.feature_probabilities.values())  # forward uses all four features
        n = trials[i]
        assert n > 5000
        assert abs(success[i] / n - p) <= Z * math.sqrt(p * (1 - p) / n), (robot.name, n)
        f = fail_to[i, [LEFT, RIGHT, STOP]]
        assert f.sum() == n - success[i]
        assert np.all(np.abs(f / f.sum() - 1 / 3) <= Z * math.sqrt(2 / 9 / f.sum()))
    # J's damaged left wheel shows
    assert success[1] / trials[1] < success[0] / trials[0] - 0.1


def certain(scenario):
    """The scenario with every true feature probability 1 (outcomes = ψ)."""
    for r in scenario.robot_names:
        for f in scenario.feature_map.features:
            scenario = scenario.with_damage(r, f, 1.0)
    return scenario


@pytest.mark.parametrize(
    "i_start, j_start, j_after",
    [
        ((5, 1, SOUTH), (6, 1, NORTH), (5, 1, NORTH)),  # adjacent: would swap
        ((5, 1, SOUTH), (7, 1, NORTH), (6, 1, NORTH)),  # one cell apart: same cell
    ],
)
def test_head_on_meeting_in_long_hallway_i_stops_j_goes(boyd2, i_start, j_start, j_after):
    sc = certain(boyd2)
    d = sc.domain
    sim = PatrolSimulator(sc)
    for seed in range(5):
        sim.reset(seed=seed, options={"starts": [i_start, j_start]})
        # both patrol on: their own policies say forward, head-on
        own = [sim.policies[k, sim.states[k]] for k in range(2)]
        assert own == [FWD, FWD]
        acts, met = sim.intended_actions()
        assert met
        assert acts.tolist() == [STOP, FWD]  # the played equilibrium: I stops, J goes
        sim.reset(seed=seed, options={"starts": [i_start, j_start]})
        _, _, _, _, info = sim.step()
        assert info["interaction"]
        assert info["actions"].tolist() == [STOP, FWD]
        after = [tuple(map(int, d.states[s])) for s in info["states"]]
        assert after == [i_start, j_after]
    # then they pass each other
    for _ in range(3):
        _, _, _, _, info = sim.step()
    cells = d.states[info["states"], :2]
    assert cells[0][0] > cells[1][0]  # I is south of J now


def test_other_equilibrium_played(boyd2):
    sc = certain(boyd2).with_options(played=("go", "stop"))
    sim = PatrolSimulator(sc)
    sim.reset(seed=0, options={"starts": [(5, 1, SOUTH), (6, 1, NORTH)]})
    acts, met = sim.intended_actions()
    assert met and acts.tolist() == [FWD, STOP]


def test_no_meeting_when_far_apart(boyd2):
    sim = PatrolSimulator(certain(boyd2))
    sim.reset(seed=0, options={"starts": [(2, 1, SOUTH), (12, 1, NORTH)]})
    acts, met = sim.intended_actions()
    assert not met and acts.tolist() == [FWD, FWD]


@pytest.mark.parametrize("name", ["boyd2", "boyd2-healthy"])
def test_random_starts_lie_on_the_patrol_cycle(name):
    sc = load_scenario(name)
    sim = PatrolSimulator(sc)
    cycles = [set(patrol_cycle(sc, i).tolist()) for i in range(2)]
    assert all(len(c) == 68 for c in cycles)
    drawn = [set(), set()]
    for seed in range(60):
        sim.reset(seed=seed, options={"random_starts": True})
        for i in range(2):
            assert int(sim.states[i]) in cycles[i]
            drawn[i].add(int(sim.states[i]))
    assert all(len(x) > 20 for x in drawn)  # actually random
    res = simulate(sc, 5, seed=1, random_starts=True)
    for i in range(2):
        assert int(res.true_states[0, i]) in cycles[i]


def test_bad_start(boyd2):
    sim = PatrolSimulator(boyd2)
    with pytest.raises(ValueError, match="hallway"):
        sim.reset(seed=0, options={"starts": [(3, 4, 0), (0, 1, 0)]})


def test_gymnasium_api(boyd2):
    sim = PatrolSimulator(boyd2, observability=1.0)
    out = sim.reset(seed=5)
    assert isinstance(out, tuple) and len(out) == 2
    obs, info = out
    assert isinstance(info, dict) and info["t"] == 0
    assert isinstance(obs, np.ndarray) and obs.shape == (2, 4)
    assert obs[:, 0].tolist() == [0, 1]  # robot, row, col, heading
    assert obs[:, 1:].tolist() == [[0, 8, WEST], [16, 8, WEST]]
    out = sim.step()
    assert isinstance(out, tuple) and len(out) == 5
    obs, reward, terminated, truncated, info = out
    assert obs.ndim == 2 and obs.shape[1] == 4
    assert isinstance(reward, float)
    assert terminated is False and truncated is False
    assert info["t"] == 1 and set(info) >= {"t", "states", "interaction", "actions"}
    # nothing visible at degree 0: an empty (0, 4) observation
    sim0 = PatrolSimulator(boyd2, observability=0.0)
    obs, _ = sim0.reset(seed=0)
    assert obs.shape == (0, 4)


def test_given_actions_are_taken_and_bad_ones_move_nobody():
    sim = PatrolSimulator("boyd2")
    sim.reset(seed=0)
    before = sim.states.copy()
    for bad in ([0], [0, 4], [0.5, 1.0], [[0, 1]]):
        with pytest.raises(ValueError, match="one per robot"):
            sim.step_actions(np.asarray(bad))
        assert sim.t == 0 and np.array_equal(sim.states, before)
    obs, _, _, _, info = sim.step_actions(np.array([STOP, STOP]))
    assert sim.t == 1 and info["interaction"] is False and list(info["actions"]) == [STOP, STOP]
    assert obs.shape[1] == 4
