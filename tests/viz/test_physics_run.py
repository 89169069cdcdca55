"""Drawing a physical run: the robots' true paths over the steps drawn, L's path once it left,
L's camera cone, and at a sighting the cone of the patroller that saw L."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("matplotlib")

from matplotlib.figure import Figure  # noqa: E402

from mirl.physics.camera import Sighting  # noqa: E402
from mirl.physics.patrol import PhysicalWorld  # noqa: E402
from mirl.viz.physics_run import draw_physical_run  # noqa: E402
from mirl.world.actions import FORWARD  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from mirl.worlds.physics import PhysicsExtras  # noqa: E402


@pytest.fixture(scope="module")
def run():
    sc = load_scenario("boyd2")
    world = PhysicalWorld(sc, seed=0, random_starts=True)
    for _ in range(4):
        world.step()
    for _ in range(3):
        world.step(FORWARD)  # L leaves at step 4
    result = SimpleNamespace(
        extras=PhysicsExtras(world, "test"), observability=world.degree, go_time=4,
        end_time=world.t, robot_names=sc.robot_names, outcome="timeout", method="oracle",
        seed=0,
    )  # fmt: skip
    return sc, world, result


def _draw(sc, result, **options):
    ax = Figure().add_subplot()
    assert draw_physical_run(ax, sc, result, **options) is ax
    return ax


def test_every_robots_path_and_ls_are_drawn_over_the_steps_asked_for(run):
    sc, world, result = run
    ax = _draw(sc, result, context=2)
    labels = [line.get_label() for line in ax.get_lines()]
    assert "I (t=2…7)" in labels and "J (t=2…7)" in labels  # two steps before L left
    (l_path,) = [line for line in ax.get_lines() if line.get_label().startswith("L (left t=4)")]
    times, poses = world.tick_poses()
    rows, cols = world.frame.cell_coordinates(*poses[times >= 4 * world.cfg.step_seconds, -1, :2].T)
    np.testing.assert_allclose(l_path.get_xdata(), cols)  # drawn in cells: x = col, y = row
    np.testing.assert_allclose(l_path.get_ydata(), rows)
    assert "physics; " in ax.get_title() and f"{world.contacts} robot contacts" in ax.get_title()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(text.startswith("L's camera (57°") for text in legend)


def test_a_sighting_draws_the_cone_of_the_patroller_that_saw_l(run):
    sc, world, result = run
    before = [t.get_text() for t in _draw(sc, result).get_legend().get_texts()]
    assert not any("saw L" in text for text in before)
    world.patroller_cameras.sightings.append(
        Sighting(13.0, 6, 1, (1.0, -2.0, 0.0), (2.0, -2.0, np.pi))
    )
    try:
        ax = _draw(sc, result)
    finally:
        world.patroller_cameras.sightings.pop()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "J's camera saw L at 13.0 s" in legend
    marks = [line for line in ax.get_lines() if line.get_marker() == "X"]
    assert len(marks) == 1  # where L was seen
