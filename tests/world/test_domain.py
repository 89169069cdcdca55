"""The patrol domain (ψ, ξ, φ, dead ends, detection) against hand-written references.

The references below never use ``mirl``'s own tables: ψ is an explicit loop over cells and
headings over a map parsed here from its text, ξ is the design's table typed out by hand, and
success probabilities are products computed with ``math.prod``.
"""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.world.catalog import load_map
from mirl.world.domain import (
    ACTIONS,
    DEFAULT_FEATURE_MAP,
    REWARD_FEATURES,
    FeatureMap,
    FeatureOverride,
    PatrolDomain,
    RewardSpec,
    dead_ends,
    detection_cells,
)
from mirl.world.maps import parse_map
from mirl.world.rewards import hallway_features
from tests.references.motion_model import DELTA, FEATURES, SPEC_XI

BOYD2_ENDS = {(0, 8), (16, 8)}


# --------------------------------------------------------------------------- references


def hallway_from_text(text: str) -> list[list[bool]]:
    """Patroller cells of a map text: '.' and 'G' (independent of mirl.world.maps.parse_map)."""
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith(";")]
    return [[ch in ".G" for ch in ln] for ln in lines]


def shipped_map_text(name: str) -> str:
    return (resources.files("mirl") / "data" / "maps" / f"{name}.txt").read_text()


def ref_states(free: list[list[bool]]) -> list[tuple[int, int, int]]:
    """Row-major cells, each with headings 0..3."""
    out = []
    for r, row in enumerate(free):
        for c, ok in enumerate(row):
            if ok:
                out.extend((r, c, h) for h in range(4))
    return out


def ref_psi(free, state, action):
    r, c, h = state
    if action == "forward":
        dr, dc = DELTA[h]
        nr, nc = r + dr, c + dc
        if 0 <= nr < len(free) and 0 <= nc < len(free[0]) and free[nr][nc]:
            return (nr, nc, h)
        return (r, c, h)
    if action == "turn_left":  # counter-clockwise: east -> north
        return (r, c, (h + 1) % 4)
    if action == "turn_right":
        return (r, c, (h - 1) % 4)
    if action == "stop":
        return (r, c, h)
    raise AssertionError(action)


def psi_as_tuples(domain: PatrolDomain):
    st_ = [tuple(map(int, s)) for s in domain.states]
    return {
        (st_[s], ACTIONS[a]): st_[int(domain.intended[s, a])]
        for s in range(domain.n_states)
        for a in range(4)
    }


def subset_of(domain: PatrolDomain, s: int, a: int) -> set[str]:
    return set(domain.subsets[int(domain.subset_index[s, a])])


@pytest.fixture(scope="module")
def boyd2():
    return PatrolDomain(load_map("boyd2"))


# --------------------------------------------------------------------------- ψ


@pytest.mark.parametrize("name", ["boyd2", "boydright"])
def test_psi_matches_hand_written_reference(name):
    free = hallway_from_text(shipped_map_text(name))
    domain = PatrolDomain(load_map(name))
    states = ref_states(free)
    assert [tuple(map(int, s)) for s in domain.states] == states
    got = psi_as_tuples(domain)
    for s in states:
        for a in ACTIONS:
            assert got[(s, a)] == ref_psi(free, s, a), (s, a)


def test_psi_specific_cases(boyd2):
    d = boyd2
    idx = {tuple(map(int, s)): i for i, s in enumerate(d.states)}

    def psi(state, action):
        return tuple(map(int, d.states[d.intended[idx[state], ACTIONS.index(action)]]))

    assert psi((0, 1, 0), "forward") == (0, 2, 0)  # east
    assert psi((5, 1, 1), "forward") == (4, 1, 1)  # north
    assert psi((0, 1, 2), "forward") == (0, 1, 2)  # west: L's room is not hallway
    assert psi((0, 1, 1), "forward") == (0, 1, 1)  # north: off the map
    assert psi((5, 1, 0), "forward") == (5, 1, 0)  # east: wall
    assert psi((0, 8, 0), "turn_left") == (0, 8, 1)  # east -> north
    assert psi((0, 8, 3), "turn_left") == (0, 8, 0)  # south -> east
    assert psi((0, 8, 0), "turn_right") == (0, 8, 3)  # east -> south
    assert psi((0, 8, 1), "turn_right") == (0, 8, 0)
    assert psi((7, 1, 3), "stop") == (7, 1, 3)


@st.composite
def random_maps(draw):
    rows = draw(st.integers(2, 6))
    cols = draw(st.integers(2, 6))
    grid = [[draw(st.booleans()) for _ in range(cols)] for _ in range(rows)]
    # L's room at (0, 0); two guaranteed hallway cells, one the goal
    grid[0][0] = False
    grid[rows - 1][cols - 1] = True
    grid[rows - 1][cols - 2] = True
    lines = []
    for r in range(rows):
        line = "".join("." if grid[r][c] else "#" for c in range(cols))
        lines.append(line)
    lines[0] = "L" + lines[0][1:]
    last = lines[-1]
    lines[-1] = last[:-1] + "G"
    return "\n".join(lines)


@settings(max_examples=60, deadline=None)
@given(random_maps())
def test_psi_on_random_maps(text):
    free = hallway_from_text(text)
    domain = PatrolDomain(parse_map(text))
    states = ref_states(free)
    assert [tuple(map(int, s)) for s in domain.states] == states
    got = psi_as_tuples(domain)
    assert got == {(s, a): ref_psi(free, s, a) for s in states for a in ACTIONS}
    # state_index inverts the state list and rejects everything else
    for i, (r, c, h) in enumerate(states):
        assert int(domain.state_index(r, c, h)) == i
    assert int(domain.state_index(0, 0, 0)) == -1  # L's room
    assert int(domain.state_index(-1, 0, 0)) == -1
    assert int(domain.state_index(states[0][0], states[0][1], 4)) == -1


# --------------------------------------------------------------------------- ξ


def test_default_xi_is_spec_table(boyd2):
    assert DEFAULT_FEATURE_MAP.features == FEATURES
    assert {a: set(v) for a, v in DEFAULT_FEATURE_MAP.action_subsets.items()} == SPEC_XI
    for s in range(boyd2.n_states):
        for a, name in enumerate(ACTIONS):
            assert subset_of(boyd2, s, a) == SPEC_XI[name]
    assert len(boyd2.subsets) == 4
    # the incidence masks agree with the subsets
    for k, sub in enumerate(boyd2.subsets):
        assert {f for f, m in zip(FEATURES, boyd2.subset_masks[k], strict=True) if m} == set(sub)


CARPET_CELLS = ((5, 1), (6, 1), (16, 4))


def carpet_map_direct(actions=None) -> FeatureMap:
    return FeatureMap(
        features=(*FEATURES, "carpet"),
        action_subsets={a: tuple(sorted(v)) for a, v in SPEC_XI.items()},
        overrides=(FeatureOverride(cells=CARPET_CELLS, actions=actions, add=("carpet",)),),
    )


def carpet_map_from_dict(actions=None) -> FeatureMap:
    override = {"cells": [list(c) for c in CARPET_CELLS], "add": ["carpet"]}
    if actions is not None:
        override["actions"] = list(actions)
    return FeatureMap.from_dict(
        {
            "features": [*FEATURES, "carpet"],
            "actions": {a: sorted(v) for a, v in SPEC_XI.items()},
            "override": [override],
        }
    )


@pytest.mark.parametrize("build", [carpet_map_direct, carpet_map_from_dict])
@pytest.mark.parametrize("actions", [None, ("forward", "turn_left")])
def test_carpet_override_changes_exactly_those_subsets(build, actions):
    gm = load_map("boyd2")
    base = PatrolDomain(gm)
    carpet = PatrolDomain(gm, build(actions))
    hit_actions = set(actions or ACTIONS)
    changed = set()
    for s in range(carpet.n_states):
        cell = tuple(map(int, carpet.states[s, :2]))
        for a, name in enumerate(ACTIONS):
            before, after = subset_of(base, s, a), subset_of(carpet, s, a)
            if cell in CARPET_CELLS and name in hit_actions:
                assert after == before | {"carpet"}
                changed.add((cell, name))
            else:
                assert after == before
    assert changed == {(c, a) for c in CARPET_CELLS for a in hit_actions}


def test_override_remove_and_all_cells():
    fm = FeatureMap(
        features=FEATURES,
        action_subsets={a: tuple(sorted(v)) for a, v in SPEC_XI.items()},
        overrides=(FeatureOverride(actions=("stop",), remove=("floor",)),),
    )
    d = PatrolDomain(load_map("boyd2"), fm)
    for s in range(d.n_states):
        assert subset_of(d, s, ACTIONS.index("stop")) == set()
        assert subset_of(d, s, 0) == SPEC_XI["forward"]
    # an empty subset succeeds with probability 1 (empty product)
    p = d.success_probabilities(dict.fromkeys(FEATURES, 0.5))
    assert np.allclose(p[:, ACTIONS.index("stop")], 1.0)


def _xi(action_subsets, overrides=(), features=FEATURES):
    return FeatureMap(features=features, action_subsets=action_subsets, overrides=overrides)


SPEC_SUBSETS = {a: tuple(sorted(v)) for a, v in SPEC_XI.items()}


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: _xi({**SPEC_SUBSETS, "stop": ("floor", "carpet")}), "carpet"),
        (lambda: _xi({**SPEC_SUBSETS, "jump": ("floor",)}), "jump"),
        (lambda: _xi({k: v for k, v in SPEC_SUBSETS.items() if k != "stop"}), "stop"),
        (lambda: _xi(SPEC_SUBSETS, (FeatureOverride(add=("mud",)),)), "mud"),
        (lambda: _xi(SPEC_SUBSETS, (FeatureOverride(remove=("ice",)),)), "ice"),
        (lambda: _xi(SPEC_SUBSETS, (FeatureOverride(actions=("fly",), add=("floor",)),)), "fly"),
        (
            lambda: FeatureMap.from_dict(
                {"features": list(FEATURES), "actions": {**SPEC_SUBSETS, "reverse": ["floor"]}}
            ),
            "reverse",
        ),
        (
            lambda: FeatureMap.from_dict(
                {
                    "features": list(FEATURES),
                    "actions": SPEC_SUBSETS,
                    "override": [{"cells": [[5, 1]], "add": ["carpet"]}],
                }
            ),
            "carpet",
        ),
    ],
)
def test_unknown_feature_or_action_is_named(make, name):
    with pytest.raises(ValueError, match=name):
        make()


def test_from_dict_missing_key_and_duplicate_feature():
    with pytest.raises(ValueError, match="actions"):
        FeatureMap.from_dict({"features": list(FEATURES)})
    with pytest.raises(ValueError, match="duplicate"):
        _xi(SPEC_SUBSETS, features=(*FEATURES, "floor"))


def test_a_feature_map_without_features_is_refused():
    """With no feature, every learner's posterior over the probabilities had no dimension
    (`mirl run` stopped on a ZeroDivisionError)."""
    with pytest.raises(ValueError, match="no transition features"):
        FeatureMap.from_dict({"features": [], "actions": {a: [] for a in SPEC_SUBSETS}})


# --------------------------------------------------------------------------- success probabilities


probs = st.floats(0.0, 1.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(st.tuples(probs, probs, probs, probs, probs))
def test_success_probabilities_are_products_by_hand(ps):
    p = dict(zip((*FEATURES, "carpet"), ps, strict=True))
    gm = load_map("boyd2")
    d = PatrolDomain(gm, carpet_map_direct())
    got = d.success_probabilities(p)
    assert got.shape == (d.n_states, 4)
    for s in range(d.n_states):
        cell = tuple(map(int, d.states[s, :2]))
        for a, name in enumerate(ACTIONS):
            subset = SPEC_XI[name] | ({"carpet"} if cell in CARPET_CELLS else set())
            assert got[s, a] == pytest.approx(math.prod(p[f] for f in subset), abs=1e-12)


def test_success_probabilities_spec_values(boyd2):
    p = {"left_wheel": 0.7, "right_wheel": 0.95, "navigation": 0.97, "floor": 0.99}
    got = boyd2.success_probabilities(p)
    assert np.allclose(got[:, 0], 0.7 * 0.95 * 0.97 * 0.99)
    assert np.allclose(got[:, 1], 0.95 * 0.97 * 0.99)
    assert np.allclose(got[:, 2], 0.7 * 0.97 * 0.99)
    assert np.allclose(got[:, 3], 0.99)


def test_success_probabilities_errors(boyd2):
    good = dict.fromkeys(FEATURES, 0.9)
    with pytest.raises(ValueError, match="carpet"):
        boyd2.success_probabilities({**good, "carpet": 0.5})
    with pytest.raises(ValueError, match="floor"):
        boyd2.success_probabilities({k: v for k, v in good.items() if k != "floor"})
    with pytest.raises(ValueError, match="navigation"):
        boyd2.success_probabilities({**good, "navigation": 1.5})


# --------------------------------------------------------------------------- φ


@pytest.fixture(scope="module")
def boyd2_rewarded():
    spec = RewardSpec(
        hallway_features(
            upper=tuple((0, c) for c in range(2, 9)),
            lower=tuple((16, c) for c in range(2, 9)),
            turn_around=((0, 8), (16, 8)),
        )
    )
    return PatrolDomain(load_map("boyd2"), reward_spec=spec)


def test_reward_features_by_hand(boyd2_rewarded):
    d = boyd2_rewarded
    free = hallway_from_text(shipped_map_text("boyd2"))
    phi = d.reward_features
    assert phi.shape == (d.n_states, 4, len(REWARD_FEATURES))
    assert REWARD_FEATURES == ("moved", "upper_hallway", "lower_hallway", "turn_around")
    for s in range(d.n_states):
        state = tuple(map(int, d.states[s]))
        cell = state[:2]
        for a, name in enumerate(ACTIONS):
            nxt = ref_psi(free, state, name)
            moved = name == "forward" and nxt[:2] != cell
            upper = cell[0] == 0 and 2 <= cell[1] <= 8
            lower = cell[0] == 16 and 2 <= cell[1] <= 8
            turn_around = name in ("turn_left", "turn_right") and cell in BOYD2_ENDS
            assert list(phi[s, a]) == [moved, upper, lower, turn_around], (state, name)


def test_reward_features_counts(boyd2_rewarded):
    phi = boyd2_rewarded.reward_features
    # moved: forward moves that change cell = 2 per hallway edge (30 edges on the "[")
    assert phi[:, :, 0].sum() == 60
    assert phi[:, 1:, 0].sum() == 0
    # turn_around: 2 ends × 4 headings × 2 turn actions
    assert phi[:, :, 3].sum() == 16
    assert phi[:, [0, 3], 3].sum() == 0


def test_turn_around_defaults_to_dead_ends():
    d = PatrolDomain(load_map("boyd2"))
    assert set(d.turn_around_cells) == BOYD2_ENDS
    w = np.array([0.0, 0.0, 0.0, 1.0])
    r = d.rewards(w)
    ends = {tuple(map(int, d.states[s, :2])) for s in np.flatnonzero(r.max(axis=1) > 0)}
    assert ends == BOYD2_ENDS
    with pytest.raises(ValueError, match="reward weights"):
        d.rewards([1.0, 2.0])


def test_reward_region_must_be_hallway():
    d = PatrolDomain(load_map("boyd2"), reward_spec=RewardSpec(hallway_features(upper=((1, 3),))))
    with pytest.raises(ValueError, match=r"\(1, 3\)"):
        d.reward_features  # noqa: B018


# --------------------------------------------------------------------------- dead ends, detection


def test_dead_ends_boyd2():
    assert set(dead_ends(load_map("boyd2"))) == BOYD2_ENDS


def test_dead_ends_boydright_by_hand():
    free = hallway_from_text(shipped_map_text("boydright"))
    R, C = len(free), len(free[0])
    expected = set()
    for r in range(R):
        for c in range(C):
            if not free[r][c]:
                continue
            n = sum(
                1
                for dr, dc in DELTA.values()
                if 0 <= r + dr < R and 0 <= c + dc < C and free[r + dr][c + dc]
            )
            if n == 1:
                expected.add((r, c))
    assert set(dead_ends(load_map("boydright"))) == expected


def ref_detection(free, r, c, h, distance):
    out = [(r, c)]
    dr, dc = DELTA[h]
    for k in range(1, distance + 1):
        nr, nc = r + k * dr, c + k * dc
        if not (0 <= nr < len(free) and 0 <= nc < len(free[0]) and free[nr][nc]):
            break
        out.append((nr, nc))
    return out


def test_detection_specific_cases():
    gm = load_map("boyd2")
    assert detection_cells(gm, 0, 1, 0, 6) == [(0, c) for c in range(1, 8)]
    assert detection_cells(gm, 0, 1, 2, 6) == [(0, 1)]  # L's room is never seen
    assert detection_cells(gm, 0, 1, 1, 6) == [(0, 1)]  # off the map
    assert detection_cells(gm, 5, 1, 0, 6) == [(5, 1)]  # wall
    assert detection_cells(gm, 12, 1, 3, 6) == [(r, 1) for r in range(12, 17)]  # edge
    assert detection_cells(gm, 16, 4, 0, 2) == [(16, 4), (16, 5), (16, 6)]
    assert detection_cells(gm, 3, 1, 3, 0) == [(3, 1)]
    assert (0, 0) not in {
        cell
        for r, c, _ in PatrolDomain(gm).states.tolist()
        for h in range(4)
        for cell in detection_cells(gm, r, c, h, 10)
    }


@pytest.mark.parametrize("name", ["boyd2", "boydright"])
@pytest.mark.parametrize("distance", [0, 1, 3, 6, 20])
def test_detection_against_reference(name, distance):
    gm = load_map(name)
    free = hallway_from_text(shipped_map_text(name))
    for r, c, h in ref_states(free):
        got = detection_cells(gm, r, c, h, distance)
        assert got == ref_detection(free, r, c, h, distance)
        # own cell first, then at most `distance` cells straight ahead, all hallway
        assert got[0] == (r, c) and len(got) - 1 <= distance
        for k, (rr, cc) in enumerate(got):
            assert free[rr][cc]
            assert (rr - r, cc - c) == (k * DELTA[h][0], k * DELTA[h][1])


def test_feature_map_without_takes_features_out_of_some_actions():
    fm = DEFAULT_FEATURE_MAP.without(("left_wheel", "right_wheel"), ("turn_left", "turn_right"))
    assert fm.action_subsets["turn_left"] == ("navigation", "floor")
    assert fm.action_subsets["turn_right"] == ("navigation", "floor")
    assert fm.action_subsets["forward"] == DEFAULT_FEATURE_MAP.action_subsets["forward"]
    assert fm.features == DEFAULT_FEATURE_MAP.features
    with pytest.raises(ValueError, match="unknown transition feature 'wheel'"):
        DEFAULT_FEATURE_MAP.without(("wheel",), ("forward",))


def test_a_written_override_is_asked_whether_it_changes_a_subset_after_those_before_it():
    """Adding back on one cell what an earlier override removed everywhere changes ξ there;
    adding what the actions have already, or removing on a cell what an earlier override took
    away there, changes nothing and is refused. A reduced map (``without``) is not asked."""

    def table(*overrides):
        return {"features": list(FEATURES), "actions": SPEC_SUBSETS, "override": list(overrides)}

    drop = {"actions": ["stop"], "remove": ["floor"]}
    back = {"cells": [[5, 1]], "actions": ["stop"], "add": ["floor"]}
    FeatureMap.from_dict(table(drop, back))  # stop on (5, 1) has the floor again
    with pytest.raises(ValueError, match="override 2 changes no action's features"):
        FeatureMap.from_dict(table(drop, {**back, "add": [], "remove": ["floor"]}))
    with pytest.raises(ValueError, match="override 1 changes no action's features"):
        FeatureMap.from_dict(table({"actions": ["forward"], "add": ["floor"]}))
    turns_only = {**SPEC_SUBSETS, "forward": ["navigation", "floor"]}  # the wheels turn only
    fm = FeatureMap.from_dict({"features": list(FEATURES), "actions": turns_only})
    fm.without(["left_wheel", "right_wheel"], ["turn_left", "turn_right"])  # no wheel left: kept
