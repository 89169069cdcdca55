"""A toy world for the test that adding a world is one module and one row
(tests/worlds/test_registry.py): the grid world in fog, which hides each of L's sightings with
probability ``FOG`` on a stream of its own. Nothing else in mirl knows it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mirl.world.scenario import Scenario
from mirl.worlds.contract import RunSetup, Simulation, World
from mirl.worlds.grid import GridRunWorld

FOG = 0.5
_FOG_STREAM = 7  # the fog's stream, apart from the patrollers' and L's


class FoggyGridWorld(GridRunWorld):
    """The grid world, each sighting lost in fog with probability :data:`FOG`."""

    def __init__(self, setup: RunSetup) -> None:
        self._fog = np.random.default_rng([setup.seed, _FOG_STREAM])
        super().__init__(setup)

    def _seen(self, obs: np.ndarray) -> np.ndarray:
        seen = super()._seen(obs)
        return np.where(self._fog.random(len(seen)) < FOG, -1, seen)

    @staticmethod
    def simulate(
        scenario: Scenario,
        steps: int,
        *,
        seed: int,
        observability: float | None = None,
        heading_noise: float = 0.0,
        random_starts: bool = False,
    ) -> Simulation:
        sim = GridRunWorld.simulate(
            scenario, steps, seed=seed, observability=observability,
            heading_noise=heading_noise, random_starts=random_starts,
        )  # fmt: skip
        fog = np.random.default_rng([seed, _FOG_STREAM])
        kept = fog.random(len(sim.observations)) >= FOG
        hidden = f"fog: {int((~kept).sum())} of {len(kept)} sightings lost"
        kept_observations = sim.observations.select(kept)
        return replace(sim, observations=kept_observations, report=(*sim.report, hidden))


_CONTRACT: World = FoggyGridWorld
