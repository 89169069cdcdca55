"""``Episode``: one seed fixes an episode, L's view goes dark once L leaves its start cell,
and the outcome is the world's detection and goal test."""

from __future__ import annotations

import numpy as np

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
