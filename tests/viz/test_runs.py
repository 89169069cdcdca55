"""Drawing a run: the map panel is the drawing its world's row names, chosen by the run's
world and not by what the run recorded."""

from __future__ import annotations

import inspect
from dataclasses import replace

import pytest

pytest.importorskip("matplotlib")

from mirl._registry import resolve  # noqa: E402
from mirl.experiments.episode import run_episode  # noqa: E402
from mirl.viz import runs  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from mirl.worlds import WORLDS  # noqa: E402


@pytest.mark.parametrize("name", list(WORLDS))
def test_every_worlds_drawing_takes_a_run_and_its_context(name):
    draw = resolve(WORLDS[name].drawing)
    params = inspect.signature(draw).parameters
    assert list(params)[:3] == ["ax", "scenario", "result"]
    assert params["context"].kind is inspect.Parameter.KEYWORD_ONLY


def test_the_run_figure_draws_with_its_worlds_drawing(monkeypatch):
    boyd2 = load_scenario("boyd2")
    protocol = {"obs_steps": 60, "watch_until_seen": None, "max_wait": 20}
    result = run_episode(boyd2, "oracle", seed=0, protocol=protocol)
    assert result.world == "grid"
    calls = []

    def drawing(ax, scenario, result, **options):
        calls.append((result.world, options))
        return ax

    monkeypatch.setattr(runs, "draw_run", drawing)
    runs.run_figure(boyd2, result)
    runs.run_figure(boyd2, result, context=5)
    assert calls == [("grid", {}), ("grid", {"context": 5})]
    elsewhere = replace(result, world="physics")  # a row's drawing is found by the run's world
    with pytest.raises(AttributeError, match="world"):
        runs.run_figure(boyd2, elsewhere)  # the physics drawing needs the physics extras
