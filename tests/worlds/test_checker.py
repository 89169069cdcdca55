"""``check_world`` on every row of the table (physics too, a few steps), and on worlds broken in
the ways it exists to catch."""

from __future__ import annotations

import itertools
from dataclasses import replace

import pytest

from mirl.worlds import WORLDS, check_world
from mirl.worlds.checker import WorldContractError
from mirl.worlds.grid import GridRunWorld


@pytest.mark.parametrize("name", list(WORLDS))
def test_every_world_of_the_table_keeps_the_contract(name):
    row = WORLDS[name]
    try:
        row.check()
    except ImportError:
        pytest.skip(f"the {name} world's extra is not installed")
    check_world(row, steps=3)


class Frozen(GridRunWorld):
    """t does not advance."""

    def step(self, observer_action=None, *, patroller_actions=None):
        out = super().step(observer_action, patroller_actions=patroller_actions)
        self._t -= 1
        return out


class Unseeded(GridRunWorld):
    """Its patrollers' starts are drawn from a seed of its own, not the setup's."""

    built = itertools.count()

    def __init__(self, setup):
        super().__init__(replace(setup, seed=setup.seed + next(self.built)))


class SeesEverything(GridRunWorld):
    """Reports patrollers L cannot see from its room."""

    def _seen(self, obs):
        return self.sim.states.copy()


class Undamageable(GridRunWorld):
    @staticmethod
    def apply_damage(scenario, robot, feature, value):
        scenario.robot_index(robot)
        if not 0 <= value <= 1 or feature not in scenario.feature_map.features:
            raise ValueError("no such part")
        return scenario  # damage is silently dropped


class TakesNoActions(GridRunWorld):
    takes_patroller_actions = False  # but steps them anyway


class ForgetfulSimulation(GridRunWorld):
    @staticmethod
    def simulate(scenario, steps, *, seed, observability=None, heading_noise=0.0,
                 random_starts=False):  # fmt: skip
        return GridRunWorld.simulate(scenario, steps, seed=seed, heading_noise=heading_noise,
                                     random_starts=random_starts)  # fmt: skip


@pytest.mark.parametrize(
    "world, needle",
    [
        (Frozen, "step\\(\\) advances t by one"),
        (Unseeded, "one setup .* gives one run"),
        (SeesEverything, "L sees patrollers only on its visible states"),
        (Undamageable, "apply_damage\\(left_wheel=0.5\\) damages it"),
        (TakesNoActions, "takes_patroller_actions is False, yet"),
        (ForgetfulSimulation, "simulate\\(observability=...\\) is the view used"),
    ],
)
def test_a_broken_world_is_named_with_what_it_breaks(world, needle):
    with pytest.raises(WorldContractError, match=f"world '{world.__name__}': {needle}"):
        check_world(world, steps=3)


def test_the_grid_worlds_class_passes_without_its_row():
    check_world(GridRunWorld, "boydright-3", steps=3, seed=4)
