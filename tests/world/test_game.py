"""The interaction game: equilibria checked by brute force, the played profile, caching, and the
meeting rule (same cell / swap)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.world.catalog import load_map
from mirl.world.domain import ACTIONS, PatrolDomain
from mirl.world.game import (
    GAME_ACTIONS,
    Equilibrium,
    InteractionGame,
    _nash_equilibria,
    _stored_equilibria,
    game_action_to_action,
    meeting,
    meeting_actions,
)
from mirl.world.scenario import load_scenario, shipped_scenarios

# The paper's payoffs, typed from its prose: (I's action, J's action) -> (I's payoff, J's payoff)
SPEC_PAYOFFS = {
    ("go", "go"): (-10, -10),
    ("go", "stop"): (2, 0),
    ("go", "turn"): (2, -1),
    ("stop", "go"): (0, 2),
    ("stop", "stop"): (0, 0),
    ("stop", "turn"): (0, -1),
    ("turn", "go"): (-1, 2),
    ("turn", "stop"): (-1, 0),
    ("turn", "turn"): (-1, -1),
}
TOL = 1e-9


def spec_matrices():
    A = np.zeros((3, 3))
    B = np.zeros((3, 3))
    for (i, j), (a, b) in SPEC_PAYOFFS.items():
        A[GAME_ACTIONS.index(i), GAME_ACTIONS.index(j)] = a
        B[GAME_ACTIONS.index(i), GAME_ACTIONS.index(j)] = b
    return A, B


def is_nash(A, B, x, y, tol=1e-7) -> bool:
    """No profitable unilateral deviation to any pure action."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if not (np.all(x >= -tol) and np.all(y >= -tol)):
        return False
    if abs(x.sum() - 1) > tol or abs(y.sum() - 1) > tol:
        return False
    u_row, u_col = x @ A @ y, x @ B @ y
    return bool(np.all(A @ y <= u_row + tol) and np.all(x @ B <= u_col + tol))


def brute_force_pure_nash(A, B) -> set[tuple[str, str]]:
    out = set()
    for i, j in itertools.product(range(3), range(3)):
        if A[i, j] >= A[:, j].max() and B[i, j] >= B[i, :].max():
            out.add((GAME_ACTIONS[i], GAME_ACTIONS[j]))
    return out


def pure_label(e: Equilibrium) -> tuple[str, str]:
    return GAME_ACTIONS[int(np.argmax(e.row))], GAME_ACTIONS[int(np.argmax(e.col))]


def test_default_payoffs_are_spec():
    A, B = spec_matrices()
    g = InteractionGame()
    np.testing.assert_array_equal(g.row_payoffs, A)
    np.testing.assert_array_equal(g.col_payoffs, B)


def test_default_equilibria_by_brute_force():
    A, B = spec_matrices()
    eqs = InteractionGame().equilibria()
    assert len(eqs) >= 1
    for e in eqs:
        assert is_nash(A, B, e.row, e.col), e
    pure = {pure_label(e) for e in eqs if e.is_pure}
    assert pure == brute_force_pure_nash(A, B) == {("go", "stop"), ("stop", "go")}
    # no duplicates
    for e, f in itertools.combinations(eqs, 2):
        assert not (np.allclose(e.row, f.row) and np.allclose(e.col, f.col))
    # the symmetric mixed equilibrium of the go/stop chicken game: each goes with p = 1/6
    mixed = [e for e in eqs if not e.is_pure]
    assert len(mixed) == 1
    np.testing.assert_allclose(mixed[0].row, [1 / 6, 5 / 6, 0], atol=1e-9)
    np.testing.assert_allclose(mixed[0].col, [1 / 6, 5 / 6, 0], atol=1e-9)
    # pure ones come first
    assert [e.is_pure for e in eqs] == sorted((e.is_pure for e in eqs), reverse=True)


@pytest.mark.parametrize("name", shipped_scenarios())
def test_stored_equilibria_are_a_fresh_enumeration(name):
    """Every shipped scenario's game has its equilibria stored (no nashpy import in a run);
    they are exactly what nashpy enumerates now: values, numpy types and order."""
    game = load_scenario(name).game
    A, B = game.row_payoffs, game.col_payoffs
    stored = _stored_equilibria(A.tobytes(), B.tobytes())
    assert stored is not None
    fresh = _nash_equilibria.__wrapped__(A.tobytes(), B.tobytes(), A.shape)  # no cache
    assert len(stored) == len(fresh) == 3
    for s, f in zip(stored, fresh, strict=True):
        assert s.row == f.row and s.col == f.col
        assert [type(x) for x in s.row + s.col] == [type(x) for x in f.row + f.col]
    assert game.equilibria() == stored


def test_other_games_are_enumerated():
    A = np.array([[3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    assert _stored_equilibria(A.tobytes(), A.tobytes()) is None
    pure = {pure_label(e) for e in InteractionGame(A, A).equilibria() if e.is_pure}
    assert pure == {("go", "go"), ("stop", "stop"), ("turn", "turn")}


payoff = st.integers(-3, 3)  # small range: many ties and degenerate games


@settings(max_examples=40, deadline=None)
@given(st.lists(payoff, min_size=9, max_size=9), st.lists(payoff, min_size=9, max_size=9))
def test_random_games_equilibria_are_nash(a, b):
    A = np.array(a, float).reshape(3, 3)
    B = np.array(b, float).reshape(3, 3)
    eqs = InteractionGame(A, B).equilibria()
    for e in eqs:
        assert is_nash(A, B, e.row, e.col), e
    # every brute-force pure NE is found (vertex enumeration lists every extreme point; in
    # degenerate games a pure NE is still an extreme point of the equilibrium set)
    found = {pure_label(e) for e in eqs if e.is_pure}
    assert brute_force_pure_nash(A, B) <= found


@pytest.mark.parametrize(
    "A, B",
    [
        (np.zeros((3, 3)), np.zeros((3, 3))),  # every profile is an equilibrium
        # J's "turn" column is I's global minimum everywhere
        ([[1, 2, 0], [2, 1, 0], [0, 0, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]),
        ([[-3, 1, -3], [1, -3, -3], [0, 0, -3]], [[1, 0, 0], [0, 1, 0], [2, 2, 2]]),
    ],
)
def test_degenerate_games(A, B):
    """Payoffs with a column (row) at the global minimum once crashed nashpy's linprog."""
    A, B = np.asarray(A, float), np.asarray(B, float)
    eqs = InteractionGame(A, B).equilibria()
    for e in eqs:
        assert is_nash(A, B, e.row, e.col), e
    assert brute_force_pure_nash(A, B) <= {pure_label(e) for e in eqs if e.is_pure}


def test_played_profile_resolves():
    g = InteractionGame()
    e = g.pure("stop", "go")
    assert e.is_pure
    assert e.row == (0.0, 1.0, 0.0) and e.col == (1.0, 0.0, 0.0)
    assert e.label() == "stop/go"
    assert g.pure("go", "stop").label() == "go/stop"
    assert load_scenario("boyd2").played_equilibrium == e


@pytest.mark.parametrize(
    "profile",
    [
        p
        for p in itertools.product(GAME_ACTIONS, GAME_ACTIONS)
        if p not in {("stop", "go"), ("go", "stop")}
    ],
)
def test_non_equilibrium_pure_profile_raises(profile):
    with pytest.raises(ValueError, match="not a Nash equilibrium"):
        InteractionGame().pure(*profile)


def test_unknown_game_action():
    with pytest.raises(ValueError, match="yield"):
        InteractionGame().pure("yield", "go")


def test_bad_payoff_matrix():
    with pytest.raises(ValueError, match="row_payoffs"):
        InteractionGame(row_payoffs=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="col_payoffs"):
        InteractionGame(col_payoffs=np.full((3, 3), np.nan))


def test_equilibria_are_cached():
    g = InteractionGame()
    first = g.equilibria()
    assert g.equilibria() is first
    # keyed by the payoffs, not by the object
    assert InteractionGame().equilibria() is first
    A, B = spec_matrices()
    B[0, 0] = -11
    assert InteractionGame(A, B).equilibria() is not first


def test_mixed_label():
    mixed = next(e for e in InteractionGame().equilibria() if not e.is_pure)
    assert mixed.label() == "(go:0.17, stop:0.83)/(go:0.17, stop:0.83)"


def test_game_action_to_action():
    own = np.array([0, 2, 3])
    assert list(game_action_to_action(np.array([0, 0, 0]), own)) == [0, 2, 3]  # go: own action
    assert list(game_action_to_action(np.array([1, 1, 1]), own)) == [3, 3, 3]  # stop
    assert list(game_action_to_action(np.array([2, 2, 2]), own)) == [1, 1, 1]  # turn_left


# --------------------------------------------------------------------------- meeting rule


@pytest.fixture(scope="module")
def boyd2():
    return PatrolDomain(load_map("boyd2"))


FWD, STOP = ACTIONS.index("forward"), ACTIONS.index("stop")
LEFT = ACTIONS.index("turn_left")
SOUTH, NORTH, EAST = 3, 1, 0


def meets(d, si, sj, ai, aj) -> bool:
    i = int(d.state_index(*si))
    j = int(d.state_index(*sj))
    assert i >= 0 and j >= 0
    return bool(meeting(d, i, j, ai, aj))


@pytest.mark.parametrize(
    "si, sj, ai, aj, expected",
    [
        # head-on, adjacent: both forward would swap cells
        ((5, 1, SOUTH), (6, 1, NORTH), FWD, FWD, True),
        ((6, 1, NORTH), (5, 1, SOUTH), FWD, FWD, True),
        ((0, 3, EAST), (0, 4, 2), FWD, FWD, True),
        # head-on, one cell apart: both forward would enter the same cell
        ((5, 1, SOUTH), (7, 1, NORTH), FWD, FWD, True),
        ((16, 3, EAST), (16, 5, 2), FWD, FWD, True),
        # one moves into the other's (stopped) cell
        ((5, 1, SOUTH), (6, 1, NORTH), FWD, STOP, True),
        # same direction, following: no meeting
        ((5, 1, SOUTH), (6, 1, SOUTH), FWD, FWD, False),
        ((6, 1, SOUTH), (5, 1, SOUTH), FWD, FWD, False),
        # both stopping, adjacent or sharing a cell: no meeting
        ((5, 1, SOUTH), (6, 1, NORTH), STOP, STOP, False),
        ((5, 1, SOUTH), (5, 1, NORTH), STOP, STOP, False),
        # turning in place next to each other: no meeting
        ((5, 1, SOUTH), (6, 1, NORTH), LEFT, LEFT, False),
        # far apart, head-on
        ((2, 1, SOUTH), (9, 1, NORTH), FWD, FWD, False),
        # sharing a cell, passing each other (they separate)
        ((5, 1, SOUTH), (5, 1, NORTH), FWD, FWD, False),
    ],
)
def test_meeting_cases(boyd2, si, sj, ai, aj, expected):
    assert meets(boyd2, si, sj, ai, aj) is expected
    assert meets(boyd2, sj, si, aj, ai) is expected  # symmetric


def test_meeting_is_vectorised(boyd2):
    d = boyd2
    si = d.state_index(np.array([5, 5]), np.array([1, 1]), np.array([SOUTH, SOUTH]))
    sj = d.state_index(np.array([6, 6]), np.array([1, 1]), np.array([NORTH, SOUTH]))
    out = meeting(d, si, sj, np.array([FWD, FWD]), np.array([FWD, FWD]))
    assert out.tolist() == [True, False]


def test_meeting_against_brute_force(boyd2):
    """Over all pairs of states in the long hallway and all action pairs."""
    d = boyd2
    states = [s for s in range(d.n_states) if d.states[s, 1] == 1 and 3 <= d.states[s, 0] <= 7]
    for i, j in itertools.product(states, states):
        ci, cj = tuple(d.states[i, :2]), tuple(d.states[j, :2])
        for ai, aj in itertools.product(range(4), range(4)):
            ni, nj = tuple(d.states[d.intended[i, ai], :2]), tuple(d.states[d.intended[j, aj], :2])
            same = ni == nj and (ni != ci or nj != cj)
            swap = ni == cj and nj == ci and ci != cj
            assert bool(meeting(d, i, j, ai, aj)) == (same or swap)


def test_a_robot_in_several_meetings_plays_its_first_pair_s_game():
    """Every pair draws both its moves, in order; each robot keeps its first meeting's move."""
    own = np.array([FWD] * 4)
    drawn = []
    moves = {0: (1, 0), 1: (0, 2), 2: (2, 1)}  # (stop, go), (go, turn), (turn, stop)

    def draw(k):
        drawn.append(k)
        return moves[k]

    acts = meeting_actions(own, [(0, 1), (1, 2), (0, 2)], draw)
    assert drawn == [0, 1, 2]
    assert acts.tolist() == [STOP, FWD, LEFT, FWD]
