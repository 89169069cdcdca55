"""L's side: predicting the patrollers and planning when and how to reach the goal unseen.

Three parts, each usable on its own:

* :func:`observer_model` — L's own MDP: states (row, col, heading) over every free cell of the
  map (hallways and rooms), the patrollers' four actions, L's failure (2.5 %: the robot stays
  put), its goal and the sparse **detection matrix** D (patroller states × L cells, SPEC §2:
  straight ahead along the heading, up to ``detect_distance`` cells, stopped by walls; room
  cells are never visible).
* :class:`BeliefFilter` — what L believes about the patrollers. Exact Bayesian filtering of the
  patrollers' state under the *learned* models: each step the belief is propagated with the
  learned policy, transition function and equilibrium, then conditioned on what L saw. An
  observed robot collapses onto its observed state; an unseen robot is known *not* to stand on a
  visible cell (negative evidence — L sees its whole field of view). The belief at t = 0 is
  uniform, so a robot never seen is spread over the occluded states. With two robots the filter
  tracks their **joint** state (S² states, 15 376 on boyd2): meetings, where the equilibrium
  replaces the policies' actions, are then modelled exactly (propagated as the S × S matrix
  P_Iᵀ B P_J, never as an S² × S² matrix). With more robots (or S² above ``max_joint_states``)
  it tracks independent marginals and ignores meetings.
  :meth:`BeliefFilter.predict` propagates the belief without evidence into the future and turns
  it into per-cell detection probabilities d_t(c) = P(some patroller sees cell c at t).
* :func:`solve_observer_mdp` — vectorised backward induction over (L state, t). Reaching the goal
  earns ``goal_reward`` (once: the goal is absorbing); being seen costs ``detection_penalty`` and
  ends the run, so the value of a state is ``goal_reward·P(goal reached unseen) −
  detection_penalty·P(seen first)`` within the horizon; with both at 1 a positive value means L
  predicts success to be more likely than detection, with the run's default penalty 0.5 (see
  :mod:`mirl.runs`) that success beats half the detection risk. In L's start cell only *leaving* is
  allowed: the go time is chosen outside the MDP (waiting in the room is safe), so V_t(start) is
  the value of going at t and one backward pass scores every go time. L goes at the argmax over
  the window if it is positive.

**Detection hazard.** The probability of being seen on a step is not independent of the previous
steps: a patroller that did not see L a step ago is mostly still not looking. Treating the
per-step detection probabilities d_t(c) as independent multiplies the same uncertainty at every
step and is far too pessimistic (on boyd2 with the true models it predicts ≈0.01 success where
the exact survival is ≈0.2). The MDP therefore uses the *first-order* hazard h_t(c | c') =
P(seen on c at t | not seen on c' at t−1), computed per robot from its predicted marginal and
one-step matrix and combined over robots as independent; it depends on L's move (c' → c), so the
arrival term is evaluated per non-zero of L's transition matrix. ``hazard="independent"`` gives
the naive d_t(c) for comparison.

The continuation (1 − h) multiplies the next value, i.e. the dynamics are time-indexed, which
:func:`mirl.mdp.backward_induction` (stationary transitions) cannot express; the loop below is
the same one-sparse-product-per-step recursion with that factor.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from mirl.domain import N_HEADINGS, STOP, TURN_LEFT, PatrolDomain
from mirl.game import Equilibrium, meeting
from mirl.maps import HEADING_DELTAS, GridMap
from mirl.mdp import policy_matrix
from mirl.models import LearnResult
from mirl.scenario import Scenario
from mirl.transitions import transition_matrix_from_success

__all__ = [
    "OBSERVER_FAILURE",
    "UNSEEN",
    "NOT_WATCHING",
    "ObserverModel",
    "observer_model",
    "observer_domain",
    "detection_matrix",
    "BeliefFilter",
    "Prediction",
    "ObserverPlan",
    "solve_observer_mdp",
    "shortest_path_policy",
]

OBSERVER_FAILURE = 0.025  # L's own action failure (the paper's 2.5 %): the robot stays put
UNSEEN = -1  # BeliefFilter.update: L watched and did not see the robot
NOT_WATCHING = -2  # BeliefFilter.update: L did not watch (it has left its room): no evidence


def observer_domain(gridmap: GridMap) -> PatrolDomain:
    """A :class:`PatrolDomain` whose cells are all of the map's free cells (L may enter rooms)."""
    free = gridmap.free
    lmap = GridMap(
        name=f"{gridmap.name}-observer",
        patroller=free,
        observer_only=np.zeros_like(free),
        observer_start=gridmap.observer_start,
        goals=gridmap.goals,
        visibility_order=np.zeros((0, 2), dtype=int),
        source=gridmap.source,
    )
    return PatrolDomain(lmap)


def detection_matrix(patrol: PatrolDomain, observer: PatrolDomain, distance: int) -> sp.csr_array:
    """Sparse (patroller states × L cells) 0/1 matrix: D[s, c] = 1 iff a patroller in state s
    sees L on cell c (the rule of :func:`mirl.domain.detection_cells`, vectorised over states).
    """
    if distance < 0:
        raise ValueError(f"detect_distance must be non-negative, got {distance}")
    r, c, h = patrol.states.T
    dr, dc = HEADING_DELTAS[h].T
    rows_n, cols_n = patrol.map.shape
    alive = np.ones(patrol.n_states, dtype=bool)
    rows, cols = [], []
    for k in range(distance + 1):  # loop over distances, vectorised over states
        rr, cc = r + k * dr, c + k * dc
        inside = (rr >= 0) & (rr < rows_n) & (cc >= 0) & (cc < cols_n)
        rr_c, cc_c = np.clip(rr, 0, rows_n - 1), np.clip(cc, 0, cols_n - 1)
        alive &= inside & patrol.map.patroller[rr_c, cc_c]  # sight stops at walls and rooms
        s = np.flatnonzero(alive)
        rows.append(s)
        cols.append(observer.cell_lut[rr_c[s], cc_c[s]])
    rows_a, cols_a = np.concatenate(rows), np.concatenate(cols)
    data = np.ones(len(rows_a))
    return sp.csr_array((data, (rows_a, cols_a)), shape=(patrol.n_states, observer.n_cells))


@dataclass(frozen=True, eq=False)
class ObserverModel:
    """L's MDP without its rewards (those come from the prediction)."""

    domain: PatrolDomain  # over the map's free cells
    transitions: sp.csr_array  # (S_L·A, S_L); failure = stay put
    goal: np.ndarray  # (S_L,) bool: states on L's goal cell
    start_state: int  # L's start cell, heading towards its door
    detection: sp.csr_array  # (S_patroller, n_L_cells), see detection_matrix
    failure: float = OBSERVER_FAILURE

    @property
    def n_states(self) -> int:
        return self.domain.n_states

    def cell_of(self, states) -> np.ndarray:
        return self.domain.state_cell(states)

    def seen_by(self, patroller_states: np.ndarray, observer_state: int) -> np.ndarray:
        """(N,) bool: which patrollers (true states) see L in ``observer_state`` — the true rule."""
        cell = int(self.cell_of(observer_state))
        column = self.detection[:, [cell]].toarray().ravel()
        return column[np.asarray(patroller_states)] > 0

    @cached_property
    def distance_to_goal(self) -> np.ndarray:
        """(S_L,) steps to the goal under intended outcomes (inf where unreachable)."""
        return _distance_to_goal(self.domain, self.goal)

    @cached_property
    def cell_pairs(self) -> np.ndarray:
        """(n_pairs, 2) distinct (cell before, cell after) of L's possible one-step moves."""
        T = self.transitions.tocoo()
        A = self.domain.n_actions
        pairs = np.column_stack([self.cell_of(T.row // A), self.cell_of(T.col)])
        return np.unique(pairs, axis=0)

    @cached_property
    def _transition_entries(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Non-zeros of T as (row s·A+a, next state, probability, index into cell_pairs)."""
        T = self.transitions.tocoo()
        A = self.domain.n_actions
        n_cells = self.domain.n_cells
        key = self.cell_of(T.row // A) * n_cells + self.cell_of(T.col)
        pair_keys = self.cell_pairs[:, 0] * n_cells + self.cell_pairs[:, 1]
        return T.row, T.col, T.data, np.searchsorted(pair_keys, key)


def observer_model(scenario: Scenario, *, failure: float = OBSERVER_FAILURE) -> ObserverModel:
    """Build L's MDP for ``scenario``: L starts in its start cell facing its first step towards
    the goal (the door), and its goal is ``scenario.goal``."""
    dom = observer_domain(scenario.map)
    T = transition_matrix_from_success(dom, 1.0 - failure, "stop")
    goal = np.zeros(dom.n_states, dtype=bool)
    gcell = dom.cell_lut[scenario.goal]
    goal[gcell * N_HEADINGS : (gcell + 1) * N_HEADINGS] = True
    D = detection_matrix(scenario.domain, dom, scenario.detect_distance)
    start_cell = dom.cell_lut[scenario.observer_start]
    dist = _distance_to_goal(dom, goal)
    heads = start_cell * N_HEADINGS + np.arange(N_HEADINGS)
    # facing the door = the heading from which the goal is nearest (ties: lowest heading)
    start = int(heads[np.argmin(dist[heads])])
    if not np.isfinite(dist[start]):
        raise ValueError(
            f"{scenario.source}: L's goal {scenario.goal} is unreachable from its start"
        )
    return ObserverModel(dom, T, goal, start, D, failure)


def _distance_to_goal(dom: PatrolDomain, goal: np.ndarray) -> np.ndarray:
    """Steps to the goal under intended outcomes (inf where unreachable), by vectorised
    relaxation: dist(s) = 1 + min_a dist(ψ(s, a)) until nothing changes."""
    dist = np.where(goal, 0.0, np.inf)
    psi = dom.intended
    for _ in range(dom.n_states):
        new = np.where(goal, 0.0, 1.0 + dist[psi].min(axis=1))
        if np.array_equal(new, dist):
            break
        dist = new
    return dist


def shortest_path_policy(model: ObserverModel) -> np.ndarray:
    """(S_L,) stationary action taking L along a shortest path to its goal (ignores patrollers).
    A failed step leaves L where it was, so following it again retries."""
    return np.argmin(model.distance_to_goal[model.domain.intended], axis=1)


# ---- prediction ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Prediction:
    """The patrollers' predicted future from time ``t0`` (index k ↔ time t0 + k).

    ``occupancy[k, i]`` is robot i's marginal state distribution; ``detection[k, c]`` the
    probability that some patroller sees L's cell c (from the joint distribution when the filter
    is joint); ``hazard[k, j]`` the probability that L is seen on cell ``pairs[j, 1]`` at k given
    it was not seen on ``pairs[j, 0]`` at k − 1 (row 0 is the unconditional detection).
    """

    t0: int
    occupancy: np.ndarray  # (K+1, N, S)
    detection: np.ndarray  # (K+1, n_L_cells)
    hazard: np.ndarray  # (K+1, n_pairs)
    pairs: np.ndarray  # (n_pairs, 2) L cell before, after

    @property
    def steps(self) -> int:
        return self.detection.shape[0] - 1


class BeliefFilter:
    """Bayesian filter over the patrollers' states under a :class:`LearnResult` (module doc).

    Call :meth:`update` once per time step, from t = 0, with the state each robot was observed
    in (:data:`UNSEEN` = -1 if L watched and did not see it, :data:`NOT_WATCHING` = -2 if L did
    not watch); :meth:`predict` then looks ahead from the current step.
    """

    def __init__(
        self,
        domain: PatrolDomain,
        learned: LearnResult,
        *,
        visible: np.ndarray | None = None,
        joint: bool | None = None,
        heading_noise: float = 0.0,
        max_joint_states: int = 60_000,
    ) -> None:
        self.domain = domain
        self.n_robots = len(learned.robots)
        self.n_states = S = domain.n_states
        self.visible = np.zeros(S, bool) if visible is None else np.asarray(visible, bool)
        self.heading_noise = float(heading_noise)
        if joint is None:
            joint = self.n_robots == 2 and S * S <= max_joint_states
        if joint and self.n_robots != 2:
            raise ValueError("the joint filter supports exactly two patrollers")
        self.joint = bool(joint)
        steps = [policy_matrix(r.transitions, r.policy) for r in learned.robots]
        # per-robot transposed one-step matrices (meetings ignored) for the detection hazard
        self._step_T = [sp.csr_array(P.T) for P in steps]
        if self.joint:
            # b' = (P_I ⊗ P_J)ᵀ((1 − m)∘b) + (M_I ⊗ M_J)ᵀ(m∘b), as matrices B (S × S):
            # B' = P_Iᵀ (B∘(1 − m)) P_J + M_Iᵀ (B∘m) M_J — O(S²) memory, no S² × S² matrix
            self._meet, mixed = _pair_parts(domain, learned, steps)
            self._mixed_T = [sp.csr_array(M.T) for M in mixed]
        unseen = (~self.visible).astype(float)
        self._both_unseen = np.outer(unseen, unseen).ravel() if self.joint else None
        self.t = -1
        self.belief: np.ndarray | None = None  # joint: (S·S,), else (N, S)
        self.fallbacks = 0  # steps whose evidence had probability ~0 under the learned model

    # evidence of one robot: likelihood of each state given what L saw
    def _evidence(self, observed: int) -> np.ndarray:
        S = self.n_states
        if observed == NOT_WATCHING:
            return np.ones(S)
        if observed < 0:
            return (~self.visible).astype(float)  # not seen ⇒ not on a visible cell
        e = np.zeros(S)
        if self.heading_noise > 0:
            cell = observed // N_HEADINGS
            e[cell * N_HEADINGS : (cell + 1) * N_HEADINGS] = self.heading_noise / 3
        e[observed] = 1.0 - self.heading_noise if self.heading_noise > 0 else 1.0
        return e

    def _propagate(self, belief: np.ndarray) -> np.ndarray:
        if self.joint:
            S = self.n_states
            B = belief.reshape(S, S)
            met = B * self._meet
            out = self._step_T[0] @ (B - met)  # P_Iᵀ X
            out = (self._step_T[1] @ out.T).T  # … P_J
            if met.any():
                out += (self._mixed_T[1] @ (self._mixed_T[0] @ met).T).T
            return out.ravel()
        return np.stack([F @ b for F, b in zip(self._step_T, belief, strict=True)])

    def marginals(self, belief: np.ndarray | None = None) -> np.ndarray:
        """(N, S) per-robot marginals of ``belief`` (default: the current one)."""
        b = self.belief if belief is None else belief
        if not self.joint:
            return b
        m = b.reshape(self.n_states, self.n_states)
        return np.stack([m.sum(axis=1), m.sum(axis=0)])

    def update(self, observed) -> None:
        """Advance one step and condition on ``observed`` ((N,) state indices, -1 = unseen)."""
        observed = np.asarray(observed, dtype=int)
        S = self.n_states
        if self.belief is None:
            prior = (
                np.full(S * S, 1.0 / (S * S)) if self.joint else np.full((self.n_robots, S), 1 / S)
            )
        else:
            prior = self._propagate(self.belief)
        ev = [self._evidence(int(o)) for o in observed]
        if self.joint:
            if observed[0] < 0 and observed[1] < 0 and observed[0] == observed[1]:
                pair = self._both_unseen if observed[0] == UNSEEN else 1.0  # the common case
            else:
                pair = np.outer(ev[0], ev[1]).ravel()
            post = prior * pair
            z = post.sum()
            if z > 1e-300:
                self.belief = post / z
            else:  # the learned model cannot explain the pair: condition each marginal alone
                self.fallbacks += 1
                m = [self._condition(p, e) for p, e in zip(self.marginals(prior), ev, strict=True)]
                self.belief = np.outer(m[0], m[1]).ravel()
        else:
            self.belief = np.stack([self._condition(p, e) for p, e in zip(prior, ev, strict=True)])
        self.t += 1

    def _condition(self, prior: np.ndarray, evidence: np.ndarray) -> np.ndarray:
        post = prior * evidence
        z = post.sum()
        if z <= 1e-300:  # impossible under the model: trust the observation alone
            self.fallbacks += not self.joint
            post, z = evidence.copy(), evidence.sum()
            if z <= 0:
                post, z = np.ones_like(prior), float(len(prior))
        return post / z

    def predict(self, steps: int, model: ObserverModel) -> Prediction:
        """Occupancies, detection probabilities and hazards for t = now … now + ``steps``.

        The only sequential part is the propagation (one sparse product per step); detection
        and hazards are then computed for all steps at once.
        """
        if self.belief is None:
            raise ValueError("predict() before any update(): the filter has no belief yet")
        S, K1 = self.n_states, steps + 1
        Dd = sp.csr_array(model.detection).toarray()
        G = 1.0 - Dd  # (S, C): a robot in state s does not see cell c
        prev, nxt = model.cell_pairs.T
        beliefs = np.empty((K1, *self.belief.shape))
        b = self.belief
        for k in range(K1):
            beliefs[k] = b
            if k < steps:
                b = self._propagate(b)
        occ = np.stack([self.marginals(x) for x in beliefs]) if self.joint else beliefs
        seen = occ @ Dd  # (K+1, N, C): P(robot i sees cell c)
        if self.joint:
            # inclusion–exclusion with the joint: P(I or J) = P(I) + P(J) − P(I and J),
            # P(I and J)[c] = Σ p[sI, sJ]·D[sI, c]·D[sJ, c]
            both = (beliefs.reshape(K1, S, S) @ Dd * Dd).sum(axis=1)
            det = seen[:, 0] + seen[:, 1] - both
        else:
            det = 1.0 - np.prod(1.0 - seen, axis=1)
        # per robot: P(not seen on c' at k−1 and not seen on c at k) / P(not seen on c' at k−1)
        # = occ_{k−1} · (G[:, c'] ∘ (P G)[:, c]) / occ_{k−1} · G[:, c'], one (S, pairs) matrix
        surv = np.ones((steps, len(prev)))
        for i, step_T in enumerate(self._step_T):
            PG = step_T.T @ G  # (S, C): P(not seeing c one step later | s)
            joint_ok = occ[:-1, i] @ (G[:, prev] * PG[:, nxt])
            before = occ[:-1, i] @ G[:, prev]
            ok = before > 1e-12
            ratio = joint_ok / np.where(ok, before, 1.0)
            surv *= np.where(ok, ratio, 1.0 - seen[1:, i, nxt])
        haz = np.concatenate([det[:1, nxt], 1.0 - surv])
        return Prediction(self.t, occ, np.clip(det, 0, 1), np.clip(haz, 0, 1), model.cell_pairs)


def _pair_parts(
    domain: PatrolDomain, learned: LearnResult, steps: list[sp.csr_array]
) -> tuple[np.ndarray, list[sp.csr_array]]:
    """The (S, S) meeting mask of the pair's states and each robot's equilibrium-mixed one-step
    matrix M_i (go → own action, stop → stop, turn → turn_left, as in :mod:`mirl.game`)."""
    S = domain.n_states
    eq: Equilibrium = learned.equilibrium
    pol = [np.asarray(r.policy, dtype=int) for r in learned.robots]
    mixed = []
    for r, probs in zip(learned.robots, (eq.row, eq.col), strict=True):
        w = np.zeros((S, domain.n_actions))
        np.add.at(w, (np.arange(S), np.asarray(r.policy, dtype=int)), probs[0])  # go
        w[:, STOP] += probs[1]
        w[:, TURN_LEFT] += probs[2]
        mixed.append(sp.csr_array(policy_matrix(r.transitions, w)))
    sI, sJ = np.divmod(np.arange(S * S), S)
    met = meeting(domain, sI, sJ, pol[0][sI], pol[1][sJ]).reshape(S, S)
    return met.astype(float), mixed


def _joint_step_matrix(
    domain: PatrolDomain, learned: LearnResult, steps: list[sp.csr_array]
) -> sp.csr_array:
    """(S², S²) row-stochastic one-step matrix of the pair (robot 0 = the game's row player).

    Given the pair's state the two robots move independently, so each row is an outer product:
    of the policies' rows away from meetings, and of the equilibrium-mixed rows at a meeting.
    Hence diag(1 − m)·(P_I ⊗ P_J) + diag(m)·(M_I ⊗ M_J). Its size is nnz(P_I)·nnz(P_J) (12 GB
    for dense chains), so the filter propagates in the equivalent matrix form instead; this is
    the reference the tests check that form against.
    """
    met, mixed = _pair_parts(domain, learned, steps)
    m = met.ravel()
    free = sp.kron(sp.csr_array(steps[0]), sp.csr_array(steps[1]), format="csr")
    meet = sp.kron(mixed[0], mixed[1], format="csr")
    return sp.csr_array(sp.diags_array(1.0 - m) @ free + sp.diags_array(m) @ meet)


# ---- planning --------------------------------------------------------------------------------
@dataclass(frozen=True)
class ObserverPlan:
    """Solution of L's time-indexed MDP from time ``t0`` (index k ↔ time t0 + k).

    ``go_values[k]`` is the value of leaving the start cell at t0 + k (k ≤ window); ``go_time``
    is the k with the highest positive go value (None if none is positive).
    """

    t0: int
    values: np.ndarray  # (K+1, S_L)
    policy: np.ndarray  # (K, S_L) greedy action at each step
    go_values: np.ndarray  # (window+1,)
    go_time: int | None

    @property
    def horizon(self) -> int:
        return self.policy.shape[0]

    @property
    def value(self) -> float:
        return (
            float(self.go_values[self.go_time])
            if self.go_time is not None
            else float(self.go_values.max(initial=-np.inf))
        )


def solve_observer_mdp(
    model: ObserverModel,
    prediction: Prediction,
    *,
    window: int | None = None,
    goal_reward: float = 1.0,
    detection_penalty: float = 1.0,
    min_value: float = 0.0,
    hazard: str = "markov",
) -> ObserverPlan:
    """Backward induction over K = ``prediction.steps`` steps (see the module doc).

    ``window`` bounds the go times considered (default: all k < K); a go time needs a go value
    above ``min_value``. ``hazard`` is ``"markov"`` (first-order hazard, default) or
    ``"independent"`` (per-step detection probabilities taken as independent).
    """
    K = prediction.steps
    if K < 1:
        raise ValueError("the plan needs at least one step of prediction")
    if hazard == "markov":
        H = prediction.hazard
    elif hazard == "independent":
        H = prediction.detection[:, prediction.pairs[:, 1]]
    else:
        raise ValueError(f"unknown hazard model '{hazard}' (known: markov, independent)")
    window = K - 1 if window is None else min(int(window), K - 1)
    dom = model.domain
    S, A = dom.n_states, dom.n_actions
    rows, cols, probs, pair = model._transition_entries
    mask = _start_cell_mask(model)
    V = np.zeros((K + 1, S))
    V[K, model.goal] = goal_reward
    policy = np.empty((K, S), dtype=np.int8)
    for k in range(K - 1, -1, -1):
        h = H[k + 1, pair]
        cont = V[k + 1, cols]  # the goal is absorbing: V[·, goal] = goal_reward
        Q = np.bincount(
            rows, weights=probs * ((1.0 - h) * cont - detection_penalty * h), minlength=S * A
        ).reshape(S, A)
        Q += mask
        policy[k] = Q.argmax(axis=1)  # first maximum: forward wins ties
        V[k] = Q.max(axis=1)
        V[k, model.goal] = goal_reward
    go_values = V[: window + 1, model.start_state].copy()
    best = int(np.argmax(go_values))
    go_time = best if go_values[best] > min_value else None
    return ObserverPlan(prediction.t0, V, policy, go_values, go_time)


def _start_cell_mask(model: ObserverModel) -> np.ndarray:
    """(S, A) additive mask: in L's start cell only actions that leave it (or, facing a wall,
    turns) are allowed — waiting there is the outer choice of the go time."""
    dom = model.domain
    cell = dom.state_cell(np.arange(dom.n_states))
    start_cell = cell[model.start_state]
    leaves = cell[dom.intended] != start_cell  # (S, A)
    allowed = np.where(
        leaves.any(axis=1)[:, None], leaves, np.arange(dom.n_actions)[None, :] != STOP
    )
    mask = np.zeros((dom.n_states, dom.n_actions))
    mask[(cell == start_cell)[:, None] & ~allowed] = -np.inf
    return mask
