"""Drawing maps: images, axes in cells and metres, the text rendering."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.viz.maps import draw_map, map_figure, map_to_text, save_map_png
from mirl.world.catalog import load_map
from mirl.world.maps import parse_map

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


def test_a_mask_of_another_shape_is_refused():
    m = load_map("boyd2")
    with pytest.raises(ValueError, match="visible_mask has shape"):
        map_to_text(m, np.zeros((3, 3), bool))


def test_routes_join_the_legend_and_metres_add_the_frames_axes():
    m = load_map("boydright")
    routes = {"I": np.array([[0, 1], [0, 2], [0, 3]]), "J": np.array([[5, 5]])}
    fig, ax = map_figure(m, m.visible_mask(0.3), routes=routes, metres=True)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "I's patrol" in labels and "J's patrol" in labels
    names = [t.get_text() for t in ax.texts]
    assert names.count("I") == 1 and names.count("J") == 1  # each route named at its start
    labels = sorted(a.get_xlabel() + a.get_ylabel() for a in ax.child_axes)
    assert labels == ["x (m)", "y (m)"]  # the frame's axes beside the cells'
    shown = int(m.visible_mask(0.3).sum())
    assert ax.get_title() == f"boydright — {shown}/{m.n_patroller_cells} cells visible"
    assert fig.axes == [ax]
