"""How sure L is of each part: a 95 % interval per transition feature and a fault verdict per robot
(docs/design.md, "Fault verdicts").

The evidence is each observed step (s, s') of a robot, explained by L's policy and a model of
motion: p(s' | s) = Σ_a π_ε(a | s) T_m(s, a, s'; p), the action integrated over L's policy
(:mod:`mirl.learning.motion_models`), over every candidate model m of where failed steps end
and whether a turn needs a wheel, the models weighed by their marginal likelihood and the
verdict averaged over them. Around that:

* **The record checked first.** Steps no action explains, stalls, jams with another robot
  and fits pinned by few trials (:mod:`mirl.learning.model_check`). Steps a failed check
  points at are left out — never failures of a part — and the verdict says that the record
  does not fit; it then gives L's models even odds (:data:`MODEL_TRUST`) and the prior the
  rest, so it claims nothing at high confidence.
* **Robots in the way.** A step with another robot in the robot's cell or up to two cells
  ahead of it, at the step's start or end, is left out of the evidence and the drift: a
  physical robot there blocks, pushes or slows it, and on a grid such steps are few.
  :func:`held_by_others`.
* **Clustered failures.** Failures come in runs (a robot on a wall, a robot queueing behind
  another), so steps are not independent trials. The lag-1 autocorrelation ρ of the
  standardised outcome residuals gives the variance inflation (1 + ρ)/(1 − ρ) of an AR(1)
  process, and the steps' log-likelihood is divided by it (a quasi-likelihood dispersion,
  McCullagh & Nelder 1989, Sec. 4.5). :func:`failure_dispersion`.
* **Drift.** Step outcomes cannot tell a differential drive's wheels apart when only forward
  steps fail (they need both wheels). Poses can: a robot veers towards its weaker wheel, so
  robot data (poses, not grid states) carry the mean lateral offset of its forward steps from
  the hallway's centre line (:attr:`~mirl.observations.trajectories.Trajectories.lateral`),
  which enters as one more likelihood term: offset ~ N(κ (p_right − p_left), se² + τ²), κ the
  drift of a unit wheel gap: measured where the robots are known (the physical world's), else
  unknown with a half-normal prior (:class:`~mirl.world.faults.DriftSpec`).
  :func:`lateral_drift`, :func:`drift_log_likelihood`.

The prior says that most parts are healthy: for each feature, with probability 0.8 a
Beta(50 h, 50 (1 − h)) around its healthy level h, else uniform on [0, 1]. From the pooled
draws: each feature's central 95 % interval and median, and the probability of every set of
damaged parts (:class:`~mirl.world.faults.DamageDefinition`), from which
:func:`verdict_from_draws` makes the verdict.

.. versionchanged:: 0.2.0
   The evidence is the per-step likelihood under every candidate motion model, averaged, in
   place of soft-labelled success counts under the scenario's model; the record is checked
   before a verdict; steps in another robot's way are left out whatever the source.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.special import expit, log_ndtr

from mirl.learning.model_check import (
    MOVE_KINDS,
    Check,
    ModelFit,
    check_jams,
    check_moves,
    check_pace,
    check_pinned,
    check_record_length,
    check_slides,
    check_stalls,
    check_unexplained,
    held_back,
    no_pace_setter,
)
from mirl.learning.motion_models import (
    DEFAULT_PRIOR,
    N_DRAWS,
    MotionModel,
    MotionPosterior,
    PriorSpec,
    candidate_models,
    feature_log_prior,
    model_domain,
    motion_posterior,
    sample_feature_prior,
    unexplained_steps,
    wheels_of,
)
from mirl.learning.smc import tempered_smc
from mirl.observations.trajectories import Trajectories
from mirl.world.domain import FORWARD, TURN_LEFT, TURN_RIGHT, PatrolDomain
from mirl.world.faults import DEFAULT_HEALTHY, WHEELS, DamageDefinition, DriftSpec
from mirl.world.maps import HEADING_DELTAS

__all__ = [
    "Verdict",
    "also_field",
    "parse_also_field",
    "FeatureUncertainty",
    "PriorSpec",
    "LateralDrift",
    "WHEELS",
    "MODEL_TRUST",
    "CONFIDENT",
    "NEVER_SEEN",
    "tempered_trust",
    "BLOCKING_DISTANCE",
    "held_by_others",
    "free_pace",
    "record_off_pace",
    "beside_others",
    "in_company",
    "lateral_drift",
    "drift_log_likelihood",
    "estimate_outside_interval",
    "weakened_wheel",
    "estimate_disagrees",
    "failure_dispersion",
    "action_distribution",
    "NEAR_TIE",
    "indistinguishable",
    "untested_features",
    "untested_words",
    "posterior_draws",
    "feature_uncertainty",
    "robot_uncertainty",
    "never_seen_moving",
    "verdict_from_draws",
    "point_verdict",
    "MOVING_ACTIONS",
    "confounded_parts",
    "TeamComparison",
    "forward_outcomes",
    "team_ratio",
    "below_probability",
    "compared_with_team",
]

LEVEL = 0.95
"""The intervals' coverage."""
COVERAGE_SLACK = 0.05
"""A verdict names the fewest parts that hold all but this much of the probability of damage."""
NOT_RULED_OUT = 0.01
"""A motion model holding at least this much of the weight (posterior odds of 1 : 99 or better
against the rest) is one the record does not rule out decisively (Jeffreys' "decisive"
evidence, a Bayes factor over 100): where two models fit the step outcomes alike and blame
different parts, their weights are the prior's, not the record's
(:func:`_common_parts_widened`)."""
MODEL_TRUST = 0.5
"""The weight L gives its motion models for a record that fails a check
(:mod:`mirl.learning.model_check`); the prior has the rest, and :func:`tempered_trust` lowers
it where a statement could otherwise reach :data:`CONFIDENT`."""
NEVER_SEEN = "L never saw it at two consecutive steps"
"""The model check's reason for a robot L never saw move: it has no verdict, and its
``confidence`` is the prior's probability that no part is damaged, a number of the prior and
not of the robot (:func:`never_seen_moving`)."""
CONFIDENT = 0.9
"""A verdict at least this probable is a confident one: a statement on a record that fails the
model check stays below it."""
MAX_AUTOCORRELATION = 0.95
"""The drift's lag-1 autocorrelation is clipped here: nearer 1, its variance inflation
(1 + ρ)/(1 − ρ) would grow without bound on a record of a robot standing still."""


@dataclass(frozen=True)
class Verdict:
    """What L concludes about one robot's parts.

    Parameters
    ----------
    part : str or None
        The damaged part; None when no part is damaged, L cannot tell which, or L has no
        verdict (it never saw the robot move).
    confidence : float
        The probability that the verdict is right: that ``part`` is damaged; that one of the
        ``candidates`` is; or, with neither, that no part is.
    candidates : tuple of str
        When L cannot tell which: the parts one (or more) of which is damaged.
    damage_probabilities : mapping of str to float
        Per feature, the probability that it is damaged.
    fit : ModelFit or None
        Whether the robot's record fits L's motion models (:mod:`mirl.learning.model_check`);
        None for verdicts not drawn from a record (the truth).
    seen_moving : bool, default True
        False when L never saw the robot at two consecutive steps: then it has no verdict, and
        ``confidence`` is the prior's probability that no part is damaged.
    weakened : str or None
        A wheel the robot's drift shows to be weaker than the other where the verdict does not
        call it damaged: weakened, its moves unaffected (:func:`weakened_wheel`).
    beside : TeamComparison or None
        The robot's forward steps against those of another robot of the same record, where
        that comparison set the verdict (:func:`compared_with_team`).

        .. versionchanged:: 0.2.0
           ``fit``, ``seen_moving``, ``weakened`` and ``beside`` are new.
    """

    part: str | None
    confidence: float
    candidates: tuple[str, ...] = ()
    damage_probabilities: Mapping[str, float] = field(default_factory=dict)
    fit: ModelFit | None = None
    seen_moving: bool = True
    weakened: str | None = None
    beside: TeamComparison | None = None

    @property
    def names_damage(self) -> bool:
        """Whether the verdict says some part is damaged (a part or candidates)."""
        return self.part is not None or bool(self.candidates)

    @property
    def named(self) -> tuple[str, ...]:
        """The parts the verdict says are (or may be) damaged."""
        return (self.part,) if self.part is not None else self.candidates

    @property
    def also(self) -> tuple[str, ...]:
        """Parts the verdict does not name that are more probably damaged than not, by
        decreasing probability (``damage_probabilities``): damaged besides the parts named —
        a second weak wheel, a common part whose failures the named part does not explain."""
        if not self.names_damage:
            return ()
        more = [(p, f) for f, p in self.damage_probabilities.items() if p > 0.5]
        return tuple(f for p, f in sorted(more, key=lambda x: -x[0]) if f not in self.named)

    def is_right(self, damaged: Sequence[str]) -> bool:
        """Whether the verdict is right when ``damaged`` are the truly damaged parts.

        Parameters
        ----------
        damaged : sequence of str
            The truly damaged parts (empty for a healthy robot).

        Returns
        -------
        bool
            With a part or candidates named: whether one of them is damaged; naming none:
            whether no part is.
        """
        if not self.names_damage:
            return not damaged
        return any(p in damaged for p in self.named)

    def to_dict(self) -> dict:
        """The verdict as a JSON-ready record (``mirl learn --json``).

        Returns
        -------
        dict
            ``part``, ``confidence`` and ``damage_probabilities`` (rounded to 4 decimals),
            ``candidates``; ``seen_moving`` (only when False), ``also``, ``weakened``, ``fit``
            and ``beside`` only when set.
        """
        out = {
            "part": self.part,
            "confidence": round(float(self.confidence), 4),
            "candidates": list(self.candidates),
            "damage_probabilities": {
                k: round(float(v), 4) for k, v in self.damage_probabilities.items()
            },
        }
        if not self.seen_moving:
            out["seen_moving"] = False
        if self.also:
            out["also"] = list(self.also)
        if self.weakened is not None:
            out["weakened"] = self.weakened
        if self.fit is not None:
            out["fit"] = self.fit.to_dict()
        if self.beside is not None:
            out["beside"] = self.beside.to_dict()
        return out

    def sentence(self, robot: str) -> str:
        """The verdict in words: "J's left wheel is damaged (confidence 0.97)".

        Parameters
        ----------
        robot : str
            The robot's name.

        Returns
        -------
        str
            The sentence, with the weakened wheel and a record that does not fit where they
            apply.
        """
        if not self.seen_moving:
            return f"L never saw {robot} move: no verdict on its parts"
        conf = f"(confidence {self.confidence:.2f})"
        if self.part is not None:
            said = f"{robot}'s {_words(self.part)} is damaged {conf}"
        elif not self.candidates:
            said = f"no part of {robot} is damaged {conf}"
        else:
            wheels = all(c.endswith("_wheel") for c in self.candidates)
            if wheels and len(self.candidates) == 2:
                what = f"one of {robot}'s wheels is weak (or both)"
            else:
                parts = ", ".join(map(_words, self.candidates))
                what = f"one of {robot}'s parts ({parts}) is damaged"
            said = f"{what}; the observations cannot tell which {conf}"
        if self.also:
            parts = " and ".join(map(_words, self.also))
            odds = ", ".join(f"{self.damage_probabilities[f]:.2f}" for f in self.also)
            verb = "is" if len(self.also) == 1 else "are"
            said += f"; its {parts} {verb} probably damaged too ({odds})"
        if self.weakened is not None:  # "unaffected" is the verdict's, as far as the record fits
            said += f"; its {_words(self.weakened)} is weakened" + (
                ", its moves unaffected" if self.fit is None or self.fit.ok else ""
            )
        if self.beside is not None:
            said += f"; {self.beside.sentence()}"
        if self.fit is not None and not self.fit.ok:
            said += f"; but {robot}'s record does not fit L's motion models: {self.fit.reason}"
        return said


def also_field(verdict: Verdict) -> str:
    """:attr:`Verdict.also` as a sweep stores it: ``PART=P`` comma-separated, P its probability
    of damage (empty for none); :func:`parse_also_field` reads it back.

    Parameters
    ----------
    verdict : Verdict
        The verdict.

    Returns
    -------
    str
        The stored form.
    """
    return ",".join(f"{f}={verdict.damage_probabilities[f]:g}" for f in verdict.also)


def parse_also_field(text: object) -> tuple[tuple[str, float], ...]:
    """A stored :func:`also_field` (empty or None for none) as (part, probability) pairs.

    Parameters
    ----------
    text : object
        The stored value.

    Returns
    -------
    tuple of (str, float)
        The parts and their probabilities of damage.
    """
    pairs = (x.split("=") for x in str(text or "").split(",") if x)
    return tuple((f, float(v)) for f, v in pairs)


def _words(feature: str) -> str:
    return feature.replace("_", " ")


@dataclass(frozen=True)
class FeatureUncertainty:
    """One robot's intervals and verdict, with how they were obtained.

    Parameters
    ----------
    intervals : mapping of str to (float, float)
        Per feature, the central 95 % posterior interval of its success probability.
    verdict : Verdict
        The robot's fault verdict.
    dispersion : float
        The variance inflation the steps' log-likelihood was divided by (1: independent steps).
    effective_draws : float
        The effective sample size (Kish) of the pooled draws.
    drift : LateralDrift or None
        The lateral drift that entered the posterior (None: no poses, or too few steps).
    medians : mapping of str to float
        Per feature, the posterior median: the posterior's answer.
    motion_models : mapping of str to float
        Each candidate motion model's posterior probability
        (:class:`~mirl.learning.motion_models.MotionModel` names); empty for a verdict not
        drawn from a record.
    indistinguishable : tuple of tuple of str
        Groups of features the robot's steps cannot tell apart under the model Eq. 4 was
        learned with: they enter the same observed feature subsets, so Eq. 4 gives them one
        value (its maximisers are mirror images of each other).
    sided_by_drift : bool
        Whether the two wheels form such a group and the robot's drift tells them apart.
    log_evidence : float
        The log marginal likelihood of the robot's kept steps (and drift) under L's policy,
        averaged over the motion models with equal prior odds.
    forward_steps : (int, int)
        The successes and trials of the robot's forward-labelled steps among those the verdict's
        evidence holds (:func:`compared_with_team`).
    untested : tuple of str
        Features no step the verdict's evidence holds could test (:func:`untested_features`):
        their draws, intervals and share of the verdict are the prior's.

        .. versionchanged:: 0.2.0
           ``medians``, ``motion_models``, ``indistinguishable``, ``sided_by_drift``,
           ``log_evidence``, ``forward_steps`` and ``untested`` are new.
    """

    intervals: Mapping[str, tuple[float, float]]
    verdict: Verdict
    dispersion: float = 1.0
    effective_draws: float = 0.0
    drift: LateralDrift | None = None
    medians: Mapping[str, float] = field(default_factory=dict)
    motion_models: Mapping[str, float] = field(default_factory=dict)
    indistinguishable: tuple[tuple[str, ...], ...] = ()
    sided_by_drift: bool = False
    log_evidence: float = 0.0
    forward_steps: tuple[int, int] = (0, 0)
    untested: tuple[str, ...] = ()


@dataclass(frozen=True)
class LateralDrift:
    """A robot's mean lateral offset on its forward steps (cells, left of the heading positive).

    Parameters
    ----------
    mean : float
        The mean offset (cells, left of the heading positive).
    se : float
        Its standard error, inflated for the correlation of consecutive steps.
    steps : int
        The forward steps it is the mean of.
    """

    mean: float
    se: float
    steps: int

    def to_dict(self) -> dict:
        """The drift as a JSON-ready record (``mirl learn --json``).

        Returns
        -------
        dict
            ``mean`` and ``se`` (rounded to 4 decimals) and ``steps``.
        """
        return {"mean": round(self.mean, 4), "se": round(self.se, 4), "steps": self.steps}

    def sentence(self) -> str:
        """The drift in words: "0.125 cell to the right of the centre line (± 0.008) on 313
        forward steps".

        Returns
        -------
        str
            The sentence.
        """
        side = "left" if self.mean > 0 else "right"
        return (
            f"{abs(self.mean):.3f} cell to the {side} of the centre line (± {self.se:.3f}) on "
            f"{self.steps} forward steps"
        )


# ---- the evidence -----------------------------------------------------------------------------
def failure_dispersion(
    domain: PatrolDomain,
    t: np.ndarray,
    s: np.ndarray,
    labels: np.ndarray,
    s_next: np.ndarray,
    probabilities: Mapping[str, float],
    cap: float = 4.0,
) -> float:
    """The variance inflation (1 + ρ)/(1 − ρ) of the step outcomes.

    ρ is the lag-1 autocorrelation of the outcomes' standardised residuals under
    ``probabilities``, over pairs of consecutive labelled steps.

    Parameters
    ----------
    domain : PatrolDomain
        The domain the labels were learned under (its ξ and intended states).
    t : ndarray of int, shape (n,)
        The robot's observed steps' times: step k goes from state ``s[k]`` at ``t[k]`` to
        ``s_next[k]`` at ``t[k] + 1``.
    s : ndarray of int, shape (n,)
        Their start states.
    labels : ndarray of int, shape (n,)
        Their action labels (-1: none; such steps are left out).
    s_next : ndarray of int, shape (n,)
        Their end states.
    probabilities : mapping of str to float
        Each feature's success probability.
    cap : float, default 4.0
        The largest inflation returned.

    Returns
    -------
    float
        The inflation, in [1, ``cap``]: 1 when ρ ≤ 0, or with fewer than 10 labelled steps or
        10 consecutive pairs.
    """
    t, s, labels, s_next = (np.asarray(v, dtype=int) for v in (t, s, labels, s_next))
    keep = labels >= 0
    t, s, labels, s_next = t[keep], s[keep], labels[keep], s_next[keep]
    if len(t) < 10:
        return 1.0
    success = domain.success_probabilities(probabilities)[s, labels]
    hit = (domain.intended[s, labels] == s_next).astype(float)
    sd = np.sqrt(np.clip(success * (1 - success), 1e-3, None))
    rho = _lag1_autocorrelation((hit - success) / sd, t, min_pairs=10)
    if rho is None:
        return 1.0
    rho = min(rho, 0.99)
    return float(np.clip((1 + rho) / (1 - rho), 1.0, cap))


def _lag1_autocorrelation(z: np.ndarray, times: np.ndarray, min_pairs: int) -> float | None:
    """The lag-1 autocorrelation of residuals ``z`` over the pairs of consecutive ``times``
    (an AR(1) process's ρ, whose variance inflation is (1 + ρ)/(1 − ρ)); None with fewer than
    ``min_pairs`` such pairs or no variance."""
    pair = np.flatnonzero(np.diff(times) == 1)
    if len(pair) < min_pairs or float(z @ z) <= 0:
        return None
    return float(z[pair] @ z[pair + 1]) / float(z @ z) * len(z) / len(pair)


def _seen_together(
    domain: PatrolDomain, series: Sequence[np.ndarray], robot: int
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per other robot: the (horizon,) steps at which L saw it and robot ``robot`` both, and
    the (row, col, heading) of ``robot`` and of the other at those steps."""
    own = np.asarray(series[robot])
    for j, other in enumerate(series):
        if j == robot:
            continue
        both = (own >= 0) & (np.asarray(other) >= 0)
        yield both, domain.states[own[both]], domain.states[np.asarray(other)[both]]


def in_company(
    domain: PatrolDomain, series: Sequence[np.ndarray], robot: int, distance: float
) -> np.ndarray:
    """The steps at which L saw another robot near a robot, not going its way.

    Robots passing each other keep to one side, and so do robots crossing: a physical robot
    keeps right of one whose heading differs from its own by more than a right angle
    (:func:`mirl.physics.control.in_company`), which a crossing robot's turns and yaw noise
    make it half the time. A robot following or leading another does not pass it and drives
    the middle, so those steps are not company.

    .. versionchanged:: 0.2.0
       A crossing robot (heading at a right angle) is company too, not only one coming the
       other way: the healthy K of boydright-3, whose branch crosses I's and J's hallway,
       kept right on those steps and read as a robot veering to its right wheel.

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain (its states' cells and headings).
    series : sequence of ndarray of int, shape (horizon,)
        Every robot's observed states, -1 where unseen.
    robot : int
        The robot's index in ``series``.
    distance : float
        How near (cells, centre to centre) the other robot must be.

    Returns
    -------
    ndarray of bool, shape (horizon,)
        Whether, both seen, another robot with another heading (coming the other way or
        crossing) was within ``distance`` cells of the robot, ahead of it or alongside
        (within 110° of its heading, so until they have passed).
    """
    own = np.asarray(series[robot])
    near = np.zeros(len(own), dtype=bool)
    for both, a, b in _seen_together(domain, series, robot):
        v = (b[:, :2] - a[:, :2]).astype(float)
        dist = np.hypot(*v.T)
        ahead = (v * HEADING_DELTAS[a[:, 2]]).sum(axis=1) >= np.cos(np.radians(110)) * dist
        other_way = b[:, 2] != a[:, 2]
        near[both] |= (dist <= distance) & other_way & ahead
    return near


BLOCKING_DISTANCE = 2.0
"""Cells (centre to centre): how near ahead another robot can be, at a step's start or end,
for the step's outcome to be its doing. The cell ahead is where a robot collides with one
standing there or arriving there during the step; two cells ahead, one coming the other way
meets it in the cell between, and one going the same way that the robot has caught up with
holds it there (a slow robot's discretised cell lags its body, which already fills the gap)."""
BLOCKING_BEARING = 70.0
"""Degrees either side of a robot's heading within which another robot is ahead of it (the
physical controller's ``AHEAD_BEARING``: what a robot slows for)."""


def held_by_others(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    robot: int,
    distance: float = BLOCKING_DISTANCE,
) -> np.ndarray:
    """The steps whose outcome another robot L saw may explain: at the step's start or its
    end, another robot in the robot's cell, or within ``distance`` cells ahead of it.

    A physical robot there is in the way (it blocks, pushes or slows the robot), so what the
    step does is not the robot's parts' doing. The steps are chosen by where the other robots
    are, never by what the step did, so leaving them all out of the evidence biases nothing:
    it only costs the trials they would have been (few on a grid, where robots seldom meet).
    Where the other robot stands is read against the robot's cell and heading at the step's
    start, the move it was making; at the end, the other robot may have come into the cell
    the robot was heading for. A robot L lost sight of for that moment (it went on into a
    cell L does not see) counts where L saw it a step before (after), one cell nearer.

    .. versionchanged:: 0.2.0
       The other robot counts up to ``distance`` cells ahead (not the cell ahead alone) and at
       the step's end as well as its start.

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain (its states' cells and headings).
    series : sequence of ndarray of int, shape (horizon,)
        Every robot's observed states, -1 where unseen.
    robot : int
        The robot's index in ``series``.
    distance : float, default BLOCKING_DISTANCE
        How near (cells, centre to centre) ahead of the robot, within
        :data:`BLOCKING_BEARING` of its heading, the other robot must be.

    Returns
    -------
    ndarray of bool, shape (horizon,)
        Whether, the robot seen at the step's start (time t; the step goes to t + 1), another
        robot seen at t or t + 1 was in the robot's cell at t or ahead of it within
        ``distance`` cells; where L did not see the other robot at t (t + 1), its cell at
        t − 1 (t + 2) counts, within ``distance`` − 1 cells, since a robot moves at most one
        cell a step. False at the last time, where no step starts.
    """
    own = np.asarray(series[robot])
    n = len(own)
    held = np.zeros(n, dtype=bool)
    cos_bearing = np.cos(np.radians(BLOCKING_BEARING))
    seen = own >= 0
    a = domain.states[np.where(seen, own, 0)]
    forward = HEADING_DELTAS[a[:, 2]]
    times = np.arange(n)

    def in_the_way(other: np.ndarray, at: np.ndarray, reach: float) -> np.ndarray:
        """Whether ``other``, seen at times ``at`` (-1: no time), is within ``reach`` cells
        ahead of the robot at each step's start, or in its cell."""
        ok = (at >= 0) & (at < n)
        b_state = np.where(ok, other[np.clip(at, 0, n - 1)], -1)
        b = domain.states[np.where(b_state >= 0, b_state, 0)]
        v = (b[:, :2] - a[:, :2]).astype(float)
        dist = np.hypot(v[:, 0], v[:, 1])
        ahead = (v * forward).sum(axis=1) >= cos_bearing * dist
        return seen & (b_state >= 0) & ((dist == 0) | ((dist <= reach) & ahead))

    for j, other in enumerate(series):
        if j == robot:
            continue
        other = np.asarray(other)
        # at the step's start (t) and end (t + 1); unseen then, a step earlier or later with a
        # cell less reach (a robot moves at most one cell a step)
        for at, beside in ((times, times - 1), (times + 1, times + 2)):
            unseen = (at >= n) | (other[np.clip(at, 0, n - 1)] < 0)
            held |= in_the_way(other, np.where(at < n, at, -1), distance)
            held |= unseen & in_the_way(other, beside, distance - 1)
    held[-1:] = False  # no step starts at the last time
    return held


def free_pace(domain: PatrolDomain, series: Sequence[np.ndarray], robot: int) -> tuple[int, int]:
    """A robot's free steps that kept its heading: how many stayed in its cell and how many
    moved to the next (its pace, :func:`~mirl.learning.model_check.no_pace_setter`).

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain (its states' cells and headings).
    series : sequence of ndarray of int, shape (horizon,)
        Every robot's observed states, -1 where unseen.
    robot : int
        The robot's index in ``series``.

    Returns
    -------
    stayed : int
        The steps, seen at both ends and with no other robot L saw in the robot's way
        (:func:`held_by_others`), that kept the robot's heading and stayed in its cell.
    moved : int
        Those of the same steps that moved it one cell.
    """
    own = np.asarray(series[robot])
    start, end = own[:-1], own[1:]
    both = (start >= 0) & (end >= 0)
    a = domain.states[np.where(both, start, 0)]
    b = domain.states[np.where(both, end, 0)]
    cells = np.abs(b[:, :2] - a[:, :2]).sum(axis=1)
    free = both & ~held_by_others(domain, series, robot)[:-1] & (a[:, 2] == b[:, 2])
    return int((free & (cells == 0)).sum()), int((free & (cells == 1)).sum())


def record_off_pace(
    domain: PatrolDomain, observations: Trajectories, series: Sequence[np.ndarray]
) -> str | None:
    """Why the step a record was read at may be no healthy robot's pace, for the model check's
    pace check (:func:`~mirl.learning.model_check.check_pace`): the poses' own reason
    (:attr:`~mirl.observations.trajectories.Trajectories.off_pace`), or, for a record read at
    its tracker's interval or at a step the user gave, that no robot moves a cell on most of its
    free steps (:func:`~mirl.learning.model_check.no_pace_setter`).

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain.
    observations : Trajectories
        The record.
    series : sequence of ndarray of int, shape (horizon,)
        Every robot's observed states, -1 where unseen, in ``observations``' robot order.

    Returns
    -------
    str or None
        The reason; "" when nothing says so; None for grid states, which carry no pace.
    """
    interval, given = observations.tracker_interval, observations.step_given
    if observations.off_pace or (interval is None and given is None):
        return observations.off_pace
    steps = {
        observations.robot_names[i]: free_pace(domain, series, i) for i in range(len(series))
    }
    if interval is not None:
        return no_pace_setter(steps, interval)
    assert given is not None  # one of the two, by the test above
    return no_pace_setter(steps, given, given=True)


def beside_others(domain: PatrolDomain, series: Sequence[np.ndarray], robot: int) -> np.ndarray:
    """The steps at which L saw another robot within one cell of a robot: where touching robots
    jam (:func:`~mirl.learning.model_check.check_jams`).

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain (its states' cells and headings).
    series : sequence of ndarray of int, shape (horizon,)
        Every robot's observed states, -1 where unseen.
    robot : int
        The robot's index in ``series``.

    Returns
    -------
    ndarray of bool, shape (horizon,)
        Whether, both seen, another robot was in the robot's cell or any of the eight around
        it.
    """
    own = np.asarray(series[robot])
    near = np.zeros(len(own), dtype=bool)
    for both, a, b in _seen_together(domain, series, robot):
        near[both] |= (np.abs(b[:, :2] - a[:, :2]) <= 1).all(axis=1)
    return near


def lateral_drift(
    domain: PatrolDomain,
    t: np.ndarray,
    s: np.ndarray,
    labels: np.ndarray,
    s_next: np.ndarray,
    lateral: np.ndarray,
    company: np.ndarray | None = None,
    min_steps: int = 5,
) -> LateralDrift | None:
    """The mean lateral offset at the end of a robot's observed forward steps that arrived in
    the cell ahead and drove alone.

    A step starting or ending in company is left out, because robots passing each other keep
    to one side, which is no wheel's doing; so is a forward step that failed (a robot stuck
    against a wall is off the centre line for the wall's reason, step after step).
    Consecutive offsets of one robot are correlated (a robot off the centre line stays off it
    for a while): the standard error is inflated by (1 + ρ)/(1 − ρ), ρ their lag-1
    autocorrelation clipped to [0, :data:`MAX_AUTOCORRELATION`].

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain.
    t : ndarray of int, shape (n,)
        The robot's observed steps' times: step k goes from state ``s[k]`` at ``t[k]`` to
        ``s_next[k]`` at ``t[k] + 1``.
    s : ndarray of int, shape (n,)
        Their start states.
    labels : ndarray of int, shape (n,)
        Their action labels (-1: none; such steps are left out).
    s_next : ndarray of int, shape (n,)
        Their end states.
    lateral : ndarray of float, shape (horizon,)
        The robot's lateral offset (cells, left of the heading positive) at each step; NaN
        where unknown (such steps are left out).
    company : ndarray of bool, shape (horizon,), optional
        The steps at which another robot was near it (:func:`in_company`).
    min_steps : int, default 5
        The fewest forward steps a drift is the mean of.

    Returns
    -------
    LateralDrift or None
        The drift; None with fewer than ``min_steps`` steps kept.
    """
    t, s, labels, s_next = (np.asarray(v, dtype=int) for v in (t, s, labels, s_next))
    y = np.asarray(lateral, dtype=float)[t + 1]
    arrived = domain.intended[s, FORWARD] == s_next
    keep = (labels == FORWARD) & arrived & np.isfinite(y)
    if company is not None:
        company = np.asarray(company, dtype=bool)
        keep &= ~(company[t] | company[t + 1])
    times, y = t[keep] + 1, y[keep]
    n = len(y)
    if n < min_steps:
        return None
    mean = float(y.mean())
    rho = _lag1_autocorrelation(y - mean, times, min_pairs=min_steps)
    rho = 0.0 if rho is None else float(np.clip(rho, 0.0, MAX_AUTOCORRELATION))
    se = float(y.std(ddof=1) * np.sqrt((1 + rho) / (1 - rho) / n))
    return LateralDrift(mean, se, n)


def drift_log_likelihood(
    gap: np.ndarray, drift: LateralDrift, spec: DriftSpec = DriftSpec()
) -> np.ndarray:
    """log p(drift | gap) for wheel gaps ``gap`` = p_right − p_left, κ integrated out.

    With offset = κ · gap + ε, ε ~ N(0, s²), s² = se² + tolerance²:

    * κ measured (``spec.per_gap`` = m, κ ~ N(m, (spread · m)²)): the offset is normal,
      N(m · gap, gap² (spread · m)² + s²) (κ's normal prior stands in for one truncated at 0,
      which it is within 3.3 standard deviations at the default spread);
    * κ unknown (κ ~ N⁺(0, scale²)): the offset is skew-normal (Azzalini 1985),
      2 φ(x; 0, v) Φ(α x / √v), v = gap² scale² + s², α = gap · scale / s.

    A gap of 0 (both wheels alike) gives N(0, s²) either way: no drift expected.

    Parameters
    ----------
    gap : array_like of float
        Wheel gaps p_right − p_left, any shape.
    drift : LateralDrift
        The robot's drift: its mean is the offset x, its standard error enters s.
    spec : DriftSpec, default DriftSpec()
        The prior of κ and the tolerance τ.

    Returns
    -------
    ndarray of float
        log p(drift | gap), of ``gap``'s shape.
    """
    gap = np.asarray(gap, dtype=float)
    s2 = drift.se**2 + spec.tolerance**2
    x = drift.mean
    if spec.per_gap is not None:
        v = gap**2 * (spec.spread * spec.per_gap) ** 2 + s2
        return -0.5 * np.log(2 * np.pi * v) - (x - spec.per_gap * gap) ** 2 / (2 * v)
    v = gap**2 * spec.scale**2 + s2
    alpha = gap * spec.scale / np.sqrt(s2)
    return (
        np.log(2.0) - 0.5 * np.log(2 * np.pi * v) - x**2 / (2 * v)
        + log_ndtr(alpha * x / np.sqrt(v))
    )  # fmt: skip


def weakened_wheel(
    drift: LateralDrift | None, spec: DriftSpec, named: Sequence[str], z: float = 2.0
) -> str | None:
    """The wheel a robot's drift shows weaker than the other where the verdict names no part:
    a motor weaker than the other that still drives the robot's steps.

    Parameters
    ----------
    drift : LateralDrift or None
        The robot's drift (None: no poses, or too few steps).
    spec : DriftSpec
        The drift specification, whose tolerance τ a healthy robot's drift may have.
    named : sequence of str
        The parts the verdict names (:attr:`Verdict.named`).
    z : float, default 2.0
        How many standard deviations of a healthy robot's drift (its standard error and τ
        combined) the drift must exceed.

    Returns
    -------
    str or None
        The wheel the robot veers towards (``"left_wheel"`` for a drift to the left), when
        ``named`` is empty and the drift exceeds ``z`` standard deviations; None otherwise.
    """
    if drift is None or named:
        return None
    if abs(drift.mean) <= z * np.hypot(drift.se, spec.tolerance):
        return None
    return WHEELS[0] if drift.mean > 0 else WHEELS[1]


def estimate_outside_interval(
    probabilities: Mapping[str, float],
    intervals: Mapping[str, tuple[float, float]],
    slack: float = 0.05,
) -> bool:
    """Whether some point estimate lies more than ``slack`` outside its 95 % interval (max
    entropy's 1.000 against a posterior's 0.99 is not worth a word).

    Parameters
    ----------
    probabilities : mapping of str to float
        Eq. 4's estimate of each feature's success probability.
    intervals : mapping of str to (float, float)
        Each feature's 95 % interval; features without an estimate are passed over.
    slack : float, default 0.05
        How far outside its interval an estimate may lie.

    Returns
    -------
    bool
        Whether some estimate lies below ``lo - slack`` or above ``hi + slack``.
    """
    return any(
        not lo - slack <= probabilities[f] <= hi + slack
        for f, (lo, hi) in intervals.items()
        if f in probabilities
    )


def estimate_disagrees(
    probabilities: Mapping[str, float],
    intervals: Mapping[str, tuple[float, float]],
    medians: Mapping[str, float],
    definition: DamageDefinition,
) -> bool:
    """Whether Eq. 4's estimates and the posterior give two answers: an estimate well outside
    its 95 % interval (:func:`estimate_outside_interval`), or one that reads a part as damaged
    (or healthy) where the posterior's median does not — the verdict follows the posterior, so
    the report then shows the posterior's medians as the answer (docs/design.md, "Fault
    verdicts").

    Parameters
    ----------
    probabilities : mapping of str to float
        Eq. 4's estimate of each feature's success probability.
    intervals : mapping of str to (float, float)
        Each feature's 95 % posterior interval.
    medians : mapping of str to float
        Each feature's posterior median.
    definition : DamageDefinition
        What "damaged" means.

    Returns
    -------
    bool
        Whether the two give different answers.
    """
    if estimate_outside_interval(probabilities, intervals):
        return True
    return any(
        definition.damaged(f, probabilities[f]) != definition.damaged(f, m)
        for f, m in medians.items()
        if f in probabilities
    )


# ---- the posterior of pooled counts -----------------------------------------------------------
def _pooled_log_likelihood(x, incidence, successes, failures) -> np.ndarray:
    """Pooled binomial log-likelihood of logit-space draws (n, F) (Eq. 2)."""
    z = (-np.logaddexp(0, -x)) @ incidence.T  # (n, m) log success of each subset
    log_fail = np.log(-np.expm1(np.minimum(z, -1e-12)))
    return z @ successes + log_fail @ failures


def posterior_draws(
    features: Sequence[str],
    observations: Sequence[tuple[Sequence[str], float, float]],
    healthy: Mapping[str, float],
    *,
    prior: PriorSpec = DEFAULT_PRIOR,
    drift: LateralDrift | None = None,
    drift_spec: DriftSpec = DriftSpec(),
    n_draws: int = 2000,
    random_state: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted draws of the features' success probabilities given pooled counts — each
    labelled step a success or failure of its subset, one model of motion — and a lateral
    drift, when the features include both :data:`WHEELS`. The records' verdicts weigh each
    step under every candidate model instead (:func:`robot_uncertainty`); this is the same
    posterior for counts already pooled.

    Parameters
    ----------
    features : sequence of str
        The features, in the order of the draws' columns.
    observations : sequence of (subset, successes, trials)
        Per feature subset (a sequence of feature names), the successes and trials of its
        steps. Counts may be fractional (a dispersion divided out).
    healthy : mapping of str to float
        Each feature's healthy level (the prior's centre;
        :data:`~mirl.world.faults.DEFAULT_HEALTHY` for one it does not name).
    prior : PriorSpec, default DEFAULT_PRIOR
        The features' prior (:class:`~mirl.learning.motion_models.PriorSpec`).
    drift : LateralDrift, optional
        The robot's lateral drift (:func:`drift_log_likelihood`).
    drift_spec : DriftSpec, default DriftSpec()
        How a weak wheel drifts the robot.
    n_draws : int, default 2000
        The sampler's draws (:func:`~mirl.learning.smc.tempered_smc`).
    random_state : int, default 0
        The sampler's seed.

    Returns
    -------
    p : ndarray of shape (n_draws, F)
        Success probabilities, one row per draw.
    weights : ndarray of shape (n_draws,)
        Normalised weights (equal: the sampler's draws are unweighted).
    """
    features = tuple(features)
    F = len(features)
    pos = {f: i for i, f in enumerate(features)}
    incidence = np.zeros((len(observations), F))
    succ = np.zeros(len(observations))
    fail = np.zeros(len(observations))
    for j, (subset, k, n) in enumerate(observations):
        incidence[j, [pos[f] for f in subset]] = 1.0
        succ[j], fail[j] = float(k), float(n) - float(k)
    h = np.array([min(healthy.get(f, DEFAULT_HEALTHY), 0.999) for f in features])
    drift_term = _drift_term(features, drift, drift_spec)

    def log_lik(x):
        out = _pooled_log_likelihood(x, incidence, succ, fail)
        return out if drift_term is None else out + drift_term(expit(x))

    draws = tempered_smc(
        lambda rng, n: sample_feature_prior(rng, n, h, prior),
        lambda x: feature_log_prior(x, h, prior),
        log_lik,
        n_draws=n_draws,
        random_state=random_state,
    )
    return expit(draws.x), draws.weights


def _drift_term(features: Sequence[str], drift: LateralDrift | None, spec: DriftSpec):
    """The drift's log-likelihood as a function of success probabilities p (n, F), or None
    without a drift or without both wheels."""
    wheels = wheels_of(features)
    if drift is None or wheels is None:
        return None
    left, right = wheels

    def term(p: np.ndarray) -> np.ndarray:
        return drift_log_likelihood(p[:, right] - p[:, left], drift, spec)

    return term


# ---- the verdict ------------------------------------------------------------------------------
def verdict_from_draws(
    features: Sequence[str], p: np.ndarray, weights: np.ndarray, definition: DamageDefinition
) -> Verdict:
    """The verdict of weighted posterior draws ``p`` (n, F).

    No part is damaged when that is at least as probable as not. Otherwise the verdict names
    the fewest parts — by decreasing probability of damage — that hold all but
    :data:`COVERAGE_SLACK` of the probability that some part is damaged: one such part is the
    verdict, with the probability that it is damaged; several are "one of these, cannot tell
    which", with the probability that one of them is. Other parts more probably damaged than
    not are the verdict's :attr:`Verdict.also`: not alternatives to the parts named, which
    the draws already tell, but damaged besides them.

    Parameters
    ----------
    features : sequence of str
        The features, in the order of the draws' columns.
    p : ndarray of float, shape (n, F)
        Draws of the features' success probabilities.
    weights : ndarray of float, shape (n,)
        The draws' normalised weights.
    definition : DamageDefinition
        What "damaged" means.

    Returns
    -------
    Verdict
        The verdict, with each feature's probability of damage.
    """
    features = tuple(features)
    thresholds = np.array([definition.threshold(f) for f in features])
    damaged = p < thresholds  # (n, F)
    marginal = weights @ damaged
    probs = {f: float(m) for f, m in zip(features, marginal, strict=True)}
    p_none = float(weights @ ~damaged.any(axis=1))
    if p_none >= 0.5:
        return Verdict(None, p_none, (), probs)
    order = np.argsort(-marginal, kind="stable")
    chosen: list[int] = []
    covered = 0.0
    for k in order:
        if covered >= (1 - p_none) - COVERAGE_SLACK:
            break
        chosen.append(int(k))
        covered = float(weights @ damaged[:, chosen].any(axis=1))
    if len(chosen) == 1:
        return Verdict(features[chosen[0]], float(marginal[chosen[0]]), (), probs)
    names = tuple(features[k] for k in sorted(chosen))
    return Verdict(None, covered, names, probs)


def point_verdict(probabilities: Mapping[str, float], definition: DamageDefinition) -> Verdict:
    """The verdict of known probabilities (the truth): certain.

    Parameters
    ----------
    probabilities : mapping of str to float
        Each feature's true success probability.
    definition : DamageDefinition
        What "damaged" means.

    Returns
    -------
    Verdict
        The damaged part (or, with several, all of them as candidates; with none, no part) at
        confidence 1; damage probabilities 0 or 1.
    """
    damaged = definition.damaged_parts(probabilities)
    probs = {f: float(f in damaged) for f in probabilities}
    if len(damaged) == 1:
        return Verdict(damaged[0], 1.0, (), probs)
    return Verdict(None, 1.0, tuple(damaged), probs)


def feature_uncertainty(
    features: Sequence[str],
    observations: Sequence[tuple[Sequence[str], float, float]],
    definition: DamageDefinition,
    *,
    dispersion: float = 1.0,
    drift: LateralDrift | None = None,
    prior: PriorSpec = DEFAULT_PRIOR,
    n_draws: int = 2000,
    random_state: int = 0,
) -> FeatureUncertainty:
    """Intervals and verdict of one robot from its pooled counts (one model of motion) and,
    with poses, its lateral drift.

    Parameters
    ----------
    features : sequence of str
        The robot's features.
    observations : sequence of (subset, successes, trials)
        Per feature subset, the successes and trials of its steps (subsets without trials are
        left out).
    definition : DamageDefinition
        What "damaged" means (and the prior's healthy levels, and how a weak wheel drifts the
        robot).
    dispersion : float, default 1
        The counts are divided by it (:func:`failure_dispersion`).
    drift : LateralDrift, optional
        Its lateral drift (:func:`lateral_drift`).
    prior : PriorSpec, default DEFAULT_PRIOR
        The features' prior (:class:`~mirl.learning.motion_models.PriorSpec`).
    n_draws : int, default 2000
        The sampler's draws, passed to :func:`posterior_draws`.
    random_state : int, default 0
        The sampler's seed.

    Returns
    -------
    FeatureUncertainty
        The intervals, medians and verdict, with the dispersion, the effective number of
        draws and the drift.

    Raises
    ------
    ValueError
        A ``dispersion`` below 1.
    """
    if dispersion < 1:
        raise ValueError(f"`dispersion` must be at least 1, got {dispersion}")
    scaled = [(sub, k / dispersion, n / dispersion) for sub, k, n in observations if n > 0]
    healthy = {f: definition.healthy_level(f) for f in features}
    p, w = posterior_draws(
        features, scaled, healthy, prior=prior, drift=drift, drift_spec=definition.drift,
        n_draws=n_draws, random_state=random_state,
    )  # fmt: skip
    intervals, medians = _summaries(features, p, w)
    return FeatureUncertainty(
        intervals,
        verdict_from_draws(features, p, w, definition),
        dispersion=float(dispersion),
        effective_draws=float(1.0 / (w**2).sum()),
        drift=drift,
        medians=medians,
    )


def _summaries(features, p: np.ndarray, w: np.ndarray):
    """Each feature's central 95 % interval and median from weighted draws."""
    tail = (1 - LEVEL) / 2
    intervals, medians = {}, {}
    for i, f in enumerate(features):
        lo, mid, hi = _quantiles(p[:, i], w, (tail, 0.5, 1 - tail))
        intervals[f], medians[f] = (lo, hi), mid
    return intervals, medians


def _quantiles(values: np.ndarray, w: np.ndarray, qs) -> list[float]:
    order = np.argsort(values)
    cdf = np.cumsum(w[order])
    k = np.minimum(np.searchsorted(cdf, qs), len(values) - 1)
    return [float(v) for v in values[order[k]]]


# ---- one robot's record -------------------------------------------------------------------------
@dataclass(frozen=True)
class RobotRecord:
    """What L saw of one robot, as its verdict reads it.

    Parameters
    ----------
    series : ndarray of shape (horizon,)
        The robot's observed states, -1 where occluded.
    labels : ndarray of shape (horizon,)
        The labels its feature probabilities were learned from (-1: none).
    lateral : ndarray of shape (horizon,), optional
        Its lateral offsets (NaN unknown), from poses; None from grid states.
    company : ndarray of shape (horizon,), optional
        The steps at which another robot was near it (:func:`in_company`), left out of the
        drift.
    held : ndarray of shape (horizon,), optional
        The steps with another robot in its cell or ahead of it, at the step's start or end
        (:func:`held_by_others`), left out of the evidence and the drift.
    beside : ndarray of shape (horizon,), optional
        The steps with another robot within one cell (:func:`beside_others`), for the jam check.
    off_pace : str, optional
        Why the record's step may be no healthy robot's pace (empty: nothing says so), from
        poses; None from grid states
        (:attr:`~mirl.observations.trajectories.Trajectories.off_pace`).
    step_given : bool, default False
        Whether the user gave the record's step (``step_seconds``): then the step is no remedy
        for a failed pace check (:func:`~mirl.learning.model_check.check_pace`).
    """

    series: np.ndarray
    labels: np.ndarray
    lateral: np.ndarray | None = None
    company: np.ndarray | None = None
    held: np.ndarray | None = None
    beside: np.ndarray | None = None
    off_pace: str | None = None
    step_given: bool = False


def robot_record(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    labels: Sequence[np.ndarray],
    robot: int,
    *,
    lateral: np.ndarray | None = None,
    reach: float = 6.0,
    off_pace: str | None = None,
    step_given: bool = False,
) -> RobotRecord:
    """Robot ``robot``'s :class:`RobotRecord` from every robot's series (-1 unseen) and
    labels; ``reach`` is how far (cells) a robot reacts to another coming the other way (the
    patrollers' detection distance), for the drift's company; ``off_pace`` and
    ``step_given`` the record's (:attr:`RobotRecord.off_pace`,
    :attr:`RobotRecord.step_given`)."""
    return RobotRecord(
        np.asarray(series[robot]),
        np.asarray(labels[robot]),
        lateral,
        None if lateral is None else in_company(domain, series, robot, reach),
        held_by_others(domain, series, robot),
        beside_others(domain, series, robot),
        off_pace,
        step_given,
    )


FITTED_SHARE = 0.1
"""The moves check compares the record with the draws of the highest likelihood, this share of
each model's: the fit its parameters can make, the prior left aside (a record of a healthy
physical robot whose forward steps succeed more often than the prior's healthy levels is no
misfit of its moves)."""

CHECK_DRAWS = 100
"""Posterior draws the model check compares the record with."""

NEAR_TIE = 0.5
"""An action L's soft policy finds at least this fraction as likely as its most likely one is
one L cannot rule out (:func:`action_distribution`)."""


def action_distribution(
    s: np.ndarray,
    labels: np.ndarray,
    n_actions: int,
    soft_policy: np.ndarray | None = None,
    own_policy: np.ndarray | None = None,
) -> np.ndarray:
    """(n, A) L's policy at each step before its error ε is mixed in.

    Where the label is L's greedy policy's action (``own_policy``; every label, without it)
    and a soft policy is given: the actions the soft policy finds at least :data:`NEAR_TIE`
    as likely as its most likely one, and the label, in the soft policy's proportions — near
    ties L cannot break (a patrol's end turned by two left turns or two right ones). Not the
    whole soft policy: its temperature is fitted to the IRL's objective, not to how often a
    robot does something else, and on healthy physical robots it predicted three times the
    stops they made; ε, learned from the record, takes the rest
    (:mod:`mirl.learning.motion_models`). Elsewhere the label itself (the meeting rule's, a
    known policy's), and uniform where a step has none.

    Parameters
    ----------
    s : ndarray of int, shape (n,)
        The steps' start states.
    labels : ndarray of int, shape (n,)
        Their action labels (-1: none).
    n_actions : int
        A, the number of actions.
    soft_policy : ndarray of shape (S, A), optional
        L's learned maximum-entropy policy; without it, every labelled step gets its label.
    own_policy : ndarray of int, shape (S,), optional
        L's greedy policy; steps whose label differs from it keep their label.

    Returns
    -------
    ndarray of float, shape (n, A)
        Each step's action distribution; rows sum to 1.
    """
    s, labels = np.asarray(s, dtype=int), np.asarray(labels, dtype=int)
    out = np.zeros((len(s), n_actions))
    out[np.arange(len(s)), np.maximum(labels, 0)] = 1.0
    if soft_policy is not None:
        own = np.ones(len(s), dtype=bool)
        if own_policy is not None:
            own = np.asarray(own_policy)[s] == labels
        pi = np.asarray(soft_policy)[s[own]]
        near = (pi >= NEAR_TIE * pi.max(axis=1, keepdims=True)) | (out[own] > 0)
        kept = np.where(near, pi, 0.0)
        out[own] = kept / kept.sum(axis=1, keepdims=True)
    out[labels < 0] = 1.0 / n_actions
    return out


def indistinguishable(
    domain: PatrolDomain, s: np.ndarray, labels: np.ndarray
) -> tuple[tuple[str, ...], ...]:
    """Groups of two or more features that enter exactly the same of the labelled steps'
    feature subsets (ξ(s, a) of ``domain``): the steps fix only their product, and Eq. 4's
    maximum-entropy solution gives them one value.

    Parameters
    ----------
    domain : PatrolDomain
        The domain whose ξ the steps are read under.
    s : ndarray of int, shape (n,)
        The steps' start states.
    labels : ndarray of int, shape (n,)
        Their action labels (-1: none; such steps are left out).

    Returns
    -------
    tuple of tuple of str
        The groups, features in ξ's order; features that enter no subset are in none.
    """
    s, labels = np.asarray(s, dtype=int), np.asarray(labels, dtype=int)
    seen = labels >= 0
    used = np.unique(domain.subset_index[s[seen], labels[seen]])
    masks = domain.subset_masks[used]  # (subsets, F)
    groups: dict[bytes, list[str]] = {}
    for f, column in zip(domain.feature_map.features, masks.T, strict=True):
        if column.any():
            groups.setdefault(column.tobytes(), []).append(f)
    return tuple(tuple(g) for g in groups.values() if len(g) > 1)


def untested_features(
    domain: PatrolDomain,
    models: Sequence[MotionModel],
    s: np.ndarray,
    *,
    drift: bool = False,
) -> tuple[str, ...]:
    """The features no step from states ``s`` can test under any of ``models``: in no action's
    subset ξ(s, a) there (every action, since a robot may not do what L's policy says).

    The steps' likelihood does not depend on such a feature, so its posterior is its prior
    (a feature a scenario puts on some cells only, a wet patch the robot never crossed).

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain.
    models : sequence of MotionModel
        The candidate motion models (each with its ξ).
    s : ndarray of int, shape (n,)
        The start states of the steps the verdict's evidence holds.
    drift : bool, default False
        Whether the robot's lateral drift enters the evidence (it tests the wheels).

    Returns
    -------
    tuple of str
        The untested features, in ξ's order; all of them when ``s`` is empty.
    """
    s = np.unique(np.asarray(s, dtype=int))
    features = domain.feature_map.features
    tested = np.zeros(len(features), dtype=bool)
    for model in models:
        md = model_domain(domain, model)
        tested |= md.subset_masks[np.unique(md.subset_index[s])].any(axis=0)
    if drift:
        tested |= np.isin(features, WHEELS)
    return tuple(f for f, t in zip(features, tested, strict=True) if not t)


def untested_words(parts: Sequence[str]) -> str:
    """What the reports say of parts no kept step could test (:func:`untested_features`).

    Parameters
    ----------
    parts : sequence of str
        The untested parts (at least one).

    Returns
    -------
    str
        "floor: no step L kept could test it; the interval is the prior's", and the like.
    """
    them = "them" if len(parts) > 1 else "it"
    return f"{' and '.join(parts)}: no step L kept could test {them}; the interval is the prior's"


def _verdict_draws(
    post: MotionPosterior,
    features: Sequence[str],
    untested: Sequence[str],
    fits: bool,
    definition: DamageDefinition,
    prior: PriorSpec,
    seed: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The draws (n, F) and weights a verdict is read from, and how many of the first draws are
    L's models': the motion posterior's pooled draws; the untested features drawn afresh from
    the prior (their posterior is the prior, independent of the rest, and the sampler's
    estimate of a flat direction carries its own error; design: "Fault verdicts"); and, for a
    record that fails the model check, the prior's draws after them at the weight L's models
    do not get (:func:`tempered_trust`)."""
    p, w = post.pooled()
    n_models = len(p)
    h = np.array([min(definition.healthy_level(f), 0.999) for f in features])
    if untested:
        fresh = expit(sample_feature_prior(np.random.default_rng((seed, 1)), len(p), h, prior))
        columns = [list(features).index(f) for f in untested]
        p = p.copy()
        p[:, columns] = fresh[:, columns]
    if not fits:  # L's models get MODEL_TRUST, the prior the rest
        q = expit(sample_feature_prior(np.random.default_rng(seed), len(p), h, prior))
        thresholds = np.array([definition.threshold(f) for f in features])
        trust = tempered_trust(float(np.mean(~(q < thresholds).any(axis=1))))
        p = np.vstack([p, q])
        w = np.concatenate([trust * w, np.full(len(q), (1 - trust) / len(q))])
    return p, w, n_models


def tempered_trust(prior_no_part: float) -> float:
    """The weight of L's models in a verdict on a record that fails a check: :data:`MODEL_TRUST`,
    or less where even a statement certain under the models would reach :data:`CONFIDENT`.

    A tempered statement's probability is ``w u + (1 - w) q``, ``u`` under the models' draws
    and ``q`` under the prior's. Every statement is "no part is damaged" or "one of these parts
    is", so over the prior's draws ``q`` is at most ``max(P0, 1 - P0)``, P0 the share of them in
    which no part is damaged: a weight that keeps ``w + (1 - w) max(P0, 1 - P0)`` below
    :data:`CONFIDENT` keeps every statement below it. A prior whose own statement is that
    confident (a user's, with few features or a small ``damaged_share``) leaves the models no
    weight, and the verdict is the prior's.

    Parameters
    ----------
    prior_no_part : float
        P0, the share of the prior's draws with no part damaged.

    Returns
    -------
    float
        The weight, in [0, :data:`MODEL_TRUST`].
    """
    q = max(prior_no_part, 1.0 - prior_no_part)
    if q >= CONFIDENT:
        return 0.0
    # strictly below: the largest weight keeping a certain statement a hair under CONFIDENT
    ceiling = (CONFIDENT - q) / (1.0 - q) - 1e-9
    return float(min(MODEL_TRUST, max(ceiling, 0.0)))


def _untempered(
    verdict: Verdict, features, p: np.ndarray, w: np.ndarray, n_models: int, definition
) -> float:
    """The verdict's probability under L's models alone: over the first ``n_models`` draws
    (:func:`_verdict_draws`)."""
    thresholds = np.array([definition.threshold(f) for f in features])
    damaged = np.asarray(p[:n_models] < thresholds, dtype=bool)
    if verdict.names_damage:
        named = [list(features).index(f) for f in verdict.named]
        holds = np.asarray(damaged[:, named].any(axis=1), dtype=float)
    else:
        holds = np.asarray(~damaged.any(axis=1), dtype=float)
    return float(w[:n_models] @ holds / w[:n_models].sum())


def never_seen_moving(
    features: Sequence[str],
    definition: DamageDefinition,
    prior: PriorSpec = DEFAULT_PRIOR,
    n_draws: int = 4000,
    random_state: int = 0,
) -> FeatureUncertainty:
    """A robot L never saw at two consecutive steps: the prior's intervals and no verdict.

    Parameters
    ----------
    features : sequence of str
        The robot's features.
    definition : DamageDefinition
        What "damaged" means, and the prior's healthy levels.
    prior : PriorSpec, default DEFAULT_PRIOR
        The features' prior (:class:`~mirl.learning.motion_models.PriorSpec`).
    n_draws : int, default 4000
        The prior draws.
    random_state : int, default 0
        Their seed.

    Returns
    -------
    FeatureUncertainty
        The prior's intervals and medians, and a verdict that names no part, with
        ``seen_moving`` False, a failed ``moves`` check and, as ``confidence``, the prior's
        probability that no part is damaged.
    """
    features = tuple(features)
    h = np.array([min(definition.healthy_level(f), 0.999) for f in features])
    p = expit(sample_feature_prior(np.random.default_rng(random_state), n_draws, h, prior))
    w = np.full(n_draws, 1.0 / n_draws)
    intervals, medians = _summaries(features, p, w)
    prior_verdict = verdict_from_draws(features, p, w, definition)
    p_none = float(w @ ~(p < [definition.threshold(f) for f in features]).any(axis=1))
    fit = ModelFit((Check("moves", False, None, NEVER_SEEN),))
    verdict = Verdict(None, p_none, (), prior_verdict.damage_probabilities, fit, False)
    return FeatureUncertainty(intervals, verdict, medians=medians)


def _check_record(
    domain, t, s, s_next, lab, action, keep, unexplained, held, beside, post, posterior,
    dispersion: float, random_state: int,
):  # fmt: skip
    """The model check of a robot's kept steps (:mod:`mirl.learning.model_check`): the checks,
    the posterior refitted without the steps another robot held (where the record shows it),
    and the misfit and held steps (bool, one per observed step)."""
    cells = domain.states[:, :2]
    long_moves = np.abs(cells[s_next] - cells[s]).sum(axis=1) >= 2
    checks = [check_unexplained(unexplained, long_moves), check_slides(_slid(domain, t, s, s_next))]
    misfit = np.zeros(len(t), dtype=bool)
    in_the_way = np.zeros(len(t), dtype=bool)
    kinds = _move_kinds(domain, s, s_next)
    stayed = kinds == len(MOVE_KINDS) - 1
    kept = np.flatnonzero(keep)
    # a robot held by another stays put for the other's reason, if the record says so
    way = held_back(stayed[kept], held[kept], lab[kept], dispersion)
    checks.append(way)
    if way.misfit.size:
        in_the_way[kept[way.misfit]] = True
        post = posterior(keep & ~in_the_way)
        kept = np.flatnonzero(keep & ~in_the_way)
    if len(kept):
        q, fitted = _kind_probabilities(post, domain, s[kept], action[kept], random_state)
        rho = (dispersion - 1) / (dispersion + 1)
        stalls, _ = check_stalls(t[kept], stayed[kept], q[:, :, -1], rho)
        jams = check_jams(stayed[kept], beside[kept], q[:, :, -1], dispersion)
        checks += [check_moves(kinds[kept], fitted, dispersion), stalls, jams]
        for c in (stalls, jams):
            misfit[kept[c.misfit]] = True
    return checks, post, misfit, in_the_way


def _every_model_covered(
    verdict: Verdict, post: MotionPosterior, features, p: np.ndarray, w: np.ndarray, definition
) -> Verdict:
    """A verdict naming damage widened to every part a plausible model of the robot's motion
    names: the union of the parts the pooled draws name and those each model holding at least
    :data:`COVERAGE_SLACK` of the weight names on its own draws, with the pooled probability
    that one of them is damaged. Averaging blends two models that blame different parts (turns
    that test a wheel blame the wheel driving the rarer turn; turns that test none, navigation)
    into a claim neither makes with its own part; the verdict covers all but 0.05 of the
    probability of damage under every model that holds more than 0.05 of the weight."""
    if not verdict.names_damage:
        return verdict
    named = set(verdict.named)
    # a mirror and its twin count with their sum: "turns need a wheel", whichever
    for model_draws, weight in zip(post.draws, post.folded_weights(), strict=True):
        if weight >= COVERAGE_SLACK:
            own = expit(model_draws.x[:, : len(features)])
            named |= set(verdict_from_draws(features, own, model_draws.weights, definition).named)
    return _widened_to(verdict, named, features, p, w, definition)


def _mirrors_weigh(post: MotionPosterior) -> bool:
    """Whether the models whose turns need a wheel but cannot say which (a mirror and its twin)
    hold at least :data:`COVERAGE_SLACK` of the weight together."""
    if not post.twins:
        return False
    folded = post.folded_weights()
    return any(t >= 0 and folded[m] >= COVERAGE_SLACK for m, t in enumerate(post.twins))


def _widened_to(verdict: Verdict, named: set, features, p, w, definition) -> Verdict:
    """``verdict`` naming ``named`` instead, with the pooled probability that one of them is
    damaged (``verdict`` itself when it names them already)."""
    if named == set(verdict.named):
        return verdict
    chosen = [i for i, f in enumerate(features) if f in named]
    thresholds = np.array([definition.threshold(f) for f in features])
    confidence = float(w @ (p[:, chosen] < thresholds[chosen]).any(axis=1))
    names = tuple(features[i] for i in chosen)
    return Verdict(None, confidence, names, verdict.damage_probabilities)


MOVING_ACTIONS = ("forward", "turn_left", "turn_right")
"""The actions that move a robot: a part every one of them needs fails them all alike."""


def confounded_parts(feature_map) -> tuple[frozenset[str], frozenset[str]]:
    """The parts every move needs, and the parts that, damaged together, fail every move
    without them.

    A damaged part that every move needs (navigation, the floor) fails all moves alike. So
    do parts each move needs one of (under the paper's ξ both wheels: forward needs both, each
    turn one), only at other rates per action. Those rates are what L's action labels cannot
    be trusted with: the labels are L's policy's actions, and a robot whose steps fail often
    retries a failed turn where L's policy expects another action. Measured on the atlas's
    office, both wheels at 0.7: turns succeed 0.67 of the time and the labelled steps have them
    at 0.45-0.50, as often as forward steps, so "navigation or floor" fitted better than the
    wheels (docs/design.md, "Fault verdicts").

    Parameters
    ----------
    feature_map : FeatureMap
        A ξ (:class:`~mirl.world.domain.FeatureMap`).

    Returns
    -------
    common : frozenset of str
        The parts every moving action needs.
    together : frozenset of str
        The union of the minimal sets of other parts that hold a part of every moving action:
        empty when some move needs only common parts (then its failures point at them).
    """
    subsets = [set(feature_map.action_subsets[a]) for a in MOVING_ACTIONS]
    common = set.intersection(*subsets)
    rest = [s - common for s in subsets]
    if any(not r for r in rest):
        return frozenset(common), frozenset()
    pool = sorted(set().union(*rest))
    hitting = [
        set(h)
        for k in range(1, len(pool) + 1)
        for h in itertools.combinations(pool, k)
        if all(r & set(h) for r in rest)
    ]
    minimal = [h for h in hitting if not any(o < h for o in hitting)]
    return frozenset(common), frozenset(set().union(*minimal))


def _common_parts_widened(
    verdict: Verdict, post: MotionPosterior, features, p: np.ndarray, w: np.ndarray, definition
) -> Verdict:
    """A verdict that names a part every move needs, widened by the parts that together fail
    every move under each model the record does not rule out (:data:`NOT_RULED_OUT`;
    :func:`confounded_parts`), with the pooled probability that one of them is damaged: the
    labelled steps cannot tell the two apart.

    Not only under the models holding :data:`COVERAGE_SLACK` of the weight: a model under
    which the wheels together fail every move (turns that need a wheel) and one under which
    they fail only forward steps (turns that need none) explain a record of failed turns and
    failed forward steps alike — the first with both wheels damaged, the second with the floor
    or navigation — so what weighs them is the prior's price of one damaged part against two.
    Measured: a grid robot of boydright-3 with both wheels at 0.7 (900 steps, full view, the
    calibration atlas's replicate) held the model of its own world at 0.047, and its verdict
    named the floor or navigation alone at 0.99."""
    if not verdict.names_damage:
        return verdict
    named = set(verdict.named)
    widened = set(named)
    for model, weight in zip(post.models, post.folded_weights(), strict=True):
        common, together = confounded_parts(model.feature_map)
        if weight >= NOT_RULED_OUT and named & common:
            widened |= together
    return _widened_to(verdict, widened, features, p, w, definition)


def _kind_probabilities(post: MotionPosterior, domain, s, action, random_state: int):
    """(draws, steps, 3) probabilities of each kind of move
    (:data:`~mirl.learning.model_check.MOVE_KINDS`) under posterior draws, and under the draws
    of the highest likelihood (:data:`FITTED_SHARE`)."""
    ahead = [domain.intended[s, a] for a in (FORWARD, TURN_LEFT, TURN_RIGHT)]
    rng = np.random.default_rng(random_state)
    out = []
    for best in (1.0, FITTED_SHARE):
        draws = post.resample(CHECK_DRAWS, rng, best)
        q = post.outcome_probabilities(domain, s, (*ahead, s), action, draws)
        q = np.stack([q[:, :, 0], q[:, :, 1] + q[:, :, 2], q[:, :, 3]], axis=2)
        q[:, ahead[0] == s, 0] = 0.0  # a forward step into a wall stays put
        out.append(q)
    return out[0], out[1]


def _slid(domain: PatrolDomain, t: np.ndarray, s: np.ndarray, s_next: np.ndarray) -> np.ndarray:
    """Per observed step, whether it moved the robot to the cell behind it (against its heading
    at the step's start) and the robot's next observed step, the one after it, started there and
    stayed in that cell (:func:`~mirl.learning.model_check.check_slides`)."""
    if not len(s):
        return np.zeros(0, dtype=bool)
    cells, headings = domain.states[:, :2], domain.states[:, 2]
    behind = cells[s] - HEADING_DELTAS[headings[s]]
    backward = (cells[s_next] == behind).all(axis=1)
    nxt = np.r_[np.arange(1, len(s)), len(s) - 1]  # the following step, where there is one
    follows = np.r_[(t[1:] == t[:-1] + 1) & (s[1:] == s_next[:-1]), False]
    stayed = (cells[s_next[nxt]] == cells[s_next]).all(axis=1)
    return backward & follows & stayed


def _move_kinds(domain: PatrolDomain, s: np.ndarray, s_next: np.ndarray) -> np.ndarray:
    """Each step's kind of move, an index into
    :data:`~mirl.learning.model_check.MOVE_KINDS` (staying put first: a forward step into a
    wall stays put)."""
    intended = domain.intended[s]
    kinds = np.full(len(s), 2)
    turned = (intended[:, TURN_LEFT] == s_next) | (intended[:, TURN_RIGHT] == s_next)
    kinds[turned] = 1
    kinds[(intended[:, FORWARD] == s_next) & (s_next != s)] = 0
    return kinds


def robot_uncertainty(
    domain: PatrolDomain,
    record: RobotRecord,
    probabilities: Mapping[str, float],
    definition: DamageDefinition,
    *,
    learned_with: MotionModel | None = None,
    soft_policy: np.ndarray | None = None,
    own_policy: np.ndarray | None = None,
    models: Sequence[MotionModel] | None = None,
    prior: PriorSpec = DEFAULT_PRIOR,
    n_draws: int = N_DRAWS,
    random_state: int = 0,
) -> FeatureUncertainty:
    """Intervals and verdict of one robot from what L saw of it (module docstring).

    Parameters
    ----------
    domain : PatrolDomain
        The scenario's domain (its ξ is the ``"paper"`` candidates').
    record : RobotRecord
        The robot's states, labels and the steps other robots were near it.
    probabilities : mapping of str to float
        Eq. 4's feature probabilities learned from the labels (under ``learned_with``).
    definition : DamageDefinition
        What "damaged" means (and the prior's healthy levels, and how a weak wheel drifts the
        robot).
    learned_with : MotionModel, optional
        The model the labels and ``probabilities`` were learned under (default: the
        first of ``models``, the scenario's ξ with Eq. 5).
    soft_policy : ndarray of shape (S, A), optional
        The learned maximum-entropy policy, whose near ties L cannot break
        (:func:`action_distribution`).
    own_policy : ndarray of shape (S,), optional
        The greedy policy the labels came from (labels that differ came from the meeting rule).
    models : sequence of MotionModel, optional
        The candidates (default: :func:`~mirl.learning.motion_models.candidate_models`).
    prior : PriorSpec, default DEFAULT_PRIOR
        The features' prior (:class:`~mirl.learning.motion_models.PriorSpec`).
    n_draws : int, default N_DRAWS
        The sampler's draws per round
        (:data:`~mirl.learning.motion_models.N_DRAWS`).
    random_state : int, default 0
        The sampler's seed.

    Returns
    -------
    FeatureUncertainty
        The intervals, medians and verdict (with the record's fit and any weakened wheel), the
        motion models' weights, the features the steps cannot tell apart, the drift and the
        log evidence; :func:`never_seen_moving`'s when L never saw the robot at two
        consecutive steps.
    """
    from mirl.learning.transitions import count_subsets, observed_steps

    features = domain.feature_map.features
    models = tuple(models or candidate_models(domain.feature_map))
    t, s, s_next = observed_steps(record.series)
    if not len(t):
        return never_seen_moving(features, definition, prior, random_state=random_state)
    lab = np.asarray(record.labels)[t]
    unexplained = unexplained_steps(domain, s, s_next)
    held = np.zeros(len(t), dtype=bool) if record.held is None else np.asarray(record.held)[t]
    beside = np.zeros(len(t), dtype=bool) if record.beside is None else np.asarray(record.beside)[t]
    keep = ~unexplained
    action = action_distribution(s, lab, domain.n_actions, soft_policy, own_policy)
    plan_domain = model_domain(domain, learned_with or models[0])
    dispersion = failure_dispersion(
        plan_domain, t[keep], s[keep], lab[keep], s_next[keep], probabilities
    )
    drift = None
    if record.lateral is not None:  # a robot beside another is off the centre line for it
        alone = keep & ~held
        drift = lateral_drift(
            domain, t[alone], s[alone], lab[alone], s_next[alone], record.lateral, record.company
        )
    healthy = {f: definition.healthy_level(f) for f in features}

    def posterior(mask: np.ndarray) -> MotionPosterior:
        return motion_posterior(
            domain, s[mask], s_next[mask], action[mask], healthy, models=models, prior=prior,
            extra_log_likelihood=_drift_term(features, drift, definition.drift),
            dispersion=dispersion, n_draws=n_draws, random_state=random_state,
        )  # fmt: skip

    post = posterior(keep)
    checks, post, misfit, in_the_way = _check_record(
        domain, t, s, s_next, lab, action, keep, unexplained, held, beside, post, posterior,
        dispersion, random_state,
    )  # fmt: skip
    counts = count_subsets(plan_domain, s[keep], lab[keep], s_next[keep]).observations()
    checks.append(check_pinned(probabilities, counts))
    if record.off_pace is not None:
        checks.append(check_pace(record.off_pace, step_given=record.step_given))
    used = keep & ~misfit & ~in_the_way  # the steps the verdict's evidence holds
    if misfit.any():  # misfit steps are never failures of a part
        post = posterior(used)
    checks.append(check_record_length(int(used.sum())))
    left_out = {
        "in another robot's way": int(in_the_way.sum()),
        "explained by no action": int(unexplained.sum()),
        "misfit (stalls, jams)": int(misfit.sum()),
    }
    fit = ModelFit(tuple(checks), left_out)
    untested = untested_features(domain, models, s[used], drift=drift is not None)
    p, w, n_models = _verdict_draws(
        post, features, untested, fit.ok, definition, prior, random_state
    )
    intervals, medians = _summaries(features, p, w)
    verdict = _every_model_covered(
        verdict_from_draws(features, p, w, definition), post, features, p, w, definition
    )
    verdict = _common_parts_widened(verdict, post, features, p, w, definition)
    if not fit.ok:
        fit = replace(fit, untempered=_untempered(verdict, features, p, w, n_models, definition))
    groups = indistinguishable(plan_domain, s[used], lab[used])
    wheels_group = any(set(g) == set(WHEELS) for g in groups)
    # turns that need a wheel, but which one the step outcomes cannot say (a mirror and its
    # twin, design: "Fault verdicts"): the wheels are told apart by nothing those models see
    unsided = _mirrors_weigh(post)
    if unsided and not wheels_group:
        groups = (*groups, tuple(f for f in features if f in WHEELS))
    return FeatureUncertainty(
        intervals,
        Verdict(
            verdict.part, verdict.confidence, verdict.candidates, verdict.damage_probabilities,
            fit, weakened=weakened_wheel(drift, definition.drift, verdict.named),
        ),  # fmt: skip
        dispersion=dispersion,
        effective_draws=float(1.0 / (w**2).sum()),
        drift=drift,
        medians=medians,
        motion_models=post.model_weights(),
        indistinguishable=groups,
        sided_by_drift=wheels_group and drift is not None and not unsided,
        log_evidence=post.mean_log_evidence,
        forward_steps=forward_outcomes(domain, s[used], lab[used], s_next[used]),
        untested=untested,
    )


# --------------------------------------------------------------------------------------------
# The robot beside its team
#
# The prior centres a healthy part on the scenario's healthy level, and a forward step needs
# every part, so a robot whose forward steps succeed a little less than the healthy levels'
# product is explained as four healthy parts a little low. Where healthy robots do better
# than those levels (the physical world's succeed on 0.98-1.00 of their forward steps, the
# levels' product is 0.87), a robot with a damaged wheel can sit there: the margin is the
# same, measured from a higher level. The team shows that level: robots of one kind, and
# healthy ones alike (the grid's truth, and the physical world's, measured). A robot whose
# forward steps succeed below another's of the same record by more than any one part's margin
# allows (1 - margin / healthy level, the smallest over forward's parts) has a damaged part by
# the definition's own ratio (docs/design.md, "The robot beside its team").


@dataclass(frozen=True)
class TeamComparison:
    """A robot's forward steps against another robot's of the same record.

    Parameters
    ----------
    robot : str
        The other robot.
    own : (int, int)
        The robot's forward steps: successes, trials.
    other : (int, int)
        The other robot's.
    ratio : float
        The ratio below which one of the robot's parts is damaged (:func:`team_ratio`).
    below : float
        The probability that the robot's forward success is below ``ratio`` times the other's
        (:func:`below_probability`).
    """

    robot: str
    own: tuple[int, int]
    other: tuple[int, int]
    ratio: float
    below: float

    def to_dict(self) -> dict:
        """The comparison as ``mirl learn --json`` gives it (``verdict.beside``).

        Returns
        -------
        dict
            ``robot``, ``forward`` and ``robot_forward`` (successes, trials), ``ratio`` and
            ``below`` (4 decimals).
        """
        return {
            "robot": self.robot,
            "forward": list(self.own),
            "robot_forward": list(self.other),
            "ratio": round(float(self.ratio), 4),
            "below": round(float(self.below), 4),
        }

    @classmethod
    def from_dict(cls, record: Mapping) -> TeamComparison:
        """The comparison :meth:`to_dict` wrote.

        Parameters
        ----------
        record : mapping
            :meth:`to_dict`'s record.

        Returns
        -------
        TeamComparison
            The comparison.
        """
        return cls(
            str(record["robot"]), tuple(record["forward"]), tuple(record["robot_forward"]),
            float(record["ratio"]), float(record["below"]),
        )  # fmt: skip

    def sentence(self) -> str:
        """The comparison in words, for :meth:`Verdict.sentence`.

        Returns
        -------
        str
            "its forward steps succeed 243 of 310 (0.78), J's 299 of 306 (0.98): less than
            0.842 of J's with probability 0.94, ...".
        """
        (s, n), (so, no) = self.own, self.other
        return (
            f"its forward steps succeed {s} of {n} ({s / n:.2f}), {self.robot}'s {so} of {no} "
            f"({so / no:.2f}): less than {self.ratio:.3f} of {self.robot}'s with probability "
            f"{self.below:.2f}, which among robots of one kind only a damaged part explains"
        )


def forward_outcomes(
    domain: PatrolDomain, s: np.ndarray, action: np.ndarray, s_next: np.ndarray
) -> tuple[int, int]:
    """Successes and trials of the forward-labelled steps among ``(s, action, s_next)``.

    Parameters
    ----------
    domain : PatrolDomain
        The domain (its intended outcomes ψ).
    s, action, s_next : ndarray of int
        The steps' states, labels (-1: none) and next states.

    Returns
    -------
    (int, int)
        Steps that reached ψ(s, forward), and forward-labelled steps.
    """
    s, action, s_next = (np.asarray(v, dtype=int) for v in (s, action, s_next))
    fwd = action == FORWARD
    hit = domain.intended[s[fwd], FORWARD] == s_next[fwd]
    return int(hit.sum()), int(fwd.sum())


def team_ratio(definition: DamageDefinition, forward_parts: Sequence[str]) -> float:
    """The ratio of a robot's forward success to a healthy robot's below which one of its parts
    is damaged: the smallest ``1 - margin / h`` over the parts a forward step needs, ``h``
    their healthy levels (a wheel's, 0.842, by default).

    Parameters
    ----------
    definition : DamageDefinition
        The healthy levels and the margin.
    forward_parts : sequence of str
        The parts a forward step needs (ξ's forward subset).

    Returns
    -------
    float
        The ratio, in (0, 1).
    """
    return min(1.0 - definition.margin / definition.healthy_level(f) for f in forward_parts)


TEAM_QUANTILES = 2001
"""Quantiles of the other robot's Beta posterior :func:`below_probability` averages over (its
error is below 1 / the quantiles)."""


def below_probability(own: tuple[int, int], other: tuple[int, int], ratio: float) -> float:
    """P(θ < ratio · θ') for independent Beta(1 + s, 1 + n − s) posteriors of two success rates.

    Averaged over evenly spaced quantiles of θ' (:data:`TEAM_QUANTILES`): deterministic, and
    exact to the quadrature's error, which a test checks against sampling.

    Parameters
    ----------
    own, other : (int, int)
        Successes and trials of θ and θ'.
    ratio : float
        The ratio.

    Returns
    -------
    float
        The probability.
    """
    # the Beta's quantile and distribution functions straight from scipy.special, which
    # scipy.stats.beta calls (the same numbers, bit for bit): importing scipy.stats costs a
    # `mirl learn` on boyd2 about a third of its time
    from scipy.special import betainc, betaincinv

    (s, n), (so, no) = own, other
    u = (np.arange(TEAM_QUANTILES) + 0.5) / TEAM_QUANTILES
    q = betaincinv(1 + so, 1 + no - so, u)
    return float(np.mean(betainc(1 + s, 1 + n - s, ratio * q)))


def compared_with_team(
    uncertainties: Sequence[FeatureUncertainty | None],
    names: Sequence[str],
    definition: DamageDefinition,
    forward_parts: Sequence[str],
) -> list[FeatureUncertainty | None]:
    """Each robot said to have no damaged part, against the robots of its record.

    For the robot, the other robot its forward steps most probably fall short of by more than
    :func:`team_ratio` (:func:`below_probability`, probability b). With b ≥ 0.5 the verdict
    becomes "one of its parts (forward's) is damaged" at b; otherwise "no part" is stated at
    no more than 1 − b, where b is at least :data:`NOT_RULED_OUT` (odds of 1 : 99 against it
    are decisive, as for a motion model's weight). A verdict naming a part, a robot never seen
    moving, a record that does not fit L's models (its verdict already claims nothing at high
    confidence) and a comparison that changes nothing are left as they are.

    Parameters
    ----------
    uncertainties : sequence of FeatureUncertainty or None
        Per robot, :func:`robot_uncertainty`'s (None: no verdict).
    names : sequence of str
        The robots' names, in that order.
    definition : DamageDefinition
        The healthy levels and the margin.
    forward_parts : sequence of str
        The parts a forward step needs (ξ's forward subset).

    Returns
    -------
    list of FeatureUncertainty or None
        The uncertainties, each verdict the comparison sets with its ``beside``.
    """

    ratio = team_ratio(definition, forward_parts)
    out = list(uncertainties)
    for i, u in enumerate(uncertainties):
        if u is None or not u.verdict.seen_moving or u.verdict.names_damage:
            continue
        if u.verdict.fit is not None and not u.verdict.fit.ok:  # already claims nothing high
            continue
        if not u.forward_steps[1]:
            continue
        found = [
            TeamComparison(
                names[j], u.forward_steps, o.forward_steps, ratio,
                below_probability(u.forward_steps, o.forward_steps, ratio),
            )  # fmt: skip
            for j, o in enumerate(uncertainties)
            if j != i and o is not None and o.forward_steps[1]
        ]
        if not found:
            continue
        most = max(found, key=lambda c: c.below)
        v = u.verdict
        if most.below >= 0.5:
            parts = tuple(f for f in u.intervals if f in set(forward_parts))
            v = replace(v, confidence=most.below, candidates=parts, weakened=None, beside=most)
        elif most.below >= NOT_RULED_OUT and 1.0 - most.below < v.confidence:
            v = replace(v, confidence=1.0 - most.below, beside=most)
        else:
            continue
        out[i] = replace(u, verdict=v)
    return out
