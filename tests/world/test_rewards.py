"""Reward features as data (:mod:`mirl.world.rewards`): the table of kinds, its row check, and
what each kind rewards on a small map, counted by hand."""

from __future__ import annotations

import numpy as np
import pytest

from mirl._registry import Registry, UnknownNameError
from mirl.world.actions import FORWARD, STOP, TURN_LEFT, TURN_RIGHT
from mirl.world.domain import PatrolDomain
from mirl.world.maps import dead_ends, parse_map
from mirl.world.rewards import (
    FIELDS,
    KINDS,
    FeatureKind,
    RewardFeature,
    RewardSpec,
    _check_kind,
    read_reward_spec,
)
from mirl.world.schema import FieldError

CORRIDOR = "L.G...\n"  # L's room (0,0); hallway (0,1)…(0,5), dead ends at both ends


def test_the_kinds_and_what_they_take():
    assert KINDS.names == ("moved", "region", "turn_around", "heading_in_region")
    for kind in KINDS.values():
        assert set(kind.needs) <= set(kind.takes) <= set(FIELDS)


@pytest.mark.parametrize(
    "kind",
    [
        FeatureKind("speed", ("speed",), (), lambda d, f: np.zeros(0)),  # a field no file has
        FeatureKind("spot", (), ("cells",), lambda d, f: np.zeros(0)),  # needs what it refuses
    ],
)
def test_a_kind_a_scenario_could_not_write_is_refused(kind):
    with pytest.raises(ValueError, match=f"reward-feature kind '{kind.name}'"):
        Registry("reward-feature kind", [kind], check=_check_kind)


def test_an_unknown_kind_names_the_nearest():
    near = r"unknown reward-feature kind 'regoin' \(did you mean 'region'"
    with pytest.raises(ValueError, match=near):
        RewardFeature("x", "regoin")
    with pytest.raises(UnknownNameError):
        KINDS.lookup("speed")
    with pytest.raises(FieldError, match=r"reward\.features\[0\]\.kind"):
        read_reward_spec({"features": [{"name": "x", "kind": "speed"}]}, (1, 6))


def test_each_kind_rewards_what_it_says():
    gm = parse_map(CORRIDOR, name="corridor")
    spec = RewardSpec((
        RewardFeature("moved", "moved"),
        RewardFeature("middle", "region", ((0, 3),)),
        RewardFeature("ends", "turn_around"),
        RewardFeature("east_at_2", "heading_in_region", ((0, 2),), (0,)),
    ))  # fmt: skip
    d = PatrolDomain(gm, reward_spec=spec)
    phi = d.reward_features  # (S, A, K)
    s = d.state_index(0, 3, 0)  # facing east in the middle: forward changes cell
    assert phi[s, FORWARD, 0] == 1 and phi[s, STOP, 0] == 0
    assert phi[d.state_index(0, 5, 0), FORWARD, 0] == 0  # facing the wall: stays
    assert np.all(phi[s, :, 1] == 1) and np.all(phi[d.state_index(0, 4, 0), :, 1] == 0)
    end = d.state_index(0, 5, 1)
    assert phi[end, TURN_LEFT, 2] == phi[end, TURN_RIGHT, 2] == 1 and phi[end, FORWARD, 2] == 0
    assert phi[d.state_index(0, 3, 1), TURN_LEFT, 2] == 0  # not a dead end
    assert np.all(phi[d.state_index(0, 2, 0), :, 3] == 1)
    assert np.all(phi[d.state_index(0, 2, 2), :, 3] == 0)  # facing west


def test_turn_around_cells_are_the_first_feature_s_own_or_the_dead_ends():
    gm = parse_map(CORRIDOR, name="corridor")
    assert RewardSpec((RewardFeature("m", "moved"),)).turn_around_cells(gm) == dead_ends(gm)
    own = RewardSpec((RewardFeature("t", "turn_around", ((0, 3),)),))
    assert own.turn_around_cells(gm) == ((0, 3),)
