"""The patrollers' interaction game: a bimatrix game over {go, stop, turn} played when two
patrollers meet head-on, its Nash equilibria (by nashpy; the paper's game's are stored), and the
meeting rule."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from mirl.world.domain import STOP, TURN_LEFT, PatrolDomain

__all__ = [
    "GAME_ACTIONS",
    "KEEP_RIGHT_BEARING",
    "Equilibrium",
    "InteractionGame",
    "meeting",
    "game_action_to_action",
    "meeting_actions",
]

GAME_ACTIONS: tuple[str, ...] = ("go", "stop", "turn")

KEEP_RIGHT_BEARING = 110.0
"""Degrees either side of a robot's heading within which another robot coming the other way
is being passed: ahead of it or alongside, until they have passed. Physical robots passing so
keep right (:func:`mirl.physics.control.in_company`), so their steps then are no evidence of a
wheel's drift (:func:`mirl.learning.verdicts.in_company`)."""


@dataclass(frozen=True)
class Equilibrium:
    """A (possibly mixed) Nash equilibrium: probabilities over :data:`GAME_ACTIONS`.

    Parameters
    ----------
    row : tuple of float
        The first (row) patroller's probabilities of go, stop and turn.
    col : tuple of float
        The second (column) patroller's.
    """

    row: tuple[float, ...]
    col: tuple[float, ...]

    @property
    def is_pure(self) -> bool:
        """Whether both players play one action with probability 1."""
        return max(self.row) > 1 - 1e-9 and max(self.col) > 1 - 1e-9

    def label(self) -> str:
        """A short label, e.g. ``go/stop`` or ``(go:0.17, stop:0.83)/(go:0.17, stop:0.83)``.

        Returns
        -------
        str
            The row player's action (or mixture), a slash, the column player's.
        """
        def one(p):
            if max(p) > 1 - 1e-9:
                return GAME_ACTIONS[int(np.argmax(p))]
            parts = [f"{a}:{x:.2f}" for a, x in zip(GAME_ACTIONS, p, strict=True) if x > 1e-9]
            return "(" + ", ".join(parts) + ")"

        return f"{one(self.row)}/{one(self.col)}"


# The paper's game (docs/design.md, "The interaction game"; every shipped scenario plays it).
_PAPER_ROW = ((-10.0, 2.0, 2.0), (0.0, 0.0, 0.0), (-1.0, -1.0, -1.0))
_PAPER_COL = ((-10.0, 0.0, -1.0), (2.0, 0.0, -1.0), (2.0, 0.0, -1.0))

# Its equilibria as :func:`_nash_equilibria` enumerates them with nashpy (the same values and
# order; tests/world/test_game.py re-enumerates and compares exactly), so learning on it never
# imports nashpy, networkx and scipy.integrate (~0.2 s of a ~1.5 s `mirl run`). Other games
# enumerate.
_STORED_EQUILIBRIA: dict[tuple[bytes, bytes], tuple[tuple[float, ...], ...]] = {
    (np.array(_PAPER_ROW).tobytes(), np.array(_PAPER_COL).tobytes()): (
        (1.0, 0.0, 0.0, 0.0, 1.0, 0.0),  # go/stop: row strategy, then column strategy
        (0.0, 1.0, 0.0, 1.0, 0.0, 0.0),  # stop/go
        (0.166666666667, 0.833333333333, 0.0, 0.166666666667, 0.833333333333, 0.0),  # mixed
    )
}


@lru_cache(maxsize=8)
def _stored_equilibria(row_bytes: bytes, col_bytes: bytes) -> tuple[Equilibrium, ...] | None:
    stored = _STORED_EQUILIBRIA.get((row_bytes, col_bytes))
    if stored is None:
        return None
    # numpy floats, as the enumeration returns them
    return tuple(
        Equilibrium(tuple(map(np.float64, p[:3])), tuple(map(np.float64, p[3:]))) for p in stored
    )


@lru_cache(maxsize=64)
def _nash_equilibria(row_bytes: bytes, col_bytes: bytes, shape: tuple[int, int]):
    import warnings

    import nashpy

    A = np.frombuffer(row_bytes).reshape(shape)
    B = np.frombuffer(col_bytes).reshape(shape)
    # Shift both matrices to be strictly positive (equilibria are unchanged). nashpy only shifts
    # when the minimum is negative, to a minimum of 0, which leaves the best-response polytope
    # unbounded when a whole column of A (row of B) is that minimum, e.g. an all-zero game, and
    # its linprog then fails with a TypeError.
    A = A - A.min() + 1.0
    B = B - B.min() + 1.0
    with warnings.catch_warnings():
        # nashpy warns on degenerate games; vertex enumeration still lists the extreme equilibria
        warnings.simplefilter("ignore")
        found = list(nashpy.Game(A, B).vertex_enumeration())
    uniq: list[Equilibrium] = []
    for sr, sc in found:
        e = Equilibrium(tuple(np.round(sr, 12) + 0.0), tuple(np.round(sc, 12) + 0.0))
        if not any(np.allclose(e.row, u.row) and np.allclose(e.col, u.col) for u in uniq):
            uniq.append(e)
    # pure equilibria first, then mixed; deterministic order
    uniq.sort(key=lambda e: (not e.is_pure, tuple(-x for x in e.row), tuple(-x for x in e.col)))
    return tuple(uniq)


@dataclass(frozen=True)
class InteractionGame:
    """2-player game at a head-on meeting; rows are the first patroller's actions.

    Parameters
    ----------
    row_payoffs : ndarray of shape (3, 3), default the paper's
        The first patroller's payoffs over :data:`GAME_ACTIONS` × :data:`GAME_ACTIONS`.
    col_payoffs : ndarray of shape (3, 3), default the paper's
        The second patroller's payoffs, indexed the same way.

    Raises
    ------
    ValueError
        A payoff matrix that is not a finite 3×3 matrix.
    """

    row_payoffs: np.ndarray = field(default_factory=lambda: np.array(_PAPER_ROW, dtype=float))
    col_payoffs: np.ndarray = field(default_factory=lambda: np.array(_PAPER_COL, dtype=float))

    def __post_init__(self) -> None:
        for name in ("row_payoffs", "col_payoffs"):
            m = np.asarray(getattr(self, name), dtype=float)
            if m.shape != (3, 3) or not np.all(np.isfinite(m)):
                raise ValueError(f"{name} must be a finite 3×3 matrix over {GAME_ACTIONS}")
            object.__setattr__(self, name, m)

    def equilibria(self) -> tuple[Equilibrium, ...]:
        """All Nash equilibria (extreme points) by nashpy's vertex enumeration, cached.

        The paper's game's are stored (no nashpy import).

        Returns
        -------
        tuple of Equilibrium
            Pure equilibria first, then mixed, in a deterministic order.
        """
        A = np.ascontiguousarray(self.row_payoffs, dtype=float)
        B = np.ascontiguousarray(self.col_payoffs, dtype=float)
        stored = _stored_equilibria(A.tobytes(), B.tobytes())
        return stored if stored is not None else _nash_equilibria(A.tobytes(), B.tobytes(), A.shape)

    def pure(self, row_action: str, col_action: str) -> Equilibrium:
        """The pure profile (row_action, col_action), which must be an equilibrium.

        Checked by best responses (no player gains by deviating alone), without enumerating the
        game's equilibria, so loading a scenario never imports nashpy.

        Parameters
        ----------
        row_action : str
            The first patroller's action, one of :data:`GAME_ACTIONS`.
        col_action : str
            The second patroller's.

        Returns
        -------
        Equilibrium
            The profile as probabilities.

        Raises
        ------
        ValueError
            An unknown action, or a profile that is not a Nash equilibrium.
        """
        for a in (row_action, col_action):
            if a not in GAME_ACTIONS:
                raise ValueError(f"unknown game action '{a}' (known: {', '.join(GAME_ACTIONS)})")
        i, j = GAME_ACTIONS.index(row_action), GAME_ACTIONS.index(col_action)
        A, B = self.row_payoffs, self.col_payoffs
        if A[i, j] < A[:, j].max() or B[i, j] < B[i, :].max():
            raise ValueError(f"({row_action}, {col_action}) is not a Nash equilibrium of the game")
        n = len(GAME_ACTIONS)
        return Equilibrium(
            tuple(float(k == i) for k in range(n)), tuple(float(k == j) for k in range(n))
        )


def game_action_to_action(game_action: ArrayLike, own_action: ArrayLike) -> np.ndarray:
    """The domain action a game action takes.

    go → the robot's own policy action; stop → stop; turn → turn_left (the first half of turning
    back, which costs the yielding robot its direction).

    Parameters
    ----------
    game_action : array_like of int
        Indices into :data:`GAME_ACTIONS`.
    own_action : array_like of int
        The action the robot's policy would take, broadcast with ``game_action``.

    Returns
    -------
    ndarray of int
        Domain actions (:data:`~mirl.world.actions.ACTIONS` indices).
    """
    return np.choose(np.asarray(game_action), [own_action, STOP, TURN_LEFT])


def meeting_actions(own: np.ndarray, pairs, draw) -> np.ndarray:
    """Each robot's action in one step, given the pairs that meet (docs/design.md, "The meeting
    rule"): a robot in several meetings plays the game of its first pair in ``pairs``' order;
    every pair still draws both its game actions, so a random stream does not depend on the
    overlap. The grid simulator and the physical world both decide by it.

    Parameters
    ----------
    own : ndarray of int, shape (N,)
        Each robot's policy action.
    pairs : sequence of (int, int)
        The meeting pairs (row robot, column robot), in robot order.
    draw : callable
        ``draw(k)`` → the k-th pair's (row, column) game actions, indices into
        :data:`GAME_ACTIONS`; called once per pair, in order.

    Returns
    -------
    ndarray of int, shape (N,)
        The actions: the policy's, or the first meeting's game move.
    """
    acts = np.array(own, copy=True)
    engaged = np.zeros(len(acts), dtype=bool)
    for k, (i, j) in enumerate(pairs):
        for robot, game_action in zip((i, j), draw(k), strict=True):
            if not engaged[robot]:
                acts[robot] = game_action_to_action(game_action, int(own[robot]))
                engaged[robot] = True
    return acts


def meeting(domain: PatrolDomain, s_row, s_col, a_row, a_col) -> np.ndarray:
    """Vectorised meeting rule (docs/design.md, "The meeting rule").

    The two robots' intended moves would put them in the same cell (at least one of them entering
    it) or make them swap cells.

    Parameters
    ----------
    domain : PatrolDomain
        The domain whose intended outcomes ψ the rule reads.
    s_row : int or ndarray of int
        The first robot's states.
    s_col : int or ndarray of int
        The second robot's states, broadcast with ``s_row``.
    a_row : int or ndarray of int
        The first robot's actions.
    a_col : int or ndarray of int
        The second robot's actions.

    Returns
    -------
    ndarray of bool
        Whether they meet, of the broadcast shape.
    """
    psi = domain.intended
    cell_r, cell_c = domain.state_cell(s_row), domain.state_cell(s_col)
    next_r = domain.state_cell(psi[s_row, a_row])
    next_c = domain.state_cell(psi[s_col, a_col])
    same = (next_r == next_c) & ((next_r != cell_r) | (next_c != cell_c))
    swap = (next_r == cell_c) & (next_c == cell_r) & (cell_r != cell_c)
    return same | swap
