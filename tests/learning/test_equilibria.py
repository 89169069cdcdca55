"""Weighing the interaction game's equilibria: the exact joint filter's likelihood against a
dense hidden-Markov model over the pair's joint state written out from the module's equations,
the weighing recovering the equilibrium a simulation played, and the meeting tests against the
meeting rule applied pair by pair."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from mirl.learning.equilibria import (
    EquilibriumWeights,
    joint_log_likelihood,
    meeting_log_likelihood,
    meeting_matrix,
    potential_meetings,
    weigh_equilibria,
)
from mirl.simulation.grid import simulate
from mirl.world.domain import STOP, TURN_LEFT
from mirl.world.game import Equilibrium, meeting
from mirl.world.scenario import load_scenario

RING = """\
L......
#.###.#
#.#g#.#
#.....#
"""

RING_SCENARIO = """\
name = "ring2"
map = "ring.txt"
observability = 0.4
[reward]
features = [{ name = "moved", kind = "moved" }, { name = "ends", kind = "turn_around" }]
weights = { moved = 1.0, ends = 0.3 }
[[robots]]
start = [0, 1, 0]
[[robots]]
start = [3, 5, 2]
"""


@pytest.fixture(scope="module")
def ring(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ring")
    (folder / "ring.txt").write_text(RING)
    (folder / "ring2.toml").write_text(RING_SCENARIO)
    return load_scenario(folder / "ring2.toml")


def dense_log_likelihood(domain, series, policies, transitions, eq, visible, epsilon=1e-3):
    """log P(both series) by the forward algorithm over the joint state (s_I, s_J), its step
    b' = (P_I ⊗ P_J)ᵀ((1 − m)∘b) + (G_I ⊗ G_J)ᵀ(m∘b) built from the definitions."""
    S, A = domain.n_states, domain.n_actions
    steps, games = [], []
    for pol, T, side in zip(policies, transitions, (eq.row, eq.col), strict=True):
        own = np.zeros((S, A))
        own[np.arange(S), pol] = 1.0
        game = side[0] * own
        game[:, STOP] += side[1]
        game[:, TURN_LEFT] += side[2]
        T3 = T.toarray().reshape(S, A, S)
        for choice, out in ((own, steps), (game, games)):
            w = (1 - epsilon) * choice + epsilon / A
            out.append(np.einsum("sa,sat->st", w, T3))
    si, sj = np.divmod(np.arange(S * S), S)
    m = meeting(domain, si, sj, policies[0][si], policies[1][sj]).astype(float)
    P = sp.kron(sp.csr_array(steps[0]), sp.csr_array(steps[1]), format="csr").T
    G = sp.kron(sp.csr_array(games[0]), sp.csr_array(games[1]), format="csr").T
    vis = visible.copy()
    x, y = series
    vis[x[x >= 0]] = True
    vis[y[y >= 0]] = True
    b = np.full(S * S, 1.0 / (S * S))
    total = 0.0
    for t in range(len(x)):
        if t > 0:
            b = P @ ((1 - m) * b) + G @ (m * b)
        keep_i = (si == x[t]) if x[t] >= 0 else ~vis[si]
        keep_j = (sj == y[t]) if y[t] >= 0 else ~vis[sj]
        b = b * (keep_i & keep_j)
        total += np.log(b.sum())
        b /= b.sum()
    return total


def _record(sc, steps, seed, observability=None):
    res = simulate(sc, steps, seed=seed, observability=observability, random_starts=True)
    series = [res.observations.state_series(sc.domain, i) for i in range(2)]
    return res, series


def test_the_joint_filter_is_the_forward_algorithm_over_the_joint_state(ring):
    res, series = _record(ring, 80, seed=1)
    assert res.interactions > 0  # meetings to weigh
    pol = [ring.true_policy(i) for i in range(2)]
    T = [ring.true_transitions(i) for i in range(2)]
    vis = ring.domain.visible_states(ring.observability)
    for eq in ring.game.equilibria():
        got = joint_log_likelihood(ring.domain, series, pol, T, eq, vis)
        assert got == pytest.approx(dense_log_likelihood(ring.domain, series, pol, T, eq, vis))


def test_the_weighing_finds_the_equilibrium_the_robots_played():
    """boyd2's patrollers play stop/go; watched over the whole hallway for 600 steps, the
    weighing puts nearly all weight on it and little on go/stop or the mixed one."""
    sc = load_scenario("boyd2")
    res, series = _record(sc, 600, seed=4, observability=1.0)
    pol = [sc.true_policy(i) for i in range(2)]
    T = [sc.true_transitions(i) for i in range(2)]
    vis = sc.domain.visible_states(1.0)
    weights = weigh_equilibria(sc.domain, series, pol, T, sc.game.equilibria(), vis)
    assert weights.n_meetings > 0
    assert weights.equilibrium.label() == "stop/go"
    assert weights.weights.sum() == pytest.approx(1.0)
    assert weights.weights[weights.best] > 0.99


def test_evident_meetings_only_count_steps_where_both_were_seen_to_meet(ring):
    res, series = _record(ring, 120, seed=2, observability=1.0)
    pol = [ring.true_policy(i) for i in range(2)]
    T = [ring.true_transitions(i) for i in range(2)]
    eq = ring.played_equilibrium
    ll, n = meeting_log_likelihood(ring.domain, series, pol, T, eq)
    x, y = series
    both = np.flatnonzero((x[:-1] >= 0) & (y[:-1] >= 0) & (x[1:] >= 0) & (y[1:] >= 0))
    expected = sum(bool(meeting(ring.domain, x[t], y[t], pol[0][x[t]], pol[1][y[t]])) for t in both)
    assert n == expected > 0 and ll < 0
    unseen = [np.full_like(x, -1), y]
    assert meeting_log_likelihood(ring.domain, unseen, pol, T, eq) == (0.0, 0)


def test_potential_meetings_are_the_steps_some_pair_of_actions_would_meet(ring):
    _, (x, y) = _record(ring, 150, seed=3, observability=1.0)
    A = ring.domain.n_actions
    expected = [
        x[t] >= 0
        and y[t] >= 0
        and any(meeting(ring.domain, x[t], y[t], a, b) for a in range(A) for b in range(A))
        for t in range(len(x))
    ]
    assert potential_meetings(ring.domain, x, y).tolist() == expected
    assert any(expected)


def test_the_sparse_meeting_matrix_is_the_rule_over_every_pair(ring):
    d = ring.domain
    S = d.n_states
    pol = [ring.true_policy(i) for i in range(2)]
    si, sj = np.divmod(np.arange(S * S), S)
    dense = meeting(d, si, sj, pol[0][si], pol[1][sj]).reshape(S, S)
    np.testing.assert_array_equal(meeting_matrix(d, pol[0], pol[1]).toarray() > 0, dense)


def test_weights_are_a_posterior_and_ties_go_to_the_earlier_candidate():
    cands = (Equilibrium((1, 0, 0), (0, 1, 0)), Equilibrium((0, 1, 0), (1, 0, 0)))
    ll = np.array([-3.0, -3.0])
    w = EquilibriumWeights.from_log_likelihoods(cands, ll, np.zeros(2), 0)
    assert w.best == 0 and w.equilibrium is cands[0]
    np.testing.assert_allclose(w.weights, [0.5, 0.5])
    w = EquilibriumWeights.from_log_likelihoods(cands, np.array([-5.0, -3.0]), np.zeros(2), 0)
    assert w.best == 1
    np.testing.assert_allclose(w.weights, np.exp([-2.0, 0.0]) / np.exp([-2.0, 0.0]).sum())
