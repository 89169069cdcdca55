"""Learning from a smooth track read at its robots' own speed: the pace is a healthy one only if
a robot that moves at it keeps its line (mirl.learning.verdicts.weak_pace)."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.learn import learn
from mirl.observations.discretise import discretise
from mirl.observations.poses import PoseTracks
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("boyd2")


def _veering(scenario, veer: tuple[float, float], speed: float = 0.5) -> PoseTracks:
    """I and J driving the top hallway back and forth at about ``speed`` cells a second (its
    speed swinging by 15 %, so that its changes of cell keep no period), tracked at 20 Hz, each
    ``veer`` of a cell to the left of its line (J 13 s behind I)."""
    frame = scenario.map.frame
    cells = [c for c in range(scenario.map.shape[1]) if scenario.map.patroller[0, c]]
    lo, hi = min(cells), max(cells)
    length = hi - lo
    out = []
    for i, (lag, left) in enumerate(zip((0.0, 13.0), veer, strict=True)):
        t = np.arange(0.0, 900.0, 0.05)
        along = speed * (t + lag) + speed * 0.15 * 37 / (2 * np.pi) * np.sin(
            2 * np.pi * (t + lag) / 37
        )  # the integral of speed · (1 + 0.15 sin(2π t / 37))
        phase = np.mod(along, 2 * length)
        east = phase < length
        col = lo + np.where(east, phase, 2 * length - phase)
        row = np.where(east, -left, left)  # left of east is north, of west south
        x, y = frame.cell_centre(row, col)
        out.append((t, np.full(len(t), i), x, y, np.where(east, 0.0, np.pi)))
    t, robot, x, y, yaw = (np.concatenate(c) for c in zip(*out, strict=True))
    return PoseTracks(("I", "J"), t, robot, x, y, yaw)


def _verdicts(scenario, veer):
    d = discretise(_veering(scenario, veer), scenario, step_seconds="auto")
    assert d.auto_step.why == "speed" and d.trajectories.pace_from_speed
    result = learn(d.trajectories, scenario, "mirl-t", observability=1.0, random_state=0)
    return {r.name: r.verdict for r in result.robots}


def test_a_pace_every_robot_at_it_veers_from_is_a_weak_robot_s(scenario):
    verdicts = _verdicts(scenario, (0.3, 0.3))
    for name, v in verdicts.items():
        assert v.weakened is not None, (name, v)
        assert not v.fit.ok and "veers towards a weak wheel" in v.fit.reason
        assert v.confidence < 0.9
        assert "pace" in v.fit.to_dict()["checks"]


def test_a_robot_at_the_pace_that_keeps_its_line_makes_it_a_healthy_pace(scenario):
    verdicts = _verdicts(scenario, (0.3, 0.0))
    assert verdicts["I"].weakened is not None and verdicts["J"].weakened is None
    assert all(v.fit.to_dict()["checks"]["pace"]["ok"] for v in verdicts.values())
