"""The team filters' parts: the sparse meeting masks and game steps against their rules, the
exact joint's marginals and sightings against sums over the tensor, the factored step against
the plain sparse products, and the factored detection against its formula written densely."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.results import oracle_models
from mirl.mdp import policy_matrix
from mirl.planning.observer import observer_model
from mirl.planning.team_filter import (
    ExactTeam,
    FactoredDetection,
    FactoredTeam,
    TeamParts,
    factored_detection,
    game_step_matrix,
    meeting_matrix,
)
from mirl.world.domain import STOP, TURN_LEFT
from mirl.world.game import meeting
from mirl.world.scenario import load_scenario

RING = """\
L......
#.###.#
#.#g#.#
#.....#
"""

RING_SCENARIO = """\
name = "ring3"
map = "ring.txt"
observability = 0.3
[reward]
features = [{ name = "moved", kind = "moved" }, { name = "ends", kind = "turn_around" }]
weights = { moved = 1.0, ends = 0.3 }
[[robots]]
start = [0, 1, 0]
[[robots]]
start = [3, 5, 2]
[[robots]]
start = [0, 6, 2]
"""


@pytest.fixture(scope="module")
def br3():
    return load_scenario("boydright-3")


@pytest.fixture(scope="module")
def ring3(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ring")
    (folder / "ring.txt").write_text(RING)
    (folder / "ring3.toml").write_text(RING_SCENARIO)
    return load_scenario(folder / "ring3.toml")


def _random_beliefs(shape, seed):
    b = np.random.default_rng(seed).random(shape) ** 3
    return b / b.sum(axis=-1, keepdims=True)


def test_meeting_matrix_is_the_meeting_rule(br3):
    d = br3.domain
    S = d.n_states
    pol = [br3.true_policy(i) for i in range(3)]
    si, sj = np.divmod(np.arange(S * S), S)
    for i, j in ((0, 1), (0, 2), (2, 1)):
        dense = meeting(d, si, sj, pol[i][si], pol[j][sj]).reshape(S, S)
        sparse = meeting_matrix(d, pol[i], pol[j]).toarray() > 0
        np.testing.assert_array_equal(sparse, dense)
        assert dense.any()


@pytest.mark.parametrize("side", [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1 / 6, 5 / 6, 0.0), (0, 0, 1)])
def test_a_game_step_moves_by_the_sides_mixture_of_own_stop_and_turn(br3, side):
    d, T, pol = br3.domain, br3.true_transitions(0), br3.true_policy(0)
    w = np.zeros((d.n_states, d.n_actions))
    w[np.arange(d.n_states), pol] += side[0]
    w[:, STOP] += side[1]
    w[:, TURN_LEFT] += side[2]
    expected = policy_matrix(T, w).toarray()
    got = game_step_matrix(d, T, pol, side).toarray()
    np.testing.assert_allclose(got, expected, atol=1e-15)
    np.testing.assert_allclose(got.sum(axis=1), 1.0)


def test_factored_propagation_is_the_plain_sparse_products(br3):
    """The factored step calls scipy's kernels directly: bit for bit the products through `@`
    (the first implementation's loop, kept here)."""
    parts = TeamParts(br3.domain, oracle_models(br3))
    belief = _random_beliefs((parts.n, parts.S), 3)
    expected = np.empty_like(belief)
    for i in range(parts.n):
        free, extra = np.ones(parts.S), []
        for k, other, side in parts.robot_pairs(i):
            m = parts.meet[k] if side == 0 else parts.meet[k].T
            w = free * np.clip(m @ belief[other], 0.0, 1.0)
            free = free - w
            if w.any():
                extra.append(parts.game_T[k][side] @ (belief[i] * w))
        expected[i] = parts.step_T[i] @ (belief[i] * free) + sum(extra, np.zeros(parts.S))
    assert np.array_equal(FactoredTeam(parts).propagate(belief), expected)


def test_every_robot_pairs_with_every_other_once_in_order(br3):
    parts = TeamParts(br3.domain, oracle_models(br3))
    assert parts.pairs == [(0, 1), (0, 2), (1, 2)]
    assert parts.robot_pairs(1) == [(0, 0, 1), (2, 2, 0)]


def test_the_exact_joints_marginals_and_sightings_are_sums_over_the_tensor(ring3):
    team = ExactTeam(TeamParts(ring3.domain, oracle_models(ring3)))
    S = ring3.domain.n_states
    b = np.random.default_rng(1).random((S, S, S))
    b /= b.sum()
    marginals = team.marginals(b)
    np.testing.assert_allclose(marginals[0], b.sum(axis=(1, 2)), rtol=1e-12)
    np.testing.assert_allclose(marginals[1], b.sum(axis=(0, 2)), rtol=1e-12)
    np.testing.assert_allclose(marginals[2], b.sum(axis=(0, 1)), rtol=1e-12)
    G = (np.random.default_rng(2).random((S, 5)) > 0.3).astype(float)
    expected = np.einsum("ijk,ic,jc,kc->c", b, G, G, G)
    np.testing.assert_allclose(team.none_sees(b, G), expected, rtol=1e-12)
    after = team.propagate(b)
    assert after.shape == b.shape and after.sum() == pytest.approx(1.0)


def _dense_detection(occ, D, step_T, pairs):
    """The factored detection and first-order hazards from their definitions, dense."""
    G = 1.0 - D
    seen = np.einsum("kis,sc->kic", occ, D)
    det = 1.0 - np.prod(1.0 - seen, axis=1)
    prev, nxt = pairs.T
    haz = np.empty((len(occ), len(pairs)))
    haz[0] = det[0, nxt]
    for k in range(1, len(occ)):
        survive = np.ones(len(pairs))
        for i, PT in enumerate(step_T):
            PG = PT.T.toarray() @ G  # P(not seeing c one step later | s)
            both = occ[k - 1, i] @ (G[:, prev] * PG[:, nxt])
            before = occ[k - 1, i] @ G[:, prev]
            survive *= np.where(before > 1e-12, both / np.maximum(before, 1e-300),
                                1.0 - seen[k, i, nxt])  # fmt: skip
        haz[k] = 1.0 - survive
    return det, haz


def test_factored_detection_is_its_formula_and_may_go_a_block_at_a_time(br3):
    parts = TeamParts(br3.domain, oracle_models(br3))
    model = observer_model(br3)
    D = model.detection.toarray()
    occ = _random_beliefs((7, parts.n, parts.S), 4)
    det, haz = factored_detection(occ, model.detection, parts.step_T, model.cell_pairs)
    ref_det, ref_haz = _dense_detection(occ, D, parts.step_T, model.cell_pairs)
    np.testing.assert_allclose(det, ref_det, atol=1e-12)
    np.testing.assert_allclose(haz, ref_haz, atol=1e-12)
    rows = FactoredDetection(model.detection, parts.step_T, model.cell_pairs).rows
    later_det, later_haz = rows(occ[3:])  # a block from step 3: its first hazard row is row 0's
    np.testing.assert_allclose(later_det, det[3:], atol=1e-15)
    np.testing.assert_allclose(later_haz[1:], haz[4:], atol=1e-15)


def test_stacked_teams_step_each_team_bit_for_bit(br3):
    """Teams of different models stepped as one block-diagonal product: each team's marginals
    exactly its own FactoredTeam's."""
    from dataclasses import replace

    from mirl.planning.team_filter import StackedFactoredTeams
    from mirl.world.motion import transition_matrix

    truth = oracle_models(br3)
    models = [truth]
    for floor in (0.5, 0.8):
        robots = []
        for r in truth.robots:
            probs = {**r.feature_probabilities, "floor": floor}
            T = transition_matrix(br3.domain, probs, br3.error_model)
            robots.append(replace(r, transitions=T, feature_probabilities=probs))
        models.append(replace(truth, robots=tuple(robots)))
    teams = [FactoredTeam(TeamParts(br3.domain, m)) for m in models]
    belief = np.stack([_random_beliefs((3, br3.domain.n_states), k) for k in range(3)])
    belief[1, 2, : br3.domain.n_states // 2] = 0.0  # zeros, as after negative evidence
    stacked = StackedFactoredTeams(teams).propagate(belief)
    for k, team in enumerate(teams):
        assert np.array_equal(stacked[k], team.propagate(belief[k]))
    assert not np.array_equal(stacked[0], stacked[1])  # the models differ
