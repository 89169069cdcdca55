"""Grid maps: the plain-text format, the visibility order and lines of sight."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.world.catalog import load_map
from mirl.world.maps import GridMap, MapError, line_of_sight, parse_map
from mirl.world.office_maps import office_map_from_name
from tests.references.line_of_sight import line_of_sight as reference_line_of_sight

# the reference maps in ../shared beside the checkout (where CI and the developers have them)
SHARED_MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def cells(*rc):
    return [tuple(x) for x in rc]


def order_list(m: GridMap) -> list[tuple[int, int]]:
    return [tuple(map(int, rc)) for rc in m.visibility_order]


# --------------------------------------------------------------------------- core maps


def test_boyd2_layout():
    m = load_map("boyd2")
    assert m.shape == (17, 9)
    assert m.n_patroller_cells == 31
    assert m.observer_start == (0, 0)
    assert m.goals == ((9, 1),)
    assert m.observer_only[0, 0] and not m.patroller[0, 0]
    assert m.patroller[9, 1]  # hallway goal: patrollers pass there
    expected = (
        [(0, c) for c in range(1, 9)]
        + [(r, 1) for r in range(1, 17)]
        + [(16, c) for c in range(2, 9)]
    )
    assert order_list(m) == expected


def test_boydright_layout():
    m = load_map("boydright")
    assert m.shape == (14, 18)
    assert m.n_patroller_cells == 46
    assert m.observer_start == (0, 17)
    assert set(m.goals) == {(1, 0), (13, 13)}
    assert all(m.observer_only[g] and not m.patroller[g] for g in m.goals)


@pytest.mark.skipif(not SHARED_MAPS.is_dir(), reason="reference maps not available")
@pytest.mark.parametrize("name", ["boyd2", "boydright"])
def test_shipped_maps_match_reference(name):
    ref = load_map(SHARED_MAPS / f"{name}.txt")
    m = load_map(name)
    assert np.array_equal(ref.patroller, m.patroller)
    assert np.array_equal(ref.observer_only, m.observer_only)
    assert ref.goals == m.goals and ref.observer_start == m.observer_start


def test_boyd2_observability_014():
    m = load_map("boyd2")
    mask = m.visible_mask(0.14)
    assert set(map(tuple, np.argwhere(mask).tolist())) == {(0, 1), (0, 2), (0, 3), (0, 4)}


@pytest.mark.parametrize("name", ["boyd2", "boydright"])
def test_visibility_order_is_permutation_of_patroller_cells(name):
    m = load_map(name)
    order = order_list(m)
    assert len(order) == len(set(order)) == m.n_patroller_cells
    assert set(order) == set(map(tuple, m.patroller_cells.tolist()))
    assert m.visible_mask(0.0).sum() == 0
    assert np.array_equal(m.visible_mask(1.0), m.patroller)


@settings(max_examples=60, deadline=None)
@given(
    name=st.sampled_from(["boyd2", "boydright"]),
    d1=st.floats(0.0, 1.0),
    d2=st.floats(0.0, 1.0),
)
def test_visible_sets_nested(name, d1, d2):
    m = load_map(name)
    lo, hi = sorted((d1, d2))
    a, b = m.visible_mask(lo), m.visible_mask(hi)
    assert not (a & ~b).any()
    assert a.sum() == round(lo * m.n_patroller_cells)
    assert not (b & ~m.patroller).any()


def test_visible_mask_rejects_bad_degree():
    with pytest.raises(ValueError):
        load_map("boyd2").visible_mask(1.5)


def test_parse_roundtrip():
    m = load_map("boydright")
    m2 = parse_map(m.to_text(), name="x")
    assert np.array_equal(m.patroller, m2.patroller)
    assert m2.goals == m.goals and m2.observer_start == m.observer_start


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("L..\n.G\n", "line 2 has 2 cells"),
        ("L..\n.x.\nG..\n", "unknown character 'x'"),
        ("...\n.G.\n", "exactly one 'L'"),
        ("L..\n.GL\n", "exactly one 'L'"),
        ("L..\n...\n", "no goal"),
        ("", "empty"),
        ("; a comment\nL..\n.G\n", "line 3 has 2 cells"),  # the file's line, comments counted
        ("; a comment\nL..\n\n.G.\n", "line 3 has 0 cells"),
    ],
)
def test_malformed_maps_name_file_and_problem(tmp_path, text, problem):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(MapError) as exc:
        load_map(path)
    msg = str(exc.value)
    assert msg.startswith(str(path))
    assert problem in msg
    assert "\n" not in msg


# ---- line of sight ---------------------------------------------------------------------------
def test_line_of_sight_is_blocked_by_walls_and_diagonal_squeezes():
    grid = parse_map(
        textwrap.dedent(
            """\
            L....
            .#...
            ..#..
            ....G"""
        )
    )
    sight = line_of_sight(grid.free, (0, 0))
    assert sight[0].all() and sight[:, 0].all()  # straight along the open row and column
    assert not sight[1, 1] and not sight[2, 2]  # walls are never in sight
    assert not sight[3, 3]  # behind the diagonal of walls (1,1), (2,2)
    assert not sight[1, 2]  # the ray to (1, 2) crosses the interior of the wall (1, 1)
    assert sight[1, 3]  # the ray to (1, 3) only touches its corner
    squeeze = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 1]], dtype=bool)
    assert not line_of_sight(squeeze, (0, 0))[1, 1]  # between two walls meeting at a corner
    touch = np.array([[1, 1, 1], [0, 1, 1], [1, 1, 1]], dtype=bool)
    assert line_of_sight(touch, (0, 0))[1, 1]  # touching one wall's corner does not block


def test_line_of_sight_range_in_cells():
    open_cells = np.ones((1, 10), dtype=bool)
    assert line_of_sight(open_cells, (0, 0), max_range=3.0)[0].tolist() == [True] * 4 + [False] * 6


@settings(max_examples=40, deadline=None)
@given(
    bits=st.lists(st.booleans(), min_size=42, max_size=42),
    r0=st.integers(0, 5),
    c0=st.integers(0, 6),
)
def test_line_of_sight_matches_the_geometric_reference(bits, r0, c0):
    open_cells = np.array(bits, dtype=bool).reshape(6, 7)
    open_cells[r0, c0] = True
    assert np.array_equal(
        line_of_sight(open_cells, (r0, c0)), reference_line_of_sight(open_cells, (r0, c0))
    )


@pytest.mark.parametrize("name", ["boyd2", "boydright", "office-60x60-s2"])
def test_visibility_order_puts_the_cells_in_line_of_sight_first(name):
    m = load_map(name)
    sight = m.in_line_of_sight()
    ranks = sight[m.visibility_order[:, 0], m.visibility_order[:, 1]]
    k = int(ranks.sum())
    assert k > 0 and ranks[:k].all() and not ranks[k:].any()


def test_shipped_view_is_in_line_of_sight_and_unchanged():
    # the shipped scenarios' view at their observability (0.14): all in L's line of sight
    for name, cells in {
        "boyd2": {(0, 1), (0, 2), (0, 3), (0, 4)},
        "boydright": {(0, 16), (0, 15), (0, 14), (0, 13), (0, 12), (0, 11)},
    }.items():
        m = load_map(name)
        mask = m.visible_mask(0.14)
        assert set(map(tuple, np.argwhere(mask).tolist())) == cells
        assert not (mask & ~m.in_line_of_sight()).any()


def test_line_of_sight_hides_a_room_behind_a_corner():
    m = parse_map(
        textwrap.dedent(
            """\
            #########
            #L......#
            #######.#
            #G......#
            #########"""
        )
    )
    assert m.in_line_of_sight()[1].sum() == 6  # the upper corridor
    assert not m.in_line_of_sight()[2:].any()  # around the corner, out of sight
    k = int(m.in_line_of_sight().sum())
    assert m.visible_mask(k / m.n_patroller_cells).sum() == k
    assert not (m.visible_mask(k / m.n_patroller_cells) & ~m.in_line_of_sight()).any()


def test_line_of_sight_in_batches_is_the_same(monkeypatch):
    """The rays are cast a few million grid crossings at a time (a real map at its native
    resolution took 5 GB at once); batches of a few crossings give the same cells."""
    from mirl.world import maps as maps_module

    m = office_map_from_name("office-30x45-s5")
    assert m is not None
    cells = np.argwhere(m.patroller)
    origin = (int(cells[len(cells) // 2][0]), int(cells[len(cells) // 2][1]))  # a hallway
    whole = maps_module.line_of_sight(m.free, origin)
    monkeypatch.setattr(maps_module, "_LOS_CHUNK", 7)
    assert np.array_equal(maps_module.line_of_sight(m.free, origin), whole)
    assert whole.sum() > 10


def test_visibility_order_is_computed_on_first_use_only(monkeypatch):
    """A map loaded only to be measured or refused, or whose placeholder start a scenario
    replaces, casts no rays (Willow Garage at 0.1 m: loading took 17 s and 5 GB, now 0.4 s)."""
    from mirl.world import maps as maps_module

    calls = []
    real = maps_module.default_visibility_order
    monkeypatch.setattr(
        maps_module, "default_visibility_order", lambda *a: calls.append(a) or real(*a)
    )
    m = parse_map("L..\n#.#\n.G.\n")
    moved = m.with_observer((0, 2), (2, 1))
    assert calls == []
    order = moved.visibility_order
    assert len(calls) == 1 and order[0].tolist() == [0, 1]
    assert moved.visibility_order is order and len(calls) == 1  # kept
    given = parse_map("L..\n#.#\n.G.\n")
    assert given.with_observer((0, 0), (2, 1)) is given  # unchanged map: the same object


def test_free_pieces_join_side_adjacent_free_cells():
    """Two rooms joined by a corridor are one piece; a cell touching them only diagonally, and
    a room behind a wall, are pieces of their own (brute force: flood fill by hand)."""
    from collections import deque

    rng = np.random.default_rng(4)
    for _ in range(20):
        free = rng.random((7, 9)) < 0.55
        gm = GridMap(
            name="rand", patroller=free, observer_only=np.zeros_like(free),
            observer_start=tuple(np.argwhere(free)[0]), goals=((0, 0),),
            visibility_order=np.zeros((0, 2), dtype=int),
        )  # fmt: skip
        pieces = gm.free_pieces()
        assert (pieces[~free] == -1).all()
        seen = np.zeros_like(free)
        for start in map(tuple, np.argwhere(free)):
            if seen[start]:
                continue
            todo, members = deque([start]), []
            seen[start] = True
            while todo:
                r, c = todo.popleft()
                members.append((r, c))
                for dr, dc in ((0, 1), (1, 0), (0, -1), (-1, 0)):
                    q = (r + dr, c + dc)
                    if 0 <= q[0] < 7 and 0 <= q[1] < 9 and free[q] and not seen[q]:
                        seen[q] = True
                        todo.append(q)
            labels = {int(pieces[m]) for m in members}
            assert len(labels) == 1
            assert (pieces == labels.pop()).sum() == len(members)
