"""``Episode``: one seed fixes an episode, L's view goes dark once L leaves its start cell,
and the outcome is the world's detection and goal test."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.envs import PenetrationEnv, TeamEnv
from mirl.envs.core import Episode
from mirl.planning.observer import observer_model, shortest_path_policy
from mirl.world.scenario import load_scenario
from mirl.worlds import WORLDS


def _episode(seed: int, scenario="boyd2", observability=None) -> Episode:
    sc = load_scenario(scenario)
    degree = sc.observability if observability is None else observability
    return Episode(WORLDS["grid"].load(), sc, observer_model(sc), degree, seed)


def test_one_seed_fixes_an_episode():
    runs = []
    for _ in range(2):
        e = _episode(7)
        views = []
        for action in [3] * 5 + [0] * 10:
            e.step(action)
            views.append((e.observer_view(), e.outcome, e.patroller_states.tolist()))
        runs.append(views)
    for (a, oa, pa), (b, ob, pb) in zip(*runs, strict=True):
        assert oa == ob and pa == pb
        assert all(np.array_equal(a[k], b[k]) for k in a)


def test_l_sees_what_the_world_saw_until_it_leaves_its_cell():
    e = _episode(3, observability=1.0)  # L sees every patroller cell from its room
    e.step(3)
    view = e.observer_view()
    seen = e.world.seen[-1]
    expected = np.where((seen >= 0)[:, None], e.scenario.domain.states[seen], -1)
    np.testing.assert_array_equal(view["patrollers"], expected)
    assert (view["patrollers"] >= 0).all() and view["out"] == 0
    for _ in range(6):  # forward until L has left its start cell
        e.step(0)
        if e.out:
            break
    assert e.out and (e.observer_view()["patrollers"] == -1).all()
    start = e.model.domain.states[e.model.start_state][:2]
    assert tuple(e.observer_view()["observer"][:2]) != tuple(start)


def test_the_outcome_is_the_worlds_detection_then_goal():
    seen = set()
    for seed in range(10):
        e = _episode(seed)
        path = shortest_path_policy(e.model)
        for _ in range(60):
            e.step(int(path[e.world.observer_state()]))
            detected = bool(e.world.detections())
            assert e.detected == detected
            assert e.arrived == (not detected and e.world.at_goal())
            if e.outcome is not None:
                break
        seen.add(e.outcome)
    assert {"detected", "success"} <= seen


@pytest.mark.parametrize(
    ("env_class", "argument", "value"),
    [
        (PenetrationEnv, "max_steps", 2.5),
        (PenetrationEnv, "max_steps", float("nan")),
        (PenetrationEnv, "goal_reward", float("nan")),
        (PenetrationEnv, "detection_penalty", float("inf")),
        (TeamEnv, "max_cycles", 0),
        (TeamEnv, "max_cycles", -3),
        (TeamEnv, "max_cycles", 2.5),
        (TeamEnv, "goal_reward", float("nan")),
        (TeamEnv, "detection_reward", float("inf")),
    ],
)
def test_an_episode_length_or_reward_that_cannot_be_meant_is_refused(env_class, argument, value):
    """A length the environment would cut or that ends every episode at once, and a reward
    that would reach every return as NaN or infinity, are refused by name."""
    with pytest.raises(ValueError, match=f"`{argument}` must be"):
        env_class("boyd2", **{argument: value})


@pytest.mark.parametrize("env_class", [PenetrationEnv, TeamEnv])
@pytest.mark.parametrize("value", [2.0, -0.1, float("nan"), "0.5", True])
def test_a_view_that_cannot_be_meant_is_refused_when_the_environment_is_made(env_class, value):
    """``observability=2.0`` was accepted by the constructor and refused by the first
    ``reset`` without the argument's name; ``"0.5"`` and True were taken as numbers."""
    with pytest.raises(ValueError, match=r"`observability` must be a number in \[0, 1\] or None"):
        env_class("boyd2", observability=value)
    assert env_class("boyd2", observability=np.float32(0.5)).observability == 0.5


def test_the_environments_take_an_integer_length_of_any_integer_type():
    assert PenetrationEnv("boyd2", max_steps=np.int64(3)).max_steps == 3
    assert TeamEnv("boyd2", max_cycles=1).max_cycles == 1
