"""What L believes about the patrollers: exact Bayesian filtering of their state under the
*learned* models.

Each step the belief is propagated with the learned policy, transition function and equilibrium,
then conditioned on what L saw. An observed robot collapses onto its observed state; an unseen
robot is known *not* to stand on a visible cell (negative evidence — L sees its whole field of
view). The belief at t = 0 is uniform, so a robot never seen is spread over the occluded states.
With two robots the filter tracks their **joint** state (S² states, 15 376 on boyd2): meetings,
where the equilibrium replaces the policies' actions, are then modelled exactly (propagated as
the S × S matrix P_Iᵀ B P_J, never as an S² × S² matrix). With N ≥ 3 robots and S^N within
``max_joint_states`` the joint is an N-dimensional tensor (:class:`~mirl.planning.team_filter.
ExactTeam`); beyond, the filter is **factored** — one marginal per robot with pairwise meeting
corrections (:class:`~mirl.planning.team_filter.FactoredTeam`).
:meth:`BeliefFilter.predict` propagates the belief without evidence into the future and turns it
into per-cell detection probabilities d_t(c) = P(some patroller sees cell c at t).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mirl.learning.results import LearnResult
from mirl.mdp import policy_matrix
from mirl.planning.observer import ObserverModel
from mirl.planning.pair_sums import MeetingStep, PairSightings
from mirl.planning.team_filter import ExactTeam, FactoredDetection, FactoredTeam, TeamParts
from mirl.sparse import csr_matmul
from mirl.world.domain import N_HEADINGS, STOP, TURN_LEFT, PatrolDomain
from mirl.world.game import Equilibrium, meeting

__all__ = ["UNSEEN", "NOT_WATCHING", "BeliefFilter", "Prediction", "StreamedPrediction"]

MAX_EXACT_STATES = 20_000_000  # an S^N joint tensor beyond this does not fit comfortably
UNSEEN = -1  # BeliefFilter.update: L watched and did not see the robot
NOT_WATCHING = -2  # BeliefFilter.update: L did not watch (it has left its room): no evidence


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

    def hazard_rows(self, lo: int, hi: int) -> np.ndarray:
        return self.hazard[lo:hi]

    def detection_rows(self, lo: int, hi: int) -> np.ndarray:
        return self.detection[lo:hi]


class StreamedPrediction:
    """A :class:`Prediction` of the factored filter that keeps only checkpoints: the marginals
    at every ``every``-th step. Rows of occupancy, detection and hazard are recomputed from the
    checkpoint before them when asked for (``*_rows``), with the same arithmetic as computing
    them all at once, so they are bit for bit those of the full arrays. Memory: K / every + every
    steps of (N, S) marginals instead of K, and a block of hazards instead of K × pairs — with
    ``every`` ≈ √K both are O(√K · S). The full arrays (:attr:`occupancy`, :attr:`detection`,
    :attr:`hazard`) are computed on access, for tests and small maps."""

    def __init__(
        self,
        t0: int,
        steps: int,
        start: np.ndarray,
        propagate,
        detection: FactoredDetection,
        pairs: np.ndarray,
    ) -> None:
        self.t0, self.steps, self.pairs = t0, int(steps), pairs
        self.every = max(1, int(np.ceil(np.sqrt(max(steps, 1)))))
        self._propagate, self._detection = propagate, detection
        self._checkpoints = [start]
        b = start
        for k in range(1, self.steps + 1):
            b = propagate(b)
            if k % self.every == 0:
                self._checkpoints.append(b)
        self._cache: tuple[int, int, np.ndarray, np.ndarray] | None = None

    def occupancy_rows(self, lo: int, hi: int) -> np.ndarray:
        """(hi − lo, N, S) marginals of steps lo … hi − 1."""
        first = lo // self.every
        b = self._checkpoints[first]
        out = np.empty((hi - lo, *b.shape))
        for k in range(first * self.every, hi):
            if k >= lo:
                out[k - lo] = b
            if k + 1 < hi:
                b = self._propagate(b)
        return out

    def _rows(self, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
        if self._cache is not None and self._cache[:2] == (lo, hi):
            return self._cache[2], self._cache[3]
        start = max(lo - 1, 0)  # a hazard row needs the step before it
        det, haz = self._detection.rows(self.occupancy_rows(start, hi))
        det, haz = np.clip(det[lo - start :], 0, 1), np.clip(haz[lo - start :], 0, 1)
        self._cache = (lo, hi, det, haz)
        return det, haz

    def detection_rows(self, lo: int, hi: int) -> np.ndarray:
        return self._rows(lo, hi)[0]

    def hazard_rows(self, lo: int, hi: int) -> np.ndarray:
        return self._rows(lo, hi)[1]

    @property
    def occupancy(self) -> np.ndarray:
        return self.occupancy_rows(0, self.steps + 1)

    @property
    def detection(self) -> np.ndarray:
        return self.detection_rows(0, self.steps + 1)

    @property
    def hazard(self) -> np.ndarray:
        return self.hazard_rows(0, self.steps + 1)


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
            joint = S**self.n_robots <= max_joint_states
        if joint and self.n_robots > 2 and S**self.n_robots > MAX_EXACT_STATES:
            raise ValueError(
                f"an exact joint of {self.n_robots} patrollers needs {S}^{self.n_robots} "
                f"states (limit {MAX_EXACT_STATES:,}); use the factored filter (joint=False)"
            )
        self.joint = bool(joint)
        # "pair": the S × S joint of two robots; "team": the S^N tensor; "factored": marginals
        self.mode = "pair" if joint and self.n_robots == 2 else "factored"
        if joint and self.n_robots > 2:
            self.mode = "team"
        self.joint = self.mode != "factored"
        self._team: ExactTeam | FactoredTeam | None = None
        if self.mode != "pair":
            parts = TeamParts(domain, learned)
            self._team = ExactTeam(parts) if self.mode == "team" else FactoredTeam(parts)
        steps = [policy_matrix(r.transitions, r.policy) for r in learned.robots]
        # per-robot transposed one-step matrices (meetings ignored) for the detection hazard
        self._step_T = [sp.csr_array(P.T) for P in steps]
        if self.mode == "pair":
            # b' = (P_I ⊗ P_J)ᵀ((1 − m)∘b) + (M_I ⊗ M_J)ᵀ(m∘b), as matrices B (S × S):
            # B' = P_Iᵀ (B∘(1 − m)) P_J + M_Iᵀ (B∘m) M_J — O(S²) memory, no S² × S² matrix
            self._meet, mixed = _pair_parts(domain, learned, steps)
            self._mixed_T = [sp.csr_array(M.T) for M in mixed]
            self._meeting = MeetingStep(self._meet, self._mixed_T)
        unseen = (~self.visible).astype(float)
        self._both_unseen = np.outer(unseen, unseen).ravel() if self.mode == "pair" else None
        self.t = -1
        self.belief: np.ndarray | None = None  # pair: (S·S,), team: (S,)*N, factored: (N, S)
        self.fallbacks = 0  # steps whose evidence had probability ~0 under the learned model
        self._static: dict[int, tuple] = {}  # per L model: predict()'s fixed matrices

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
        if self._team is not None:
            return self._team.propagate(belief)
        if self.joint:
            S = self.n_states
            away = belief.reshape(S, S).copy()  # B∘(1 − m): m is 0/1, so B off meetings, 0 on
            met = away.flat[self._meeting.at]  # B∘m, at the meeting states only
            away.flat[self._meeting.at] = 0.0
            out = csr_matmul(self._step_T[0], away)  # P_Iᵀ X
            out_t = csr_matmul(self._step_T[1], out.T)  # (… P_J)ᵀ
            if met.any():
                self._meeting.add_to(out_t.ravel(), met)  # + (M_Iᵀ (B∘m) M_J)ᵀ
            return out_t.T.ravel()
        return np.stack([csr_matmul(F, b) for F, b in zip(self._step_T, belief, strict=True)])

    def marginals(self, belief: np.ndarray | None = None) -> np.ndarray:
        """(N, S) per-robot marginals of ``belief`` (default: the current one)."""
        b = self.belief if belief is None else belief
        assert b is not None, "no belief yet: call update() first"
        if isinstance(self._team, ExactTeam):
            return self._team.marginals(b)
        if not self.joint:
            return b
        m = b.reshape(self.n_states, self.n_states)
        return np.stack([m.sum(axis=1), m.sum(axis=0)])

    def update(self, observed) -> None:
        """Advance one step and condition on ``observed`` ((N,) state indices, -1 = unseen)."""
        observed = np.asarray(observed, dtype=int)
        S = self.n_states
        prior: np.ndarray
        if self.belief is None and self.mode == "team":
            prior = np.full((S,) * self.n_robots, float(S) ** -self.n_robots)
        elif self.belief is None:
            prior = (
                np.full(S * S, 1.0 / (S * S)) if self.joint else np.full((self.n_robots, S), 1 / S)
            )
        else:
            prior = self._propagate(self.belief)
        ev = [self._evidence(int(o)) for o in observed]
        if self.mode == "team":
            self._update_team(prior, ev)
        elif self.joint:
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

    def _update_team(self, prior: np.ndarray, ev: list[np.ndarray]) -> None:
        post = prior.copy()
        for axis, e in enumerate(ev):
            shape = [1] * self.n_robots
            shape[axis] = self.n_states
            post *= e.reshape(shape)
        z = post.sum()
        if z > 1e-300:
            self.belief = post / z
            return
        self.fallbacks += 1
        m = [self._condition(p, e) for p, e in zip(self.marginals(prior), ev, strict=True)]
        out = m[0]
        for x in m[1:]:
            out = np.multiply.outer(out, x)
        self.belief = out

    def _condition(self, prior: np.ndarray, evidence: np.ndarray) -> np.ndarray:
        post = prior * evidence
        z = post.sum()
        if z <= 1e-300:  # impossible under the model: trust the observation alone
            self.fallbacks += not self.joint
            post, z = evidence.copy(), evidence.sum()
            if z <= 0:
                post, z = np.ones_like(prior), float(len(prior))
        return post / z

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        """``belief`` (in this filter's form) one step later, without evidence."""
        return self._propagate(belief)

    def condition_unseen(
        self, belief: np.ndarray, not_seeing: np.ndarray
    ) -> tuple[np.ndarray, float]:
        """``belief`` conditioned on no patroller seeing L, and the probability of that.

        ``not_seeing`` is (S,): 1 where a patroller in that state does not see L's cell. Exact
        for the joint forms; the factored filter conditions each marginal alone and multiplies
        the robots' probabilities (its independence approximation).
        """
        g = np.asarray(not_seeing, dtype=float)
        if self.mode == "pair":
            B = belief.reshape(self.n_states, self.n_states)
            post = B * g[:, None] * g[None, :]
        elif self.mode == "team":
            post = belief.copy()
            for axis in range(self.n_robots):
                shape = [1] * self.n_robots
                shape[axis] = self.n_states
                post *= g.reshape(shape)
        else:
            kept = belief @ g
            ok = kept > 1e-300
            post = np.where(ok[:, None], belief * g / np.where(ok, kept, 1.0)[:, None], belief)
            return post, float(np.prod(kept))
        z = float(post.sum())
        return (post / z if z > 1e-300 else post).reshape(belief.shape), z

    def _factored_detection(self, model: ObserverModel) -> FactoredDetection:
        """The factored filter's sparse detection parts for L's ``model`` (built once)."""
        cached = self._static.get(id(model))
        if cached is None or cached[0] is not model:
            parts = FactoredDetection(model.detection, self._step_T, model.cell_pairs)
            cached = self._static[id(model)] = (model, parts)
        return cached[1]

    def _detection_parts(self, model: ObserverModel):
        """Dense D (S, C), G = 1 − D, per robot G[:, c'] ∘ (P G)[:, c] over L's moves c' → c
        (P G: P(not seeing c one step later | s)) and G[:, c'], and the pair's sightings
        index: fixed for a filter and L's model, so computed once, not at every re-plan."""
        cached = self._static.get(id(model))
        if cached is None or cached[0] is not model:
            Dd = sp.csr_array(model.detection).toarray()
            G = 1.0 - Dd  # (S, C): a robot in state s does not see cell c
            prev, nxt = model.cell_pairs.T
            moves = [G[:, prev] * (step_T.T @ G)[:, nxt] for step_T in self._step_T]
            pair = PairSightings(Dd) if self.mode == "pair" else None
            cached = self._static[id(model)] = (model, Dd, G, moves, G[:, prev], pair)
        return cached[1:]

    def predict(
        self,
        steps: int,
        model: ObserverModel,
        *,
        belief: np.ndarray | None = None,
        t: int | None = None,
    ) -> Prediction | StreamedPrediction:
        """Occupancies, detection probabilities and hazards for t = now … now + ``steps``.

        The only sequential part is the propagation (one sparse product per step); detection
        and hazards are then computed for all steps at once — or, for the factored filter, a
        block of steps at a time from checkpoints (:class:`StreamedPrediction`), so that its
        memory grows with √steps × states rather than steps × (states + L's cell pairs).
        ``belief`` (in this filter's form) and its step ``t`` predict from an earlier belief
        instead of the current one (the go rule's chances of the record).
        """
        if belief is None:
            belief, t = self.belief, self.t
        if belief is None:
            raise ValueError("predict() before any update(): the filter has no belief yet")
        t0 = self.t if t is None else int(t)
        if self.mode == "factored":
            return StreamedPrediction(
                t0, steps, belief, self._propagate, self._factored_detection(model),
                model.cell_pairs,
            )  # fmt: skip
        Dd, G, moves, G_prev, pair = self._detection_parts(model)
        if self.mode == "team":
            occ, none = self._predict_team(steps, G, belief)
            seen = occ @ Dd  # (K+1, N, C): P(robot i sees cell c)
            det = 1.0 - none
        else:
            occ, seen, det = self._predict_pair(steps, Dd, pair, belief)
        nxt = model.cell_pairs[:, 1]
        # per robot: P(not seen on c' at k−1 and not seen on c at k) / P(not seen on c' at k−1)
        # = occ_{k−1} · (G[:, c'] ∘ (P G)[:, c]) / occ_{k−1} · G[:, c'], one (S, pairs) matrix
        surv = np.ones((steps, len(nxt)))
        for i, move in enumerate(moves):
            joint_ok = occ[:-1, i] @ move
            before = occ[:-1, i] @ G_prev
            ok = before > 1e-12
            ratio = joint_ok / np.where(ok, before, 1.0)
            surv *= np.where(ok, ratio, 1.0 - seen[1:, i, nxt])
        haz = np.concatenate([det[:1, nxt], 1.0 - surv])
        return Prediction(t0, occ, np.clip(det, 0, 1), np.clip(haz, 0, 1), model.cell_pairs)

    def _predict_team(
        self, steps: int, G: np.ndarray, b: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Occupancies and P(no patroller sees c) from the N-robot joint ``b``, one step at a
        time (the S^N tensors are not kept)."""
        assert isinstance(self._team, ExactTeam)
        occ, none = [], []
        for k in range(steps + 1):
            occ.append(self._team.marginals(b))
            none.append(self._team.none_sees(b, G))
            if k < steps:
                b = self._team.propagate(b)
        return np.stack(occ), np.stack(none)

    def _predict_pair(self, steps: int, Dd: np.ndarray, sightings: PairSightings, b: np.ndarray):
        """Occupancies, per-robot sightings and detection from the pair's joint ``b``
        (inclusion–exclusion)."""
        S, K1 = self.n_states, steps + 1
        beliefs = np.empty((K1, S * S))
        both = np.empty((K1, Dd.shape[1]))
        for k in range(K1):
            beliefs[k] = b
            both[k] = sightings.both(b)  # while b is in cache
            if k < steps:
                b = self._propagate(b)
        joint = beliefs.reshape(K1, S, S)
        occ = np.stack([joint.sum(axis=2), joint.sum(axis=1)], axis=1)  # (K+1, 2, S) marginals
        seen = occ @ Dd  # (K+1, N, C): P(robot i sees cell c)
        # inclusion–exclusion with the joint: P(I or J) = P(I) + P(J) − P(I and J),
        # P(I and J)[c] = Σ p[sI, sJ]·D[sI, c]·D[sJ, c]
        det = seen[:, 0] + seen[:, 1] - both
        return occ, seen, det


def _pair_parts(
    domain: PatrolDomain, learned: LearnResult, steps: list[sp.csr_array]
) -> tuple[np.ndarray, list[sp.csr_array]]:
    """The (S, S) meeting mask of the pair's states and each robot's equilibrium-mixed one-step
    matrix M_i (go → own action, stop → stop, turn → turn_left, as in :mod:`mirl.world.game`)."""
    S = domain.n_states
    eq: Equilibrium = learned.pair_equilibrium(0, 1)
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
