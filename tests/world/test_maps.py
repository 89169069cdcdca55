"""Maps: plain-text core, ROS map_server maps, generated office floors, rendering."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from scipy import ndimage

from mirl.viz.maps import draw_map, map_to_text, save_map_png
from mirl.world.catalog import load_map, shipped_maps
from mirl.world.maps import GridMap, MapError, line_of_sight, parse_map
from mirl.world.office_maps import generate_office_map, office_map_from_name
from mirl.world.ros_maps import load_ros_map
from tests.references.line_of_sight import line_of_sight as reference_line_of_sight

# the reference maps in ../shared beside the checkout (where CI and the developers have them)
SHARED_MAPS = Path(__file__).resolve().parents[3] / "shared" / "maps"


def cells(*rc):
    return [tuple(x) for x in rc]


def order_list(m: GridMap) -> list[tuple[int, int]]:
    return [tuple(map(int, rc)) for rc in m.visibility_order]


# --------------------------------------------------------------------------- core maps


def test_shipped_maps_listed():
    assert {"boyd2", "boydright"} <= set(shipped_maps())


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


def test_missing_map_file(tmp_path):
    path = tmp_path / "nope.txt"
    with pytest.raises(MapError, match="no such file") as exc:
        load_map(path)
    assert str(exc.value).startswith(str(path))


def test_unreadable_map_file(tmp_path):
    path = tmp_path / "binary.txt"
    path.write_bytes(b"\xff\xfe\x00\x81L..\n")
    with pytest.raises(MapError, match="cannot read") as exc:
        load_map(path)
    assert str(exc.value).startswith(str(path))
    d = tmp_path / "dir.txt"
    d.mkdir()
    with pytest.raises(MapError, match="cannot read"):
        load_map(d)


# --------------------------------------------------------------------------- ROS maps


def _scaled_free_pixels(m: GridMap, k: int) -> np.ndarray:
    return np.kron(m.free.astype(np.uint8), np.ones((k, k), dtype=np.uint8)).astype(bool)


def _write_ros(tmp_path, free_px, *, name="boyd2", extra=None, plain=False, **keys):
    pixels = np.where(free_px, 254, 0).astype(np.uint8)  # map_saver: free 254, occupied 0
    img = tmp_path / f"{name}.pgm"
    if plain:  # P2, ASCII
        h, w = pixels.shape
        body = "\n".join(" ".join(map(str, row)) for row in pixels)
        img.write_text(f"P2\n# written by test\n{w} {h}\n255\n{body}\n")
    else:
        Image.fromarray(pixels, mode="L").save(img)
    data = {
        "image": img.name,
        "resolution": 0.5,
        "origin": [-2.0, -3.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    data.update(keys)
    data.update(extra or {})
    yml = tmp_path / f"{name}.yaml"
    yml.write_text(yaml.safe_dump(data))
    return yml


@pytest.mark.parametrize("plain", [False, True])
def test_ros_roundtrip_boyd2(tmp_path, plain):
    m = load_map("boyd2")
    yml = _write_ros(
        tmp_path,
        _scaled_free_pixels(m, 2),
        plain=plain,
        extra={"mirl_observer_start": [0, 0], "mirl_goals": [[9, 1]]},
    )
    r = load_ros_map(yml, cell_size=1.0)
    assert r.shape == m.shape
    assert np.array_equal(r.patroller, m.patroller)
    assert np.array_equal(r.observer_only, m.observer_only)
    assert r.observer_start == (0, 0) and r.goals == ((9, 1),)
    assert order_list(r) == order_list(m)
    assert r.source == str(yml) and r.name == "boyd2"
    # through the generic loader too
    r2 = load_map(yml, cell_size=1.0)
    assert np.array_equal(r2.patroller, m.patroller)


def test_ros_default_cell_size_is_half_a_metre(tmp_path):
    m = load_map("boyd2")
    yml = _write_ros(tmp_path, _scaled_free_pixels(m, 2))  # 0.5 m a pixel
    r = load_ros_map(yml, observer_start=(0, 0), goals=[(18, 2)])
    assert r.shape == (34, 18) and r.frame.cell_size == 0.5
    assert r.n_patroller_cells == 4 * m.free.sum() - 1
    fine = _write_ros(tmp_path, _scaled_free_pixels(m, 20), name="fine", extra={"resolution": 0.05})
    r = load_ros_map(fine)  # 0.05 m a pixel: cells of 0.5 m, not of a pixel
    assert r.shape == (34, 18) and r.frame.cell_size == 0.5
    coarse = _write_ros(
        tmp_path, _scaled_free_pixels(m, 1), name="coarse", extra={"resolution": 1.0}
    )
    assert load_ros_map(coarse).frame.cell_size == 1.0  # never finer than a pixel


def test_ros_plain_map_is_unmarked(tmp_path):
    m = load_map("boyd2")
    r = load_ros_map(_write_ros(tmp_path, _scaled_free_pixels(m, 2)), cell_size=1.0)
    assert not r.marked
    assert np.array_equal(r.patroller, m.free)  # L's room is a free cell like any other
    assert not r.observer_only.any()
    assert "L" not in r.to_text() and "G" not in r.to_text()
    marked = r.with_observer((0, 0), (9, 1))
    assert marked.marked and marked.observer_start == (0, 0) and marked.goals == ((9, 1),)


def test_ros_grid_limit_counts_cells_and_names_a_cell_size_that_fits(tmp_path):
    px = np.ones((20, 1200), dtype=bool)  # 60 m wide at 0.05 m a pixel
    yml = _write_ros(tmp_path, px, name="long", extra={"resolution": 0.05})
    assert load_ros_map(yml).shape == (2, 120)  # 1200 pixels a side are 120 cells of 0.5 m
    msg = _ros_error(yml, cell_size=0.05)
    assert "`cell_size` 0.05 m" in msg and "1200 cells a side" in msg
    assert "`cell_size` of at least 0.1 m" in msg
    assert load_ros_map(yml, cell_size=0.1).shape[1] <= 1000


def test_ros_cell_free_only_if_all_pixels_free(tmp_path):
    m = load_map("boyd2")
    px = _scaled_free_pixels(m, 2)
    px[2 * 5 + 1, 2 * 1] = False  # one occupied pixel in cell (5, 1)
    pixels = np.where(px, 254, 0).astype(np.uint8)
    pixels[2 * 7, 2 * 1 + 1] = 205  # unknown pixel in cell (7, 1)
    yml = _write_ros(tmp_path, px, extra={"mirl_observer_start": [0, 0], "mirl_goals": [[9, 1]]})
    Image.fromarray(pixels, mode="L").save(tmp_path / "boyd2.pgm")
    r = load_ros_map(yml, cell_size=1.0)
    expected = m.patroller.copy()
    expected[5, 1] = expected[7, 1] = False
    assert np.array_equal(r.patroller, expected)


def test_ros_negate_and_png(tmp_path):
    m = load_map("boyd2")
    px = _scaled_free_pixels(m, 2)
    rgb = np.zeros(px.shape + (3,), dtype=np.uint8)
    rgb[px] = 0
    rgb[~px] = 255  # negated: white is occupied
    Image.fromarray(rgb, mode="RGB").save(tmp_path / "neg.png")
    yml = tmp_path / "neg.yaml"
    yml.write_text(
        yaml.safe_dump(
            {
                "image": "neg.png",
                "resolution": 0.5,
                "origin": [0, 0, 0],
                "negate": 1,
                "occupied_thresh": 0.65,
                "free_thresh": 0.196,
            }
        )
    )
    r = load_ros_map(yml, cell_size=1.0, observer_start=(0, 0), goals=[(16, 8)])
    assert np.array_equal(r.patroller, m.patroller)
    assert r.goals == ((16, 8),)


def test_ros_keyword_arguments_override_yaml(tmp_path):
    m = load_map("boyd2")
    yml = _write_ros(
        tmp_path,
        _scaled_free_pixels(m, 2),
        extra={"mirl_observer_start": [0, 0], "mirl_goals": [[9, 1]]},
    )
    r = load_ros_map(yml, cell_size=1.0, observer_start=(16, 8), goals=[(0, 0), (3, 1)])
    assert r.observer_start == (16, 8) and r.goals == ((0, 0), (3, 1))
    assert not r.patroller[16, 8] and r.observer_only[16, 8]
    assert r.patroller[0, 0]


def _ros_error(yml, **kw) -> str:
    with pytest.raises(MapError) as exc:
        load_ros_map(yml, **kw)
    msg = str(exc.value)
    assert msg.startswith(str(yml)), msg
    assert "\n" not in msg, msg
    return msg


def test_ros_errors(tmp_path):
    m = load_map("boyd2")
    px = _scaled_free_pixels(m, 2)
    lg = {"mirl_observer_start": [0, 0], "mirl_goals": [[9, 1]]}

    assert "no such file" in _ros_error(tmp_path / "missing.yaml")

    bad = tmp_path / "bad.yaml"
    bad.write_text("image: [unclosed\nresolution: : :\n")
    assert "invalid YAML" in _ros_error(bad)

    bad.write_text("- just\n- a list\n")
    assert "mapping" in _ros_error(bad)

    yml = _write_ros(tmp_path, px, extra=lg)
    data = yaml.safe_load(yml.read_text())
    for key in ("image", "resolution", "origin"):
        d = dict(data)
        del d[key]
        bad.write_text(yaml.safe_dump(d))
        assert f"missing key '{key}'" in _ros_error(bad)

    bad.write_text(yaml.safe_dump({**data, "image": "nothere.pgm"}))
    assert "not found" in _ros_error(bad)

    (tmp_path / "junk.pgm").write_bytes(b"this is not an image")
    bad.write_text(yaml.safe_dump({**data, "image": "junk.pgm"}))
    assert "cannot read image" in _ros_error(bad)

    bad.write_text(yaml.safe_dump({**data, "resolution": "fine"}))
    assert "'resolution' must be a number" in _ros_error(bad)

    bad.write_text(yaml.safe_dump({**data, "mode": "fancy"}))
    assert "unknown mode" in _ros_error(bad)

    assert "smaller than the map resolution" in _ros_error(yml, cell_size=0.25)

    nolg = _write_ros(tmp_path, px, name="nolg")
    msg = _ros_error(nolg, cell_size=1.0, observer_start=(0, 0))
    assert "marks L's start but not its goal" in msg and "[observer]" in msg
    assert "mirl_goals" in msg

    assert "not a free cell" in _ros_error(yml, cell_size=1.0, observer_start=(5, 5))
    assert "outside" in _ros_error(yml, cell_size=1.0, goals=[(40, 1)])
    assert "not a free cell" in _ros_error(yml, cell_size=1.0, goals=[(3, 3)])
    assert "[row, col]" in _ros_error(yml, cell_size=1.0, observer_start=("a", 1))


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


# --------------------------------------------------------------------------- rendering


def test_save_map_png(tmp_path):
    m = load_map("boyd2")
    out = save_map_png(m, tmp_path / "boyd2.png", observability=0.14)
    assert out.stat().st_size > 1000
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    svg = save_map_png(m, tmp_path / "sub" / "boyd2.svg")
    assert b"<svg" in svg.read_bytes()[:2000]


def test_draw_map_axes_coordinates():
    from matplotlib.figure import Figure

    m = load_map("boydright")
    fig = Figure()
    ax = fig.add_subplot()
    assert draw_map(ax, m, m.visible_mask(0.5)) is ax
    assert ax.get_xlim() == (-0.5, 17.5)
    assert ax.get_ylim() == (13.5, -0.5)  # row 0 at the top
    ax.plot([17, 16], [0, 0])  # later layers use x = col, y = row


@pytest.mark.parametrize("name", ["boyd2", "boydright"])
@pytest.mark.parametrize("degree", [0.0, 0.14, 0.5, 1.0])
def test_map_to_text_marks_visible_cells(name, degree):
    m = load_map(name)
    text = map_to_text(m, m.visible_mask(degree))
    grid = [ln for ln in text.splitlines() if not ln.startswith(";")]
    assert len(grid) == m.shape[0] and all(len(ln) == m.shape[1] for ln in grid)
    body = "".join(grid)
    assert body.count("o") + body.count("O") == round(degree * m.n_patroller_cells)
    assert "visible" in text.splitlines()[-1] or "visible" in text.splitlines()[-2]
    assert body.count("L") == 1


def test_map_to_text_without_mask_is_parseable():
    m = load_map("boydright")
    text = map_to_text(m)
    assert set("".join(ln for ln in text.splitlines() if not ln.startswith(";"))) <= set(".#LGg")
    m2 = parse_map(text)
    assert np.array_equal(m2.patroller, m.patroller)
    assert text.splitlines()[: m.shape[0]] == m.to_text().splitlines()


def test_map_to_text_boyd2_014():
    m = load_map("boyd2")
    first = map_to_text(m, m.visible_mask(0.14)).splitlines()[0]
    assert first == "Loooo...."


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


def test_ros_wall_one_pixel_thick_still_separates_rooms(tmp_path):
    px = np.ones((40, 40), dtype=bool)  # 2 m x 2 m at 0.05 m a pixel
    px[:, 23] = False  # a wall 5 cm thick, inside the third column of 0.5 m cells
    r = load_ros_map(_write_ros(tmp_path, px, name="thin", extra={"resolution": 0.05}))
    assert r.shape == (4, 4)
    assert not r.patroller[:, 2].any()  # the cells the wall crosses are walls
    assert r.patroller[:, [0, 1, 3]].all()  # and the rooms either side stay whole
