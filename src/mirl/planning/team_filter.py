"""Belief propagation for teams of N ≥ 2 patrollers (used by :class:`~mirl.planning.belief.
BeliefFilter` when the team is not a pair small enough for its S × S joint).

**Meetings.** Robot i meets robot j when their policies' intended moves meet (docs/design.md, "The
meeting rule"); it then plays its side of the pair's equilibrium instead of its policy. A robot that
meets two others in one step plays the game of its first pair in robot order ((0, 1), (0, 2), …, (1,
2), …), as the simulator does (:meth:`mirl.simulation.grid.PatrolSimulator.intended_actions`).

**Exact** (:class:`ExactTeam`): the belief over the joint state, a tensor of S^N entries. Given
the joint state the robots move independently, each with its policy's or its game's one-step
matrix, so the joint step is a sum over the *assignments* (which game, if any, each robot
plays) present in the tensor of the masked belief pushed through one matrix per axis.

**Factored** (:class:`FactoredTeam`): one marginal per robot, with pairwise meeting corrections:
robot i at s meets j with probability q_ij(s) = Σ_s' m_ij(s, s') b_j(s') (independence between
robots), plays pair (i, j)'s game with probability q_ij(s) ∏_{earlier pairs k} (1 − q_ik(s)), and
its policy otherwise. Meeting masks are sparse (robots meet only on neighbouring cells), built
by sparse products of "next cell" and "current cell" incidence matrices.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mirl.learning.results import LearnResult
from mirl.mdp import policy_matrix
from mirl.sparse import csr_block_matvec
from mirl.world.domain import STOP, TURN_LEFT, PatrolDomain

__all__ = [
    "meeting_matrix",
    "game_step_matrix",
    "TeamParts",
    "ExactTeam",
    "FactoredTeam",
    "StackedFactoredTeams",
    "FactoredDetection",
    "factored_detection",
]


def meeting_matrix(domain: PatrolDomain, pol_i: np.ndarray, pol_j: np.ndarray) -> sp.csr_array:
    """Which pairs of states meet under two robots' policies.

    The rule of :func:`mirl.world.game.meeting`, without an S × S dense mask.

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    pol_i : ndarray of int, shape (S,)
        Robot i's policy.
    pol_j : ndarray of int, shape (S,)
        Robot j's policy.

    Returns
    -------
    scipy.sparse.csr_array of shape (S, S)
        1 where robot i in s and robot j in s' meet; 0 elsewhere.
    """
    S = domain.n_states
    cells = np.arange(S) // 4
    nxt_i = domain.state_cell(domain.intended[np.arange(S), pol_i])
    nxt_j = domain.state_cell(domain.intended[np.arange(S), pol_j])
    C = domain.n_cells

    def inc(col: np.ndarray, rows: np.ndarray | None = None) -> sp.csr_array:
        r = np.arange(S) if rows is None else rows
        return sp.csr_array((np.ones(len(r)), (r, col[r])), shape=(S, C))

    same = inc(nxt_i) @ inc(nxt_j).T  # same next cell …
    stay_i, stay_j = np.flatnonzero(nxt_i == cells), np.flatnonzero(nxt_j == cells)
    both_stay = inc(nxt_i, stay_i) @ inc(nxt_j, stay_j).T  # … unless neither moves
    swap = (inc(nxt_i) @ inc(cells).T) * (inc(cells) @ inc(nxt_j).T)
    swap = swap - swap * (inc(cells) @ inc(cells).T)  # swapping needs two different cells
    out = (same - both_stay + swap).tocsr()
    out.data = (out.data > 0.5).astype(float)
    out.eliminate_zeros()
    return sp.csr_array(out)


def game_step_matrix(
    domain: PatrolDomain, transitions: sp.csr_array, policy: np.ndarray, side
) -> sp.csr_array:
    """One-step matrix of a robot playing ``side`` of an equilibrium.

    go → its own action, stop → stop, turn → turn_left
    (:func:`mirl.world.game.game_action_to_action`).

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    transitions : scipy.sparse.csr_array of shape (S*A, S)
        The robot's T.
    policy : ndarray of int, shape (S,)
        Its policy.
    side : sequence of float
        Its go, stop and turn probabilities.

    Returns
    -------
    scipy.sparse.csr_array of shape (S, S)
        The state-to-state matrix of one game move.
    """
    S = domain.n_states
    w = np.zeros((S, domain.n_actions))
    np.add.at(w, (np.arange(S), np.asarray(policy, dtype=int)), side[0])
    w[:, STOP] += side[1]
    w[:, TURN_LEFT] += side[2]
    return sp.csr_array(policy_matrix(transitions, w))


class TeamParts:
    """What the team filters propagate by.

    Per robot the policy step Pᵢ and, per pair, meeting masks and the game steps of both sides,
    transposed for propagation (column vectors b' = Pᵀ b).

    Parameters
    ----------
    domain : PatrolDomain
        The domain.
    learned : LearnResult
        The robots' learned T and policies, and the pairs' equilibria.
    """

    def __init__(self, domain: PatrolDomain, learned: LearnResult) -> None:
        robots = learned.robots
        self.n = n = len(robots)
        self.S = domain.n_states
        self.pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        pols = [np.asarray(r.policy, dtype=int) for r in robots]
        self.step_T = [sp.csr_array(policy_matrix(r.transitions, r.policy).T) for r in robots]
        self.meet = [meeting_matrix(domain, pols[i], pols[j]) for i, j in self.pairs]
        self.game_T: list[tuple[sp.csr_array, sp.csr_array]] = []
        for i, j in self.pairs:
            eq = learned.pair_equilibrium(i, j)
            gi = game_step_matrix(domain, robots[i].transitions, pols[i], eq.row)
            gj = game_step_matrix(domain, robots[j].transitions, pols[j], eq.col)
            self.game_T.append((sp.csr_array(gi.T), sp.csr_array(gj.T)))

    def robot_pairs(self, i: int) -> list[tuple[int, int, int]]:
        """Robot i's pairs, in order.

        Parameters
        ----------
        i : int
            The robot.

        Returns
        -------
        list of (int, int, int)
            (pair index, other robot, side: 0 row / 1 column).
        """
        return [(k, b if a == i else a, 0 if a == i else 1)
                for k, (a, b) in enumerate(self.pairs) if i in (a, b)]  # fmt: skip


class FactoredTeam:
    """Marginals (N, S) with pairwise meeting corrections (module doc).

    A step is three sparse products for the whole team instead of ~7 per robot: every robot's
    meeting probabilities at once (the masks stacked, each at its other robot's columns), every
    robot's game moves (block-diagonal) and every robot's policy step (block-diagonal). Each
    output entry adds the same products in the same order as the per-robot products did (a
    transposed mask is read as the CSR of its transpose: its entries in column order, as the CSC
    kernel adds them), and a game move with no meeting adds exact zeros, so the step is bit for
    bit the per-robot loop's (``tests/experiments/test_teams.py`` keeps that loop as the
    reference).

    Parameters
    ----------
    parts : TeamParts
        The team's steps, masks and game moves.
    """

    def __init__(self, parts: TeamParts) -> None:
        self.parts = p = parts
        n, S = p.n, p.S
        # position r of robot i's pairs, in pair order: (other robot, mask, game step); rows of
        # the stacked products are ordered (position, robot), so results reshape to (n-1, n, S)
        pairs = [p.robot_pairs(i) for i in range(n)]
        masks, games = [], []
        for r in range(n - 1):
            for i in range(n):
                k, other, side = pairs[i][r]
                mask = p.meet[k] if side == 0 else sp.csr_array(p.meet[k].T)
                masks.append((mask, other * S))
                games.append((p.game_T[k][side], (r * n + i) * S))  # its slot of the input
        self._masks = _stacked(masks, n * S)  # (n-1)·n·S × n·S
        self._games = _stacked(games, n * S, diagonal=True)  # (n-1)·n·S × (n-1)·n·S
        self._steps = _stacked([(m, i * S) for i, m in enumerate(p.step_T)], n * S, True)

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        """One step of every marginal (three kernel calls for the team, see the class doc).

        Parameters
        ----------
        belief : ndarray of shape (N, S)
            The marginals.

        Returns
        -------
        ndarray of shape (N, S)
            The marginals one step later.
        """
        p = self.parts
        n, S = p.n, p.S
        q = _csr_product(self._masks, belief.reshape(-1)).reshape(n - 1, n, S)
        np.clip(q, 0.0, 1.0, out=q)  # P(robot i at s meets its r-th pair's other robot)
        free = np.ones((n, S))
        w = np.empty((n - 1, n, S))
        for r in range(n - 1):  # each robot's pairs in order: the earlier pair's game wins
            np.multiply(free, q[r], out=w[r])
            free = free - w[r]
        games = _csr_product(self._games, (belief * w).reshape(-1)).reshape(n - 1, n, S)
        extra = np.zeros((n, S))
        for r in range(n - 1):
            extra = extra + games[r]
        return _csr_product(self._steps, (belief * free).reshape(-1)).reshape(n, S) + extra


class StackedFactoredTeams:
    """Several :class:`FactoredTeam` steps taken as one: the teams' stacked products joined
    block-diagonally, so a step of M filters (the posterior's model sets, fed the same record)
    is the three kernel calls of one team on M times the rows, not 3·M calls each with its own
    Python overhead. Each output row adds the same products in the same order as its own team's
    did and the element-wise steps are the same operations, so every team's marginals are bit
    for bit those of :meth:`FactoredTeam.propagate`.

    Parameters
    ----------
    teams : sequence of FactoredTeam
        The teams, of the same number of robots and states.
    """

    def __init__(self, teams) -> None:
        self.teams = list(teams)
        shapes = {(t.parts.n, t.parts.S) for t in self.teams}
        if len(shapes) != 1:
            raise ValueError(f"teams of different sizes (robots, states): {sorted(shapes)}")
        ((self.n, self.S),) = shapes
        self._masks = _block_diagonal([t._masks for t in self.teams])
        self._games = _block_diagonal([t._games for t in self.teams])
        self._steps = _block_diagonal([t._steps for t in self.teams])

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        """One step of every team's marginals (:meth:`FactoredTeam.propagate`, stacked).

        Parameters
        ----------
        belief : ndarray of shape (M, N, S)
            Each team's marginals.

        Returns
        -------
        ndarray of shape (M, N, S)
            The marginals one step later.
        """
        M, n, S = len(self.teams), self.n, self.S
        if n == 1:  # a lone robot: its policy step alone
            return _csr_product(self._steps, belief.reshape(-1)).reshape(M, n, S)
        # FactoredTeam.propagate's operations for every team at once, less the ones that
        # cannot change a bit: q is a sum of non-negative terms (clipping at 0 is a no-op), the
        # first pair's weight is 1·q and the games' sum starts from 0 + the first game's term
        q = _csr_product(self._masks, belief.reshape(-1)).reshape(M, n - 1, n, S)
        np.minimum(q, 1.0, out=q)
        w = np.empty((M, n - 1, n, S))
        w[:, 0] = q[:, 0]
        free = 1.0 - q[:, 0]
        for r in range(1, n - 1):  # each robot's pairs in order: the earlier pair's game wins
            np.multiply(free, q[:, r], out=w[:, r])
            free -= w[:, r]
        np.multiply(w, belief[:, None], out=w)
        games = _csr_product(self._games, w.reshape(-1)).reshape(M, n - 1, n, S)
        out = _csr_product(self._steps, (belief * free).reshape(-1)).reshape(M, n, S)
        extra = games[:, 0]
        for r in range(1, n - 1):
            extra = extra + games[:, r]
        out += extra
        return out


def _block_diagonal(arrays: list[tuple]) -> tuple:
    """The CSR arrays of :func:`_stacked` joined block-diagonally (each block's rows after the
    previous block's, its columns shifted past theirs), entries in their order; 32-bit indices
    when they fit (the product then reads less memory; its sums are the same)."""
    indptr, indices, data = [np.zeros(1, dtype=np.int64)], [], []
    rows = cols = nnz = 0
    for ptr, idx, dat, (r, c) in arrays:
        indptr.append(ptr[1:] + nnz)  # a block may have no rows (a lone robot's masks)
        indices.append(idx + cols)
        data.append(dat)
        rows, cols, nnz = rows + r, cols + c, nnz + len(dat)
    ptr_all, idx_all = np.concatenate(indptr), np.concatenate(indices)
    if max(int(ptr_all[-1]), rows, cols) < 2**31 - 1:
        ptr_all, idx_all = ptr_all.astype(np.int32), idx_all.astype(np.int32)
    return ptr_all, idx_all, np.concatenate(data), (rows, cols)


def _stacked(blocks, n_cols: int, diagonal: bool = False) -> tuple:
    """CSR arrays (indptr, indices, data, shape) of CSR ``blocks`` stacked by rows, each with its
    columns shifted by its offset (``diagonal``: the offsets make a block-diagonal matrix); the
    entries keep their order within each row, so products add as each block's did."""
    indptr, rows = [np.zeros(1, dtype=np.int64)], 0
    indices, data = [np.zeros(0, dtype=np.int64)], [np.zeros(0)]  # no blocks: a lone robot
    for A, offset in blocks:
        A = sp.csr_array(A)
        indptr.append(A.indptr[1:].astype(np.int64) + indptr[-1][-1])
        indices.append(A.indices.astype(np.int64) + offset)
        data.append(A.data)
        rows += A.shape[0]
    cols = rows if diagonal else n_cols
    return np.concatenate(indptr), np.concatenate(indices), np.concatenate(data), (rows, cols)


def _csr_product(arrays: tuple, x: np.ndarray) -> np.ndarray:
    indptr, indices, data, (rows, cols) = arrays
    out = np.zeros(rows)
    csr_block_matvec(rows, cols, 1, indptr, indices, data, x, out)  # scipy's one-vector kernel
    return out


class ExactTeam:
    """The joint belief over S^N states as an N-dimensional tensor (module doc).

    A step is the free part — the belief where nobody meets, pushed through the policies' steps
    as dense mode products — plus the meeting assignments through one precomputed sparse chain:
    meetings cover ~8 % of the joint states on boyd2 with three robots, so pushing each
    assignment through dense mode products over the whole tensor (as the first version did,
    ~0.3 s per step there) cost several times the free part for nothing.

    Parameters
    ----------
    parts : TeamParts
        The team's steps, masks and game moves.
    """

    def __init__(self, parts: TeamParts) -> None:
        self.parts = p = parts
        choice, code = meeting_assignments(p)
        self.free = (code == 0).astype(float)
        groups = []  # (flat joint states, per robot transposed matrix) per meeting assignment
        flat_code = code.ravel()
        for value in np.unique(flat_code[flat_code != 0]):
            idx = np.flatnonzero(flat_code == value)
            mats = []
            for r in range(p.n):
                k = int(choice[r].flat[idx[0]]) - 1
                mats.append(p.step_T[r] if k < 0 else p.game_T[k][0 if p.pairs[k][0] == r else 1])
            groups.append((idx, mats))
        self.meetings = _SparseChain(groups, p.S, p.n)

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        """One step of the joint.

        Parameters
        ----------
        belief : ndarray of shape (S,)*N
            The joint belief.

        Returns
        -------
        ndarray of shape (S,)*N
            The joint one step later.
        """
        out = np.ascontiguousarray(_mode_products(belief * self.free, self.parts.step_T))
        self.meetings.add_to(belief.reshape(-1), out.reshape(-1))  # a view: out is contiguous
        return out

    def marginals(self, belief: np.ndarray) -> np.ndarray:
        """The per-robot marginals, summing out one axis at a time (only the first two sums read the
        whole tensor).

        Parameters
        ----------
        belief : ndarray of shape (S,)*N
            The joint belief.

        Returns
        -------
        ndarray of shape (N, S)
            Each robot's state distribution.
        """
        out = []
        x = belief
        while x.ndim > 1:
            out.append(x.reshape(x.shape[0], -1).sum(axis=1))
            x = x.sum(axis=0)
        return np.stack([*out, x])

    def none_sees(self, belief: np.ndarray, G: np.ndarray) -> np.ndarray:
        """P(no patroller sees cell c) = Σ_s B[s] ∏ᵢ G[sᵢ, c].

        Parameters
        ----------
        belief : ndarray of shape (S,)*N
            The joint belief.
        G : ndarray of shape (S, C)
            1 − D: a robot in state s does not see cell c.

        Returns
        -------
        ndarray of shape (C,)
            The probability per cell.
        """
        x = np.tensordot(belief, G, axes=([belief.ndim - 1], [0]))  # (S, …, S, C)
        while x.ndim > 2:
            x = np.einsum("...sc,sc->...c", x, G)
        return np.einsum("sc,sc->c", x, G)


class _SparseChain:
    """The joint states of the meeting assignments, each pushed through its own transposed step
    matrix per axis, as a chain of N fixed sparse matrices: stage r maps the support reached so
    far to the support after moving axis r (each state has ~3 successors, so the supports stay
    small, unlike one S^N × |states| Khatri–Rao matrix). Supports are keyed by
    (assignment, joint state) until the last stage, which merges the assignments, so one
    scatter adds them all."""

    def __init__(self, groups: list[tuple[np.ndarray, list[sp.csr_array]]], S: int, n: int) -> None:
        size = S**n
        self.idx = np.concatenate([idx for idx, _ in groups])
        support = np.concatenate([g * size + idx for g, (idx, _) in enumerate(groups)])
        self.stages = []
        for axis in range(n):
            stride = S ** (n - 1 - axis)
            gid, flat = np.divmod(support, size)
            a = (flat // stride) % S
            targets, srcs, vals = [], [], []
            for g, (_, mats) in enumerate(groups):
                pos = np.flatnonzero(gid == g)  # support is sorted, so one block per group
                M = sp.csc_array(mats[axis])  # column a: the successors of a, their probability
                counts = np.diff(M.indptr)[a[pos]]
                src = np.repeat(pos, counts)
                nz = np.repeat(M.indptr[a[pos]] - (np.cumsum(counts) - counts), counts)
                nz = nz + np.arange(len(src))
                targets.append(support[src] + (M.indices[nz] - a[src]) * stride)
                srcs.append(src)
                vals.append(M.data[nz])
            target = np.concatenate(targets)
            if axis == n - 1:
                target = target % size  # the last stage sums the assignments' contributions
            n_in = len(support)
            support, row = np.unique(target, return_inverse=True)
            data = (np.concatenate(vals), (row, np.concatenate(srcs)))
            stage = sp.csr_array(data, shape=(len(support), n_in))
            if stage.nnz < 2**31 - 1:  # 32-bit indices: the product reads ~2× less memory
                stage.indices = stage.indices.astype(np.int32)
                stage.indptr = stage.indptr.astype(np.int32)
            self.stages.append(stage)
        self.out = support

    def add_to(self, flat_in: np.ndarray, flat_out: np.ndarray) -> None:
        v = flat_in[self.idx]
        for stage in self.stages:
            v = stage @ v
        flat_out[self.out] += v  # self.out is unique, so += is a plain scatter-add


def meeting_assignments(p: TeamParts) -> tuple[np.ndarray, np.ndarray]:
    """Per robot and joint state, which of its options it takes — 0 = its policy, 1 + k = the
    game of its k-th pair (first meeting in robot order) — as (n, S, …, S) ``choice``, and the
    joint states' assignment codes (0 = nobody meets), (S, …, S)."""
    shape = (p.S,) * p.n
    choice = np.zeros((p.n, *shape), dtype=np.int8)
    for k, (i, j) in enumerate(p.pairs):
        met = _broadcast(p.meet[k].toarray() > 0, i, j, p.n)
        for r in (i, j):
            choice[r] = np.where((choice[r] == 0) & met, 1 + k, choice[r])
    code = np.zeros(shape, dtype=np.int64)
    for r in range(p.n):
        code = code * (len(p.pairs) + 1) + choice[r]
    return choice, code


def _broadcast(mask2: np.ndarray, i: int, j: int, n: int) -> np.ndarray:
    shape = [1] * n
    shape[i] = shape[j] = mask2.shape[0]
    return mask2.reshape(shape)


def _mode_products(x: np.ndarray, mats_T: list[sp.csr_array]) -> np.ndarray:
    """x ×₀ M₀ᵀ ×₁ M₁ᵀ …: apply each (transposed) one-step matrix along its axis. Axis 0 is one
    product with the contiguous (S, S^(N−1)) view; the other axes slice by slice (each slice
    contiguous and, at S² entries, in cache), which avoids transposing copies of the whole
    tensor — half the time of moving each axis to the front on boyd2 with three robots."""
    M = mats_T[0]
    y = M @ x.reshape(x.shape[0], -1)
    if len(mats_T) == 1:
        return y.reshape(M.shape[0], *x.shape[1:])
    if x.ndim == 2:
        return (mats_T[1] @ y.T).T  # the last axis of a slice: a small transposed product
    y = y.reshape(M.shape[0], *x.shape[1:])
    out = np.empty(tuple(m.shape[0] for m in mats_T))
    for i, part in enumerate(y):
        out[i] = _mode_products(part, mats_T[1:])
    return out


class FactoredDetection:
    """Detection and first-order hazards from per-robot occupancies, with D kept sparse.

    Detection d_k(c) = 1 − ∏ᵢ (1 − P(i sees c)) and the first-order hazards of
    :meth:`~mirl.planning.belief.BeliefFilter.predict`: with G = 1 − D and P G = 1 − P D,
    occ · (G[:, c'] ∘ (P G)[:, c]) = Σocc − occ·D[:, c'] − occ·(P D)[:, c] + occ·(D[:, c'] ∘
    (P D)[:, c]). The sparse matrices depend on the robots' steps and L's model only, so they
    are built once; :meth:`rows` then takes any run of consecutive steps, each step's numbers
    computed as if all steps were taken at once (the products add per column, the sums per row),
    so a prediction may be computed a block of steps at a time. On the 60 × 60 office (S =
    3 804, ~4 000 cell pairs, 390 steps) this takes well under a second where dense (S, pairs)
    products took ~60 s.

    Parameters
    ----------
    detection : scipy.sparse.csr_array of shape (S, C)
        D, which patroller states see which L cells.
    step_T : list of scipy.sparse.csr_array of shape (S, S)
        Each robot's one-step matrix, transposed.
    cell_pairs : ndarray of int, shape (n_pairs, 2)
        L's moves: its cell before and after.
    """

    def __init__(
        self, detection: sp.csr_array, step_T: list[sp.csr_array], cell_pairs: np.ndarray
    ) -> None:
        self.D = D = sp.csc_array(detection)
        self.DT = sp.csr_array(D.T)
        prev, self.nxt = np.asarray(cell_pairs).T
        Dp = sp.csc_array(D[:, prev])
        self.Dp_T = sp.csr_array(Dp.T)
        self.per_robot = []
        for PT in step_T:
            PDn = sp.csc_array(sp.csr_array(PT.T) @ D)[:, self.nxt]  # P(sees c one step later | s)
            both = sp.csc_array(Dp.multiply(PDn))
            self.per_robot.append((sp.csr_array(PDn.T), sp.csr_array(both.T)))

    def rows(self, occ: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Detection and hazards of the steps whose per-robot occupancies are ``occ``.

        Parameters
        ----------
        occ : ndarray of shape (K1, N, S)
            Per-robot occupancies of consecutive steps.

        Returns
        -------
        detection : ndarray of shape (K1, C)
            P(some patroller sees cell c).
        hazard : ndarray of shape (K1, n_pairs)
            The first-order hazards; row 0 is the unconditional detection of its pairs.
        """
        K1, N, S = occ.shape
        seen = (self.DT @ occ.reshape(K1 * N, S).T).T.reshape(K1, N, -1)  # P(robot i sees c)
        det = 1.0 - np.prod(1.0 - seen, axis=1)
        nxt = self.nxt
        surv = np.ones((K1 - 1, len(nxt)))
        for i, (PDn_T, both_T) in enumerate(self.per_robot):
            o = occ[:-1, i]
            total = o.sum(axis=1, keepdims=True)
            o_prev = (self.Dp_T @ o.T).T
            joint_ok = total - o_prev - (PDn_T @ o.T).T + (both_T @ o.T).T
            before = total - o_prev
            ok = before > 1e-12
            ratio = joint_ok / np.where(ok, before, 1.0)
            surv *= np.where(ok, ratio, 1.0 - seen[1:, i, nxt])
        haz = np.concatenate([det[:1, nxt], 1.0 - surv])
        return det, haz


def factored_detection(
    occ: np.ndarray, detection: sp.csr_array, step_T: list[sp.csr_array], cell_pairs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`FactoredDetection.rows` of all of ``occ`` at once.

    Parameters
    ----------
    occ : ndarray of shape (K+1, N, S)
        Per-robot occupancies.
    detection : scipy.sparse.csr_array of shape (S, C)
        D.
    step_T : list of scipy.sparse.csr_array of shape (S, S)
        Each robot's one-step matrix, transposed.
    cell_pairs : ndarray of int, shape (n_pairs, 2)
        L's moves.

    Returns
    -------
    detection : ndarray of shape (K+1, C)
        P(some patroller sees cell c).
    hazard : ndarray of shape (K+1, n_pairs)
        The first-order hazards.
    """
    return FactoredDetection(detection, step_T, cell_pairs).rows(occ)
