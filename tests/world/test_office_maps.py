"""Generated office floors: connected one-cell hallways, rooms for L and its goals, names."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from mirl.world.maps import GridMap, MapError, parse_map
from mirl.world.office_maps import generate_office_map, office_map_from_name


def order_list(m: GridMap) -> list[tuple[int, int]]:
    return [tuple(map(int, rc)) for rc in m.visibility_order]


# --------------------------------------------------------------------------- office maps


def test_office_default_size_and_connectivity():
    m = generate_office_map()
    assert m.shape == (60, 60)
    assert m.n_patroller_cells >= 800
    _, n = ndimage.label(m.patroller, structure=ndimage.generate_binary_structure(2, 1))
    assert n == 1
    # one cell wide: no 2x2 block of hallway
    p = m.patroller
    assert not (p[:-1, :-1] & p[1:, :-1] & p[:-1, 1:] & p[1:, 1:]).any()
    # L starts in a room next to the hallway; goals are L-only rooms
    r, c = m.observer_start
    assert m.observer_only[r, c] and not m.patroller[r, c]
    nbrs = [(r + dr, c + dc) for dr, dc in ((0, 1), (-1, 0), (0, -1), (1, 0))]
    assert any(0 <= a < 60 and 0 <= b < 60 and p[a, b] for a, b in nbrs)
    assert 1 <= len(m.goals) <= 2
    assert all(m.free[g] for g in m.goals)


def test_office_deterministic_by_seed():
    a, b = generate_office_map(seed=3), generate_office_map(seed=3)
    assert np.array_equal(a.patroller, b.patroller)
    assert a.observer_start == b.observer_start and a.goals == b.goals
    assert np.array_equal(a.visibility_order, b.visibility_order)
    c = generate_office_map(seed=4)
    assert not np.array_equal(a.patroller, c.patroller)


@pytest.mark.parametrize("seed", [0, 1, 7])
def test_office_visibility_order_covers_cells_once(seed):
    m = generate_office_map(seed=seed)
    order = order_list(m)
    assert len(order) == len(set(order)) == m.n_patroller_cells
    assert set(order) == set(map(tuple, m.patroller_cells.tolist()))


def test_office_text_roundtrip():
    m = generate_office_map(30, 40, seed=2)
    m2 = parse_map(m.to_text())
    assert np.array_equal(m.patroller, m2.patroller)
    assert m2.observer_start == m.observer_start and set(m2.goals) == set(m.goals)


def test_office_map_from_name():
    assert office_map_from_name("boyd2") is None
    assert office_map_from_name("officer") is None
    m = office_map_from_name("office")
    assert m.shape == (60, 60)
    assert np.array_equal(m.patroller, generate_office_map().patroller)
    m = office_map_from_name("office-30x45")
    assert m.shape == (30, 45)
    m = office_map_from_name("office-30x45-s5")
    assert np.array_equal(m.patroller, generate_office_map(30, 45, seed=5).patroller)
    assert m.name == "office-30x45-s5"
    with pytest.raises(MapError, match=r"^office-3x3: "):
        office_map_from_name("office-3x3")


@pytest.mark.parametrize(
    "kwargs, problem",
    [
        ({"rows": 4}, "at least 5x5"),
        ({"corridor_spacing": 2}, "corridor_spacing"),
        ({"removal": 1.0}, "removal"),
        ({"removal": -0.1}, "removal"),
        ({"n_goals": 0}, "n_goals"),
    ],
)
def test_impossible_parameters_are_refused(kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        generate_office_map(**kwargs)


@pytest.mark.parametrize("n_goals", [1, 3])
def test_the_goal_rooms_asked_for_are_placed_apart_from_each_other_and_from_l(n_goals):
    m = generate_office_map(40, 40, seed=1, n_goals=n_goals)
    assert len(m.goals) == n_goals and m.goals == tuple(sorted(m.goals))
    rooms = [m.observer_start, *m.goals]
    assert all(m.observer_only[r] and not m.patroller[r] for r in rooms)
    for i, a in enumerate(rooms):
        for b in rooms[i + 1 :]:
            assert abs(a[0] - b[0]) + abs(a[1] - b[1]) > 1  # each room has its own walls


def test_removal_takes_segments_out_but_never_disconnects():
    full = generate_office_map(seed=5, removal=0.0)
    sparse = generate_office_map(seed=5, removal=0.5)
    assert sparse.n_patroller_cells < full.n_patroller_cells
    for m in (full, sparse):
        _, n = ndimage.label(m.patroller, structure=ndimage.generate_binary_structure(2, 1))
        assert n == 1


def test_the_default_name_says_size_and_seed():
    m = generate_office_map(30, 35, seed=9)
    assert m.name == "office-30x35-s9" and "seed 9" in m.source
    assert generate_office_map(30, 35, seed=9, name="mine").name == "mine"
