"""ROS map_server maps: pixels to free cells, the map frame, marks and refusals."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from mirl.world.catalog import load_map
from mirl.world.maps import GridMap, MapError
from mirl.world.ros_maps import (
    discretise_free_mask,
    load_ros_map,
    occupancy_free_mask,
    ros_map_frame,
)


def order_list(m: GridMap) -> list[tuple[int, int]]:
    return [tuple(map(int, rc)) for rc in m.visibility_order]


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

    # safe_load keeps the last of a key given twice: an edit above a forgotten line is refused
    bad.write_text("image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nresolution: 0.1\n")
    assert _ros_error(bad).endswith("line 4: key 'resolution' given twice; give it once")

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


def test_ros_wall_one_pixel_thick_still_separates_rooms(tmp_path):
    px = np.ones((40, 40), dtype=bool)  # 2 m x 2 m at 0.05 m a pixel
    px[:, 23] = False  # a wall 5 cm thick, inside the third column of 0.5 m cells
    r = load_ros_map(_write_ros(tmp_path, px, name="thin", extra={"resolution": 0.05}))
    assert r.shape == (4, 4)
    assert not r.patroller[:, 2].any()  # the cells the wall crosses are walls
    assert r.patroller[:, [0, 1, 3]].all()  # and the rooms either side stay whole


# ---- the pixel rules, one function at a time --------------------------------------------------


def test_free_pixels_follow_map_servers_thresholds():
    grey = np.array([[0, 100, 204, 205, 254, 255]])
    # trinary: occupancy p = (255 - x) / 255, free when p < 0.196, i.e. x > 205.02
    assert occupancy_free_mask(grey).tolist() == [[False, False, False, False, True, True]]
    # negate: p = x / 255, free when x < 49.98
    assert occupancy_free_mask(grey, negate=True).tolist() == [[True] + [False] * 5]
    # raw: the value is the occupancy in percent, anything above 100 unknown
    raw = np.array([[0, 19, 20, 100, 101, 255]])
    expected = [[True, True, False, False, False, False]]
    assert occupancy_free_mask(raw, mode="raw").tolist() == expected


def test_scale_mode_treats_a_pixel_not_fully_opaque_as_unknown():
    grey = np.full((1, 3), 254)
    alpha = np.array([[255, 254, 0]])
    assert occupancy_free_mask(grey, mode="scale", alpha=alpha).tolist() == [[True, False, False]]
    assert occupancy_free_mask(grey, mode="trinary", alpha=alpha).all()  # alpha unused


@settings(max_examples=40, deadline=None)
@given(
    bits=st.lists(st.booleans(), min_size=7 * 9, max_size=7 * 9),
    k=st.sampled_from([1, 2, 3]),
)
def test_a_cell_is_free_when_every_pixel_whose_centre_it_holds_is_free(bits, k):
    """Against the rule written out pixel by pixel: cells of k pixels, complete cells only."""
    free = np.array(bits).reshape(7, 9)
    cells = discretise_free_mask(free, resolution=0.1, cell_size=0.1 * k)
    rows, cols = -(-7 // k), -(-9 // k)
    assert cells.shape == (rows, cols)
    for r in range(rows):
        for c in range(cols):
            block = free[r * k : (r + 1) * k, c * k : (c + 1) * k]
            complete = block.shape == (k, k)
            assert cells[r, c] == (complete and bool(block.all())), (r, c)


def test_the_frame_puts_cell_0_0_half_a_cell_inside_the_top_left_corner():
    frame = ros_map_frame([-2.0, -3.0, 0.7], resolution=0.05, height_px=200, cell_size=0.5)
    # the image spans y from -3 to -3 + 200 * 0.05 = 7; row 0 is the top
    assert frame.cell_size == 0.5
    assert (frame.origin_x, frame.origin_y) == pytest.approx((-1.75, 6.75))
    x, y = frame.cell_centre(0, 0)
    assert (float(x), float(y)) == pytest.approx((-1.75, 6.75))
    assert float(frame.cell_centre(1, 0)[1]) == pytest.approx(6.25)  # rows go south
