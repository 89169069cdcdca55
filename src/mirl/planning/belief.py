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
corrections (:class:`~mirl.planning.team_filter.FactoredTeam`). Each of the three forms is a
class behind one interface (:class:`BeliefForm`), a row of :data:`BELIEF_MODES` chosen once
when the filter is built. :meth:`BeliefFilter.predict` propagates the belief without evidence
into the future and turns it into per-cell detection probabilities d_t(c) = P(some patroller
sees cell c at t).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from mirl._registry import Registry
from mirl._validation import Interval, check_argument
from mirl.learning.results import LearnResult
from mirl.mdp import policy_matrix
from mirl.planning.observer import ObserverModel
from mirl.planning.pair_sums import MeetingStep, PairSightings
from mirl.planning.team_filter import (
    ExactTeam,
    FactoredDetection,
    FactoredTeam,
    StackedFactoredTeams,
    TeamParts,
)
from mirl.sparse import csr_matmul
from mirl.world.domain import N_HEADINGS, STOP, TURN_LEFT, PatrolDomain
from mirl.world.game import Equilibrium, meeting

__all__ = [
    "UNSEEN",
    "NOT_WATCHING",
    "BELIEF_MODES",
    "BeliefFilter",
    "BeliefForm",
    "FactoredBelief",
    "FactoredFilterStack",
    "PairBelief",
    "Prediction",
    "StreamedPrediction",
    "TeamBelief",
]

MAX_EXACT_STATES = 20_000_000  # an S^N joint tensor beyond this does not fit comfortably
UNSEEN = -1  # BeliefFilter.update: L watched and did not see the robot
NOT_WATCHING = -2  # BeliefFilter.update: L did not watch (it has left its room): no evidence


# ---- prediction ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Prediction:
    """The patrollers' predicted future from time ``t0`` (index k ↔ time t0 + k).

    Parameters
    ----------
    t0 : int
        The time of row 0.
    occupancy : ndarray of shape (K+1, N, S)
        ``occupancy[k, i]`` is robot i's marginal state distribution.
    detection : ndarray of shape (K+1, C)
        ``detection[k, c]`` the probability that some patroller sees L's cell c (from the joint
        distribution when the filter is joint).
    hazard : ndarray of shape (K+1, n_pairs)
        ``hazard[k, j]`` the probability that L is seen on cell ``pairs[j, 1]`` at k given it was
        not seen on ``pairs[j, 0]`` at k − 1 (row 0 is the unconditional detection).
    pairs : ndarray of int, shape (n_pairs, 2)
        L's moves: its cell before and after.
    """

    t0: int
    occupancy: np.ndarray  # (K+1, N, S)
    detection: np.ndarray  # (K+1, n_L_cells)
    hazard: np.ndarray  # (K+1, n_pairs)
    pairs: np.ndarray  # (n_pairs, 2) L cell before, after

    @property
    def steps(self) -> int:
        """K, the steps predicted beyond ``t0``."""
        return self.detection.shape[0] - 1

    def hazard_rows(self, lo: int, hi: int) -> np.ndarray:
        """Rows ``lo`` … ``hi`` − 1 of :attr:`hazard`.

        Parameters
        ----------
        lo : int
            The first row.
        hi : int
            One past the last row.

        Returns
        -------
        ndarray of shape (hi - lo, n_pairs)
            The hazards.
        """
        return self.hazard[lo:hi]

    def detection_rows(self, lo: int, hi: int) -> np.ndarray:
        """Rows ``lo`` … ``hi`` − 1 of :attr:`detection`.

        Parameters
        ----------
        lo : int
            The first row.
        hi : int
            One past the last row.

        Returns
        -------
        ndarray of shape (hi - lo, C)
            The detection probabilities.
        """
        return self.detection[lo:hi]


class StreamedPrediction:
    """A :class:`Prediction` of the factored filter that keeps only checkpoints.

    It keeps the marginals at every ``every``-th step. Rows of occupancy, detection and hazard
    are recomputed from the checkpoint before them when asked for (``*_rows``), with the same
    arithmetic as computing them all at once, so they are bit for bit those of the full arrays.
    Memory: K / every + every steps of (N, S) marginals instead of K, and a block of hazards
    instead of K × pairs — with ``every`` ≈ √K both are O(√K · S). The full arrays
    (:attr:`occupancy`, :attr:`detection`, :attr:`hazard`) are computed on access, for tests and
    small maps.

    Parameters
    ----------
    t0 : int
        The time of row 0.
    steps : int
        K, the steps predicted beyond ``t0``.
    start : ndarray of shape (N, S)
        The marginals at ``t0``.
    propagate : callable
        Marginals one step later (the factored filter's step).
    detection : FactoredDetection
        Computes detection and hazard rows from marginals.
    pairs : ndarray of int, shape (n_pairs, 2)
        L's moves: its cell before and after.
    """

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
        """The marginals of steps ``lo`` … ``hi`` − 1.

        Parameters
        ----------
        lo : int
            The first step.
        hi : int
            One past the last step.

        Returns
        -------
        ndarray of shape (hi - lo, N, S)
            The marginals, propagated from the checkpoint before ``lo``.
        """
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
        """Rows ``lo`` … ``hi`` − 1 of :attr:`detection`, recomputed from a checkpoint.

        Parameters
        ----------
        lo : int
            The first row.
        hi : int
            One past the last row.

        Returns
        -------
        ndarray of shape (hi - lo, C)
            The detection probabilities.
        """
        return self._rows(lo, hi)[0]

    def hazard_rows(self, lo: int, hi: int) -> np.ndarray:
        """Rows ``lo`` … ``hi`` − 1 of :attr:`hazard`, recomputed from a checkpoint.

        Parameters
        ----------
        lo : int
            The first row.
        hi : int
            One past the last row.

        Returns
        -------
        ndarray of shape (hi - lo, n_pairs)
            The hazards.
        """
        return self._rows(lo, hi)[1]

    @property
    def occupancy(self) -> np.ndarray:
        """All (K+1, N, S) marginals, computed on access."""
        return self.occupancy_rows(0, self.steps + 1)

    @property
    def detection(self) -> np.ndarray:
        """All (K+1, C) detection probabilities, computed on access."""
        return self.detection_rows(0, self.steps + 1)

    @property
    def hazard(self) -> np.ndarray:
        """All (K+1, n_pairs) hazards, computed on access."""
        return self.hazard_rows(0, self.steps + 1)


# ---- the filter's forms ----------------------------------------------------------------------
def _condition(prior: np.ndarray, evidence: np.ndarray) -> tuple[np.ndarray, bool]:
    """One robot's marginal conditioned on its evidence, and whether the evidence was impossible
    under the model (then the observation alone is trusted)."""
    post = prior * evidence
    z = post.sum()
    impossible = bool(z <= 1e-300)
    if impossible:
        post, z = evidence.copy(), evidence.sum()
        if z <= 0:
            post, z = np.ones_like(prior), float(len(prior))
    return post / z, impossible


def _conditioned_marginals(form: BeliefForm, prior: np.ndarray, ev: list[np.ndarray]) -> list:
    """Each robot's marginal of ``prior`` conditioned alone: a joint form's answer to evidence
    the learned model cannot explain (one fallback for the step, not one per robot)."""
    return [_condition(p, e)[0] for p, e in zip(form.marginals(prior), ev, strict=True)]


class BeliefForm(ABC):
    """How a :class:`BeliefFilter` holds its belief, moves it a step, conditions it on what L saw
    and predicts from it: the S × S joint of two robots (:class:`PairBelief`), the S^N joint
    tensor of a team (:class:`TeamBelief`), or per-robot marginals (:class:`FactoredBelief`).

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain.
    learned : LearnResult
        The models the belief moves by.
    steps : list of sparse arrays of shape (S, S)
        Each robot's one-step matrix under its policy (meetings ignored).
    visible : ndarray of shape (S,) of bool
        The states L sees.
    """

    name: ClassVar[str]
    description: ClassVar[str]
    joint: ClassVar[bool]  # exact over the robots' joint state
    min_robots: ClassVar[int] = 1
    max_robots: ClassVar[int | None] = None

    def __init__(
        self,
        domain: PatrolDomain,
        learned: LearnResult,
        steps: list[sp.csr_array],
        visible: np.ndarray,
    ) -> None:
        self.n_robots = len(learned.robots)
        self.n_states = domain.n_states
        # per-robot transposed one-step matrices (meetings ignored) for the detection hazard
        self.step_T = [sp.csr_array(P.T) for P in steps]
        self._static: dict[int, tuple] = {}  # per L model: predict()'s fixed matrices

    @abstractmethod
    def uniform(self) -> np.ndarray:
        """The belief at t = 0: every state alike."""

    @abstractmethod
    def propagate(self, belief: np.ndarray) -> np.ndarray:
        """``belief`` one step later, without evidence.

        Parameters
        ----------
        belief : ndarray
            A belief in this form.

        Returns
        -------
        ndarray
            The belief one step later, in this form.
        """

    @abstractmethod
    def marginals(self, belief: np.ndarray) -> np.ndarray:
        """The per-robot marginals of ``belief``.

        Parameters
        ----------
        belief : ndarray
            A belief in this form.

        Returns
        -------
        ndarray of shape (N, S)
            Each robot's state distribution.
        """

    @abstractmethod
    def condition(
        self, prior: np.ndarray, ev: list[np.ndarray], observed: np.ndarray
    ) -> tuple[np.ndarray, int]:
        """``prior`` conditioned on each robot's evidence.

        Parameters
        ----------
        prior : ndarray
            A belief in this form.
        ev : list of ndarray of shape (S,)
            Each robot's evidence: the likelihood of each of its states.
        observed : ndarray of int, shape (N,)
            What L saw of each robot (a state, :data:`UNSEEN` or :data:`NOT_WATCHING`).

        Returns
        -------
        posterior : ndarray
            The conditioned belief.
        fallbacks : int
            Robots (or one for the joint) whose evidence had probability ~0 under the learned
            models, so that each marginal was conditioned alone.
        """

    @abstractmethod
    def condition_unseen(self, belief: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, float]:
        """:meth:`BeliefFilter.condition_unseen` in this form.

        Parameters
        ----------
        belief : ndarray
            A belief in this form.
        g : ndarray of shape (S,)
            1 where a patroller in that state does not see L's cell.

        Returns
        -------
        posterior : ndarray
            The belief given that no patroller sees L.
        probability : float
            The probability that none does.
        """

    @abstractmethod
    def predict(
        self, steps: int, model: ObserverModel, belief: np.ndarray, t0: int
    ) -> Prediction | StreamedPrediction:
        """:meth:`BeliefFilter.predict` from ``belief`` at step ``t0``.

        Parameters
        ----------
        steps : int
            K, the steps to look ahead.
        model : ObserverModel
            L's model: its cells, moves and what the patrollers see.
        belief : ndarray
            A belief in this form.
        t0 : int
            The step of ``belief``.

        Returns
        -------
        Prediction or StreamedPrediction
            Occupancies, detection probabilities and hazards for t0 … t0 + K.
        """


class _JointBelief(BeliefForm):
    """The exact forms: occupancies and detection from the joint, hazards per robot from its
    marginals (:meth:`predict`)."""

    joint = True
    min_robots = 2

    def _sightings(self, Dd: np.ndarray) -> PairSightings | None:
        """What the form's detection needs of the dense D beyond it (the pair's index)."""
        return None

    def _detection_parts(self, model: ObserverModel):
        """Dense D (S, C), G = 1 − D, per robot G[:, c'] ∘ (P G)[:, c] over L's moves c' → c
        (P G: P(not seeing c one step later | s)) and G[:, c'], and the pair's sightings
        index: fixed for a filter and L's model, so computed once, not at every re-plan."""
        cached = self._static.get(id(model))
        if cached is None or cached[0] is not model:
            Dd = sp.csr_array(model.detection).toarray()
            G = 1.0 - Dd  # (S, C): a robot in state s does not see cell c
            prev, nxt = model.cell_pairs.T
            moves = [G[:, prev] * (step_T.T @ G)[:, nxt] for step_T in self.step_T]
            pair = self._sightings(Dd)
            cached = self._static[id(model)] = (model, Dd, G, moves, G[:, prev], pair)
        return cached[1:]

    @abstractmethod
    def _occupancy_and_detection(
        self, steps: int, Dd: np.ndarray, G: np.ndarray, pair, belief: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(K+1, N, S) occupancies, (K+1, N, C) per-robot sightings and (K+1, C) detection."""

    def predict(
        self, steps: int, model: ObserverModel, belief: np.ndarray, t0: int
    ) -> Prediction | StreamedPrediction:
        Dd, G, moves, G_prev, pair = self._detection_parts(model)
        occ, seen, det = self._occupancy_and_detection(steps, Dd, G, pair, belief)
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


class PairBelief(_JointBelief):
    """The exact S × S joint of two robots, kept flat (S·S,).

    A step is B' = P_Iᵀ (B∘(1 − m)) P_J + M_Iᵀ (B∘m) M_J, the matrix form of
    b' = (P_I ⊗ P_J)ᵀ((1 − m)∘b) + (M_I ⊗ M_J)ᵀ(m∘b): O(S²) memory, no S² × S² matrix; the
    meeting part is summed over its non-zero terms only
    (:class:`~mirl.planning.pair_sums.MeetingStep`).

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain.
    learned : LearnResult
        The models the belief moves by.
    steps : list of sparse arrays of shape (S, S)
        Each robot's one-step matrix under its policy (meetings ignored).
    visible : ndarray of shape (S,) of bool
        The states L sees.
    """

    name = "pair"
    description = "the exact S × S joint of two robots"
    max_robots = 2

    def __init__(self, domain, learned, steps, visible) -> None:
        super().__init__(domain, learned, steps, visible)
        self.meet, mixed = _pair_parts(domain, learned, steps)
        self.mixed_T = [sp.csr_array(M.T) for M in mixed]
        self.meeting = MeetingStep(self.meet, self.mixed_T)
        unseen = (~visible).astype(float)
        self._both_unseen = np.outer(unseen, unseen).ravel()

    def uniform(self) -> np.ndarray:
        S = self.n_states
        return np.full(S * S, 1.0 / (S * S))

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        S = self.n_states
        away = belief.reshape(S, S).copy()  # B∘(1 − m): m is 0/1, so B off meetings, 0 on
        met = away.flat[self.meeting.at]  # B∘m, at the meeting states only
        away.flat[self.meeting.at] = 0.0
        out = csr_matmul(self.step_T[0], away)  # P_Iᵀ X
        out_t = csr_matmul(self.step_T[1], out.T)  # (… P_J)ᵀ
        if met.any():
            self.meeting.add_to(out_t.ravel(), met)  # + (M_Iᵀ (B∘m) M_J)ᵀ
        return out_t.T.ravel()

    def marginals(self, belief: np.ndarray) -> np.ndarray:
        m = belief.reshape(self.n_states, self.n_states)
        return np.stack([m.sum(axis=1), m.sum(axis=0)])

    def condition(self, prior, ev, observed) -> tuple[np.ndarray, int]:
        if observed[0] < 0 and observed[1] < 0 and observed[0] == observed[1]:
            pair = self._both_unseen if observed[0] == UNSEEN else 1.0  # the common case
        else:
            pair = np.outer(ev[0], ev[1]).ravel()
        post = prior * pair
        z = post.sum()
        if z > 1e-300:
            return post / z, 0
        # the learned model cannot explain the pair: condition each marginal alone
        m = _conditioned_marginals(self, prior, ev)
        return np.outer(m[0], m[1]).ravel(), 1

    def condition_unseen(self, belief, g) -> tuple[np.ndarray, float]:
        B = belief.reshape(self.n_states, self.n_states)
        post = B * g[:, None] * g[None, :]
        z = float(post.sum())
        return (post / z if z > 1e-300 else post).reshape(belief.shape), z

    def _sightings(self, Dd: np.ndarray) -> PairSightings:
        return PairSightings(Dd)

    def _occupancy_and_detection(self, steps, Dd, G, pair, belief):
        """Occupancies, per-robot sightings and detection from the pair's joint ``b``
        (inclusion–exclusion)."""
        S, K1 = self.n_states, steps + 1
        b = belief
        beliefs = np.empty((K1, S * S))
        both = np.empty((K1, Dd.shape[1]))
        for k in range(K1):
            beliefs[k] = b
            both[k] = pair.both(b)  # while b is in cache
            if k < steps:
                b = self.propagate(b)
        joint = beliefs.reshape(K1, S, S)
        occ = np.stack([joint.sum(axis=2), joint.sum(axis=1)], axis=1)  # (K+1, 2, S) marginals
        seen = occ @ Dd  # (K+1, N, C): P(robot i sees cell c)
        # inclusion–exclusion with the joint: P(I or J) = P(I) + P(J) − P(I and J),
        # P(I and J)[c] = Σ p[sI, sJ]·D[sI, c]·D[sJ, c]
        det = seen[:, 0] + seen[:, 1] - both
        return occ, seen, det


class TeamBelief(_JointBelief):
    """The exact joint of N robots as an N-dimensional tensor (S,)*N.

    Propagated by :class:`~mirl.planning.team_filter.ExactTeam`.

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain.
    learned : LearnResult
        The models the belief moves by.
    steps : list of sparse arrays of shape (S, S)
        Each robot's one-step matrix under its policy (meetings ignored).
    visible : ndarray of shape (S,) of bool
        The states L sees.
    """

    name = "team"
    description = "the exact S^N joint tensor of a team"

    def __init__(self, domain, learned, steps, visible) -> None:
        super().__init__(domain, learned, steps, visible)
        self.team: ExactTeam = ExactTeam(TeamParts(domain, learned))

    def uniform(self) -> np.ndarray:
        S = self.n_states
        return np.full((S,) * self.n_robots, float(S) ** -self.n_robots)

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        return self.team.propagate(belief)

    def marginals(self, belief: np.ndarray) -> np.ndarray:
        return self.team.marginals(belief)

    def _along(self, axis: int, x: np.ndarray) -> np.ndarray:
        """(S,) ``x`` shaped to broadcast along robot ``axis`` of the joint."""
        shape = [1] * self.n_robots
        shape[axis] = self.n_states
        return x.reshape(shape)

    def condition(self, prior, ev, observed) -> tuple[np.ndarray, int]:
        post = prior.copy()
        for axis, e in enumerate(ev):
            post *= self._along(axis, e)
        z = post.sum()
        if z > 1e-300:
            return post / z, 0
        m = _conditioned_marginals(self, prior, ev)
        out = m[0]
        for x in m[1:]:
            out = np.multiply.outer(out, x)
        return out, 1

    def condition_unseen(self, belief, g) -> tuple[np.ndarray, float]:
        post = belief.copy()
        for axis in range(self.n_robots):
            post *= self._along(axis, g)
        z = float(post.sum())
        return (post / z if z > 1e-300 else post).reshape(belief.shape), z

    def _occupancy_and_detection(self, steps, Dd, G, pair, belief):
        """Occupancies and P(some patroller sees c) from the N-robot joint, one step at a
        time (the S^N tensors are not kept)."""
        b = belief
        occ_k, none = [], []
        for k in range(steps + 1):
            occ_k.append(self.team.marginals(b))
            none.append(self.team.none_sees(b, G))
            if k < steps:
                b = self.team.propagate(b)
        occ = np.stack(occ_k)
        seen = occ @ Dd  # (K+1, N, C): P(robot i sees cell c)
        return occ, seen, 1.0 - np.stack(none)


class FactoredBelief(BeliefForm):
    """Per-robot marginals (N, S) with pairwise meeting corrections.

    Propagated by :class:`~mirl.planning.team_filter.FactoredTeam`; each robot is conditioned
    alone and the robots' probabilities of not seeing L multiply (its independence
    approximation).

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain.
    learned : LearnResult
        The models the belief moves by.
    steps : list of sparse arrays of shape (S, S)
        Each robot's one-step matrix under its policy (meetings ignored).
    visible : ndarray of shape (S,) of bool
        The states L sees.
    """

    name = "factored"
    description = "per-robot marginals with pairwise meeting corrections"
    joint = False

    def __init__(self, domain, learned, steps, visible) -> None:
        super().__init__(domain, learned, steps, visible)
        self.team: FactoredTeam = FactoredTeam(TeamParts(domain, learned))

    def uniform(self) -> np.ndarray:
        return np.full((self.n_robots, self.n_states), 1 / self.n_states)

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        return self.team.propagate(belief)

    def marginals(self, belief: np.ndarray) -> np.ndarray:
        return belief

    def condition(self, prior, ev, observed) -> tuple[np.ndarray, int]:
        done = [_condition(p, e) for p, e in zip(prior, ev, strict=True)]
        return np.stack([post for post, _ in done]), sum(bad for _, bad in done)

    def condition_unseen(self, belief, g) -> tuple[np.ndarray, float]:
        kept = belief @ g
        ok = kept > 1e-300
        post = np.where(ok[:, None], belief * g / np.where(ok, kept, 1.0)[:, None], belief)
        return post, float(np.prod(kept))

    def _detection(self, model: ObserverModel) -> FactoredDetection:
        """The sparse detection parts for L's ``model`` (built once)."""
        cached = self._static.get(id(model))
        if cached is None or cached[0] is not model:
            parts = FactoredDetection(model.detection, self.step_T, model.cell_pairs)
            cached = self._static[id(model)] = (model, parts)
        return cached[1]

    def predict(
        self, steps: int, model: ObserverModel, belief: np.ndarray, t0: int
    ) -> Prediction | StreamedPrediction:
        return StreamedPrediction(
            t0, steps, belief, self.propagate, self._detection(model), model.cell_pairs
        )


BELIEF_MODES: Registry[type[BeliefForm]] = Registry(
    "belief mode", (PairBelief, TeamBelief, FactoredBelief), name=lambda form: form.name
)
"""The filter's forms by name (:attr:`BeliefFilter.mode`)."""


class BeliefFilter:
    """Bayesian filter over the patrollers' states under a :class:`LearnResult` (module doc).

    Call :meth:`update` once per time step, from t = 0, with the state each robot was observed
    in (:data:`UNSEEN` = -1 if L watched and did not see it, :data:`NOT_WATCHING` = -2 if L did
    not watch); :meth:`predict` then looks ahead from the current step.

    Parameters
    ----------
    domain : PatrolDomain
        The patrollers' domain.
    learned : LearnResult
        The models the belief moves by.
    visible : ndarray of shape (S,) of bool, optional
        The states L sees (default: none, so "not seen" is no evidence).
    joint : bool, optional
        Track the robots' joint state exactly (default: when S^N is at most
        ``max_joint_states``): the pair form for two robots, the team tensor for more.
    heading_noise : float, default 0.0
        Probability that an observed robot's heading is one of the other three.
    max_joint_states : int, default 60 000
        The largest S^N tracked jointly by default.
    mode : {"pair", "team", "factored"}, optional
        The form (:data:`BELIEF_MODES`), instead of the one ``joint`` chooses; ``"team"`` on
        two robots runs the general tensor code.

    Attributes
    ----------
    fallbacks : int
        The steps so far on which what L saw had probability ~0 (at most 1e-300) under the
        models, one per robot in the factored form: the models say it cannot happen, and the
        filter conditioned each robot's marginal on its sighting alone. ``mirl run`` reports
        them (``filter_fallbacks``).

    Raises
    ------
    ValueError
        A mode for another number of robots or that contradicts ``joint``; an exact joint of
        more than 20 000 000 states; a ``visible`` that is not (S,), a ``heading_noise``
        outside [0, 1], or models of another map than ``domain``'s.
    TypeError
        ``learned`` that is not a :class:`~mirl.learning.results.LearnResult`.
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
        mode: str | None = None,
    ) -> None:
        if not isinstance(learned, LearnResult):
            raise TypeError(f"learned must be a mirl.LearnResult, got {type(learned)}")
        self.domain = domain
        self.n_robots = n = len(learned.robots)
        self.n_states = S = domain.n_states
        # checked here, not where the first product fails: another map's models or view, and a
        # heading noise that would make the evidence's likelihoods negative
        if visible is not None and np.shape(visible) != (S,):
            shape = np.shape(visible)
            raise ValueError(f"visible must have shape ({S},), one per state, got {shape}")
        check_argument("heading_noise", heading_noise, Interval(float, 0.0, 1.0))
        for r in learned.robots:
            if np.shape(r.policy) != (S,) or np.shape(r.transitions) != (S * domain.n_actions, S):
                raise ValueError(
                    f"learned's model of {r.name} is not of this domain's {S} states: a policy "
                    f"of shape {np.shape(r.policy)} and transitions of {np.shape(r.transitions)}"
                )
        self.visible = np.zeros(S, bool) if visible is None else np.asarray(visible, bool)
        self.heading_noise = float(heading_noise)
        form = _chosen_form(n, S, joint, max_joint_states, mode)
        steps = [policy_matrix(r.transitions, r.policy) for r in learned.robots]
        self.form: BeliefForm = form(domain, learned, steps, self.visible)
        self.t = -1
        self.belief: np.ndarray | None = None  # pair: (S·S,), team: (S,)*N, factored: (N, S)
        self.fallbacks = 0  # steps whose evidence had probability ~0 under the learned model

    @property
    def mode(self) -> str:
        """The form's name: ``"pair"``, ``"team"`` or ``"factored"``."""
        return self.form.name

    @property
    def joint(self) -> bool:
        """Whether the belief is exact over the robots' joint state."""
        return self.form.joint

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

    def marginals(self, belief: np.ndarray | None = None) -> np.ndarray:
        """The per-robot marginals of ``belief``.

        Parameters
        ----------
        belief : ndarray, optional
            A belief in this filter's form; the current one by default.

        Returns
        -------
        ndarray of shape (N, S)
            Each robot's state distribution.
        """
        b = self.belief if belief is None else belief
        if b is None:
            raise ValueError("marginals() before any update(): the filter has no belief yet")
        return self.form.marginals(b)

    def update(self, observed) -> None:
        """Advance one step and condition on what L saw.

        Parameters
        ----------
        observed : array_like of int, shape (N,)
            Each robot's observed state, :data:`UNSEEN` (-1) if L watched and did not see it, or
            :data:`NOT_WATCHING` (-2) if L did not watch.
        """
        prior = self.form.uniform() if self.belief is None else self.form.propagate(self.belief)
        ev = self.evidence(observed)
        self.belief, fallbacks = self.form.condition(prior, ev, observed)
        self.fallbacks += fallbacks
        self.t += 1

    def evidence(self, observed) -> list[np.ndarray]:
        """Each robot's evidence of one step: the likelihood of each of its states.

        Parameters
        ----------
        observed : array_like of int, shape (N,)
            As for :meth:`update`.

        Returns
        -------
        list of ndarray of shape (S,)
            One likelihood per robot.

        Raises
        ------
        ValueError
            ``observed`` not N integers in [-2, S): a state past the map failed inside numpy,
            one below -2 was taken as "not seen", and 3.7 as state 3.
        """
        obs = np.asarray(observed)
        if obs.shape != (self.n_robots,) or (obs.size and obs.dtype.kind not in "iu"):
            raise ValueError(
                f"observed must be {self.n_robots} integers, one per robot, got shape "
                f"{obs.shape} and dtype {obs.dtype}"
            )
        bad = (obs < NOT_WATCHING) | (obs >= self.n_states)
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"observed[{i}] = {obs[i]} is not a state index in [0, {self.n_states}), "
                f"{UNSEEN} (not seen) or {NOT_WATCHING} (not watching)"
            )
        return [self._evidence(int(o)) for o in obs]

    def propagate(self, belief: np.ndarray) -> np.ndarray:
        """``belief`` (in this filter's form) one step later, without evidence.

        Parameters
        ----------
        belief : ndarray
            A belief in this filter's form.

        Returns
        -------
        ndarray
            The belief one step later.
        """
        return self.form.propagate(belief)

    def condition_unseen(
        self, belief: np.ndarray, not_seeing: np.ndarray
    ) -> tuple[np.ndarray, float]:
        """``belief`` conditioned on no patroller seeing L, and the probability of that.

        Exact for the joint forms; the factored filter conditions each marginal alone and multiplies
        the robots' probabilities (its independence approximation).

        Parameters
        ----------
        belief : ndarray
            A belief in this filter's form.
        not_seeing : ndarray of shape (S,)
            1 where a patroller in that state does not see L's cell.

        Returns
        -------
        posterior : ndarray
            The conditioned belief.
        probability : float
            The probability that no patroller sees L.
        """
        return self.form.condition_unseen(belief, np.asarray(not_seeing, dtype=float))

    def predict(
        self,
        steps: int,
        model: ObserverModel,
        *,
        belief: np.ndarray | None = None,
        t: int | None = None,
    ) -> Prediction | StreamedPrediction:
        """Occupancies, detection probabilities and hazards for t = now … now + ``steps``.

        The only sequential part is the propagation (one sparse product per step); detection and
        hazards are then computed for all steps at once — or, for the factored filter, a block
        of steps at a time from checkpoints (:class:`StreamedPrediction`), so that its memory
        grows with √steps × states rather than steps × (states + L's cell pairs).

        Parameters
        ----------
        steps : int
            K, the steps to look ahead.
        model : ObserverModel
            L's model: its cells, moves and what the patrollers see.
        belief : ndarray, optional
            Predict from this earlier belief (in this filter's form) instead of the current one (the
            go rule's chances of the record).
        t : int, optional
            The step of ``belief``; the filter's current step by default.

        Returns
        -------
        Prediction or StreamedPrediction
            The prediction from the belief's step.

        Raises
        ------
        ValueError
            No belief yet (:meth:`update` was never called) and none given; ``steps`` not an
            integer of at least 0.
        """
        check_argument("steps", steps, Interval(int, 0, None))
        if belief is None:
            belief, t = self.belief, self.t
        if belief is None:
            raise ValueError("predict() before any update(): the filter has no belief yet")
        t0 = self.t if t is None else int(t)
        return self.form.predict(steps, model, belief, t0)


class FactoredFilterStack:
    """Factored :class:`BeliefFilter` s fed the same record, stepped together: one
    :class:`~mirl.planning.team_filter.StackedFactoredTeams` step for all of them and their
    conditioning as one array operation. Each filter's belief, step and fallbacks are then
    those its own :meth:`BeliefFilter.update` would give, bit for bit (the same products added
    in the same order, each robot's normalising sum over the same contiguous row).

    Parameters
    ----------
    filters : sequence of BeliefFilter
        Factored filters of the same domain, L's same view and heading noise, at the same step.

    Raises
    ------
    ValueError
        A filter that is not factored, or filters that differ in their view, heading noise,
        robots or step.
    """

    def __init__(self, filters) -> None:
        self.filters = list(filters)
        first = self.filters[0]
        for f in self.filters:
            if not self.stackable([f]):
                raise ValueError(f"a stack steps factored filters only, not '{f.mode}'")
            same = (
                f.n_robots == first.n_robots and f.n_states == first.n_states
                and f.heading_noise == first.heading_noise and f.t == first.t
                and np.array_equal(f.visible, first.visible)
            )  # fmt: skip
            if not same:
                raise ValueError("stacked filters differ in robots, view, heading noise or step")
        self.team = StackedFactoredTeams([f.form.team for f in self.filters])  # type: ignore[attr-defined]
        self._post: np.ndarray | None = None  # the last update's beliefs, (M, N, S)
        self._views: list[np.ndarray] = []

    @staticmethod
    def stackable(filters) -> bool:
        """Whether ``filters`` are all factored (the form a stack steps).

        Parameters
        ----------
        filters : sequence of BeliefFilter
            The filters.

        Returns
        -------
        bool
            True when every filter holds per-robot marginals.
        """
        return all(isinstance(f.form, FactoredBelief) for f in filters)

    @property
    def t(self) -> int:
        """The filters' current step (-1 before the first)."""
        return self.filters[0].t

    def update(self, observed) -> None:
        """:meth:`BeliefFilter.update` of every filter.

        Parameters
        ----------
        observed : array_like of int, shape (N,)
            As for :meth:`BeliefFilter.update`.
        """
        first = self.filters[0]
        if first.belief is None:
            prior = np.stack([f.form.uniform() for f in self.filters])
        else:
            beliefs = [f.belief for f in self.filters]
            ours = self._post is not None and all(
                b is v for b, v in zip(beliefs, self._views, strict=True)
            )  # unless a filter was stepped alone, its belief is a row of the last update's
            stacked = self._post if ours and self._post is not None else np.stack(beliefs)
            prior = self.team.propagate(stacked)
        ev = first.evidence(observed)
        post = prior * np.stack(ev)
        z = post.sum(axis=-1)  # each row's own sum, as _condition takes it
        impossible = z <= 1e-300
        post /= np.where(impossible, 1.0, z)[..., None]
        for m, i in zip(*np.nonzero(impossible), strict=True):
            post[m, i] = _condition(prior[m, i], ev[i])[0]
        bad = impossible.sum(axis=1)
        self._post, self._views = post, list(post)
        for m, f in enumerate(self.filters):
            f.belief = self._views[m]
            f.fallbacks += int(bad[m])
            f.t += 1


def _chosen_form(
    n_robots: int, n_states: int, joint: bool | None, max_joint_states: int, mode: str | None
) -> type[BeliefForm]:
    """The form of :class:`BeliefFilter`'s arguments: ``mode``'s, or by default the exact joint
    while S^N is at most ``max_joint_states`` (the pair's for two robots) and the factored
    marginals beyond."""
    if mode is not None:
        form = BELIEF_MODES.lookup(mode)
        if joint is not None and bool(joint) != form.joint:
            raise ValueError(f"belief mode '{mode}' is {'' if form.joint else 'not '}joint")
        if not form.min_robots <= n_robots <= (form.max_robots or n_robots):
            raise ValueError(f"belief mode '{mode}' does not track {n_robots} robots")
    else:
        if joint is None:
            joint = n_states**n_robots <= max_joint_states
        if not joint or n_robots == 1:  # one robot's marginal is its joint
            form = FactoredBelief
        else:
            form = PairBelief if n_robots == 2 else TeamBelief
    if form.joint and n_robots > 2 and n_states**n_robots > MAX_EXACT_STATES:
        raise ValueError(
            f"an exact joint of {n_robots} patrollers needs {n_states}^{n_robots} "
            f"states (limit {MAX_EXACT_STATES:,}); use the factored filter (joint=False)"
        )
    return form


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
