"""The contract's types: mypy checks a world's class and its instances against ``World`` (a
class that breaks it is an error), and the records a world returns say what they hold."""

from __future__ import annotations

import dataclasses
import textwrap

import numpy as np
import pytest

from mirl.observations.trajectories import Trajectories
from mirl.worlds.contract import Detection, Simulation


@pytest.mark.slow  # about 15 s of mypy; `mypy src` checks the shipped worlds' classes every time
def test_mypy_checks_a_world_class_against_the_contract(tmp_path):
    api = pytest.importorskip("mypy.api")
    module = tmp_path / "worlds_under_check.py"
    module.write_text(
        textwrap.dedent("""
        import numpy as np

        from mirl.worlds.contract import World
        from mirl.worlds.grid import GridRunWorld


        class WrongVersion(GridRunWorld):
            @staticmethod
            def version() -> int:  # type: ignore[override]
                return 0


        class WrongStep(GridRunWorld):
            def step(  # type: ignore[override]
                self, observer_action: int | None = None
            ) -> np.ndarray:
                return super().step(observer_action)


        kept: World = GridRunWorld
        version: World = WrongVersion
        step: World = WrongStep
    """)
    )
    out, _, status = api.run(
        [str(module), "--cache-dir", str(tmp_path / "cache"), "--follow-imports=silent"]
    )
    errors = [line for line in out.splitlines() if ": error:" in line]
    assert status == 1 and len(errors) == 2, out
    assert any("type[WrongVersion]" in e for e in errors)
    assert any("type[WrongStep]" in e for e in errors)


def test_a_simulation_counts_its_steps_and_each_robots_sightings():
    names = ("I", "J")
    truth = Trajectories(names, np.repeat(np.arange(4), 2), np.tile([0, 1], 4),
                         *np.zeros((3, 8), dtype=int), 4)  # fmt: skip
    seen = truth.select((truth.robot == 0) | (truth.t == 0))  # I always, J once
    sim = Simulation(seen, truth, 0.5)
    assert sim.steps == 4
    np.testing.assert_allclose(sim.observed_share(), [1.0, 0.25])
    assert sim.poses is None and sim.report == () and sim.step_seconds is None


def test_records_are_frozen():
    d = Detection(3, "I", (1, 2, 0), (0, 0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.t = 4  # type: ignore[misc]
