"""How sure L is of each part: a 95 % interval per transition feature and a fault verdict per robot
(docs/design.md, "Fault verdicts").

The evidence is the same as the point estimate's — each observed step, labelled with an action,
is a success or a failure of the feature subset ξ(s, a) the action relies on (Eq. 2–3) — with
two corrections for what the point estimate takes as certain:

* **The labels.** mIRL*/T+Int labels a step with its learned policy's action; the policy may be
  wrong there. Each step is spread over the actions by the posterior probability that the robot
  meant each one, P(a | s, s') ∝ π(a | s) T(s, a, s'), with π the learned *soft* policy (the IRL's
  maximum-entropy policy, whose temperature is learned) and T the learned model: the E-step of
  EM over latent labels (Dempster, Laird & Rubin 1977). Steps labelled by the meeting rule and
  labels from a known policy stay as they are, unless T says the label cannot have produced the
  step (a wrong label, not a failure of its features). :func:`soft_counts`.
* **Clustered failures.** Failures come in runs (a robot on a wall, a robot queueing behind
  another), so steps are not independent trials. The lag-1 autocorrelation ρ of the
  standardised outcome residuals gives the variance inflation (1 + ρ)/(1 − ρ) of an AR(1)
  process, and the counts are divided by it (a quasi-likelihood dispersion, McCullagh & Nelder
  1989, Sec. 4.5). :func:`failure_dispersion`.
* **Robots in the way.** In robot data (poses: physical robots) a step that starts with another
  robot in the robot's cell or the cell ahead is left out of the counts, the dispersion and the
  drift: a robot there blocks or pushes it, and what the step does is not its parts' doing.
  Grid robots do not block each other. :func:`held_by_others`.
* **Drift.** Step outcomes cannot tell a differential drive's wheels apart when only forward
  steps fail (they need both wheels): a weak motor that still pivots in time leaves the side
  unknown. Poses can: a robot veers towards its weaker wheel, so robot data (poses, not grid
  states) carry the mean lateral offset of its forward steps from the hallway's centre line
  (:attr:`~mirl.observations.trajectories.Trajectories.lateral`), which enters as one more
  likelihood term: offset ~ N(κ (p_right − p_left), se² + τ²), κ the drift of a unit wheel gap:
  measured where the robots are known (the physical world's), else unknown with a half-normal
  prior (:class:`~mirl.world.faults.DriftSpec`). :func:`lateral_drift`,
  :func:`drift_log_likelihood`.

The posterior over the features' success probabilities is then the product of the pooled
binomial likelihood (Eq. 2: a subset succeeds with ∏_{τ∈ξ} p_τ) and a prior saying that most
parts are healthy: for each feature, with probability 0.8 a Beta(50 h, 50 (1 − h)) around its
healthy level h, else uniform on [0, 1]. It is sampled by population Monte Carlo in logit space
(adaptive importance sampling with a defensive mixture component, Cappé, Guillin, Marin & Robert
2004): draws from the prior, then two rounds from Gaussian kernels around resampled draws. The
posterior can be multimodal ("the left wheel or the right wheel" when only forward steps were
seen) and is never more than a handful of dimensions, which is what this sampler handles.

From the draws: each feature's central 95 % interval, and the probability of every set of damaged
parts (:class:`~mirl.world.faults.DamageDefinition`), from which :func:`verdict_from_draws` makes
the verdict.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.special import betaln, expit, log_ndtr

from mirl.world.domain import FORWARD, N_HEADINGS, PatrolDomain
from mirl.world.faults import WHEELS, DamageDefinition, DriftSpec
from mirl.world.maps import HEADING_DELTAS

__all__ = [
    "Verdict",
    "FeatureUncertainty",
    "PriorSpec",
    "LateralDrift",
    "WHEELS",
    "soft_counts",
    "held_by_others",
    "in_company",
    "lateral_drift",
    "drift_log_likelihood",
    "estimate_outside_interval",
    "outside_interval_note",
    "failure_dispersion",
    "posterior_draws",
    "feature_uncertainty",
    "robot_uncertainty",
    "verdict_from_draws",
    "point_verdict",
]

LEVEL = 0.95
"""The intervals' coverage."""
COVERAGE_SLACK = 0.05
"""A verdict names the fewest parts that hold all but this much of the probability of damage."""


@dataclass(frozen=True)
class Verdict:
    """What L concludes about one robot's parts.

    Parameters
    ----------
    part : str or None
        The damaged part; None when no part is damaged or L cannot tell which.
    confidence : float
        The probability that the verdict is right: that ``part`` is damaged; that one of the
        ``candidates`` is; or, with neither, that no part is.
    candidates : tuple of str
        When L cannot tell which: the parts one (or more) of which is damaged.
    damage_probabilities : mapping of str to float
        Per feature, the probability that it is damaged.
    """

    part: str | None
    confidence: float
    candidates: tuple[str, ...] = ()
    damage_probabilities: Mapping[str, float] = field(default_factory=dict)

    @property
    def names_damage(self) -> bool:
        """Whether the verdict says some part is damaged (a part or candidates)."""
        return self.part is not None or bool(self.candidates)

    @property
    def named(self) -> tuple[str, ...]:
        """The parts the verdict says are (or may be) damaged."""
        return (self.part,) if self.part is not None else self.candidates

    def is_right(self, damaged: Sequence[str]) -> bool:
        """Whether the verdict is right when ``damaged`` are the truly damaged parts."""
        if not self.names_damage:
            return not damaged
        return any(p in damaged for p in self.named)

    def to_dict(self) -> dict:
        return {
            "part": self.part,
            "confidence": round(float(self.confidence), 4),
            "candidates": list(self.candidates),
            "damage_probabilities": {
                k: round(float(v), 4) for k, v in self.damage_probabilities.items()
            },
        }

    def sentence(self, robot: str) -> str:
        """The verdict in words: "J's left wheel is damaged (confidence 0.97)"."""
        conf = f"(confidence {self.confidence:.2f})"
        if self.part is not None:
            return f"{robot}'s {_words(self.part)} is damaged {conf}"
        if not self.candidates:
            return f"no part of {robot} is damaged {conf}"
        wheels = all(c.endswith("_wheel") for c in self.candidates)
        if wheels and len(self.candidates) == 2:
            what = f"one of {robot}'s wheels is weak (or both)"
        else:
            parts = ", ".join(map(_words, self.candidates))
            what = f"one of {robot}'s parts ({parts}) is damaged"
        return f"{what}; the observations cannot tell which {conf}"


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
    dispersion : float
        The variance inflation the counts were divided by (1: independent steps).
    effective_draws : float
        The importance sampler's effective sample size (Kish).
    drift : LateralDrift or None
        The lateral drift that entered the posterior (None: no poses, or too few steps).
    """

    intervals: Mapping[str, tuple[float, float]]
    verdict: Verdict
    dispersion: float = 1.0
    effective_draws: float = 0.0
    drift: LateralDrift | None = None


@dataclass(frozen=True)
class LateralDrift:
    """A robot's mean lateral offset on its forward steps (cells, left of the heading positive).

    Parameters
    ----------
    mean : float
    se : float
        Its standard error, inflated for the correlation of consecutive steps.
    steps : int
        The forward steps it is the mean of.
    """

    mean: float
    se: float
    steps: int

    def to_dict(self) -> dict:
        return {"mean": round(self.mean, 4), "se": round(self.se, 4), "steps": self.steps}

    def sentence(self) -> str:
        """The drift in words: "0.125 cell to the right of the centre line (± 0.008) on 313
        forward steps"."""
        side = "left" if self.mean > 0 else "right"
        return (
            f"{abs(self.mean):.3f} cell to the {side} of the centre line (± {self.se:.3f}) on "
            f"{self.steps} forward steps"
        )


@dataclass(frozen=True)
class PriorSpec:
    """The prior of each success probability: with probability ``damaged_share`` uniform on
    [0, 1], else Beta(``strength`` h, ``strength`` (1 − h)) around the healthy level h."""

    damaged_share: float = 0.2
    strength: float = 50.0


# ---- the evidence -----------------------------------------------------------------------------
def soft_counts(
    domain: PatrolDomain,
    s: np.ndarray,
    labels: np.ndarray,
    s_next: np.ndarray,
    transitions: sp.csr_array | None = None,
    soft_policy: np.ndarray | None = None,
    own_policy: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Successes and trials per subset of ``domain.subsets`` (floats), each labelled step
    spread over the actions by P(a | s, s') ∝ π(a | s) T(s, a, s').

    Without ``soft_policy`` (labels from perception or a known policy) the labels count as
    they are. Steps whose label is not ``own_policy``'s action (the meeting rule's) and
    unlabelled steps (-1, left out) keep their labels too — unless T says the label cannot have
    produced the step (T(s, a, s') = 0: under the ``stop`` error model, a "stop" after which
    the robot moved): such a step is spread over the actions that can, by π(a | s) T(s, a, s'),
    π the soft policy or, without one, uniform. A label T cannot explain is a wrong label, not
    a failure of its features; a step no action explains keeps its label.

    Parameters
    ----------
    domain : PatrolDomain
    s, labels, s_next : ndarray of shape (n,)
        Observed steps and their labels (-1: unlabelled).
    transitions : sparse array of shape (S·A, S), optional
        The learned T the labels were last learned with.
    soft_policy : ndarray of shape (S, A), optional
        The learned maximum-entropy policy.
    own_policy : ndarray of shape (S,), optional
        The greedy policy the labels came from.
    """
    s, labels, s_next = (np.asarray(v, dtype=int) for v in (s, labels, s_next))
    keep = labels >= 0
    s, labels, s_next = s[keep], labels[keep], s_next[keep]
    A, n_sub = domain.n_actions, len(domain.subsets)
    resp = np.zeros((len(s), A))
    resp[np.arange(len(s)), labels] = 1.0
    if transitions is not None and len(s):
        rows = (s[:, None] * A + np.arange(A)[None, :]).ravel()
        cols = np.repeat(s_next, A)
        lik = np.asarray(sp.csr_array(transitions)[rows, cols]).reshape(len(s), A)
        prior = np.full((len(s), A), 1.0 / A) if soft_policy is None else soft_policy[s]
        joint = np.asarray(prior) * lik
        total = joint.sum(axis=1)
        soft = np.zeros(len(s), dtype=bool)
        if soft_policy is not None:
            soft[:] = True if own_policy is None else np.asarray(own_policy)[s] == labels
        soft |= lik[np.arange(len(s)), labels] <= 0  # a label T cannot explain
        soft &= total > 0
        resp[soft] = joint[soft] / total[soft, None]
    idx = domain.subset_index[s]  # (n, A)
    hit = domain.intended[s] == s_next[:, None]  # (n, A)
    trials = np.bincount(idx.ravel(), weights=resp.ravel(), minlength=n_sub)
    successes = np.bincount(idx.ravel(), weights=(resp * hit).ravel(), minlength=n_sub)
    return successes, trials


def failure_dispersion(
    domain: PatrolDomain,
    t: np.ndarray,
    s: np.ndarray,
    labels: np.ndarray,
    s_next: np.ndarray,
    probabilities: Mapping[str, float],
    cap: float = 4.0,
) -> float:
    """The variance inflation (1 + ρ)/(1 − ρ) of the step outcomes, ρ the lag-1 autocorrelation
    of their standardised residuals under ``probabilities`` over consecutive labelled steps
    (``t`` the steps' times); 1 when ρ ≤ 0 or there are too few pairs, at most ``cap``."""
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
    """(horizon,) bool: the steps at which L saw another robot coming the other way (the
    opposite heading) within ``distance`` cells (centre to centre) of robot ``robot``, ahead of
    it or alongside (within 110° of its heading, so until they have passed), both seen;
    ``series`` holds every robot's observed states (-1 unseen).

    Robots passing each other keep to one side; a robot following or leading another does not
    pass it and drives the middle, so those steps are not company.
    """
    own = np.asarray(series[robot])
    near = np.zeros(len(own), dtype=bool)
    for both, a, b in _seen_together(domain, series, robot):
        v = (b[:, :2] - a[:, :2]).astype(float)
        dist = np.hypot(*v.T)
        ahead = (v * HEADING_DELTAS[a[:, 2]]).sum(axis=1) >= np.cos(np.radians(110)) * dist
        oncoming = b[:, 2] == (a[:, 2] + N_HEADINGS // 2) % N_HEADINGS
        near[both] |= (dist <= distance) & oncoming & ahead
    return near


def held_by_others(domain: PatrolDomain, series: Sequence[np.ndarray], robot: int) -> np.ndarray:
    """(horizon,) bool: the steps at which L saw another robot in robot ``robot``'s cell or in
    the cell ahead of it, both seen; ``series`` holds every robot's observed states (-1
    unseen). A physical robot there is in the way: what the step does is not its parts' doing.
    """
    own = np.asarray(series[robot])
    held = np.zeros(len(own), dtype=bool)
    for both, a, b in _seen_together(domain, series, robot):
        v = b[:, :2] - a[:, :2]
        ahead = (v == HEADING_DELTAS[a[:, 2]]).all(axis=1)
        held[both] |= (v == 0).all(axis=1) | ahead
    return held


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
    the cell ahead and drove alone, or None with fewer than ``min_steps`` of them.

    ``t, s, labels, s_next`` are its observed steps (as for :func:`failure_dispersion`),
    ``lateral`` its (horizon,) offsets and ``company`` the (horizon,) steps at which another
    robot was near it (:func:`in_company`): a step starting or ending in company is left out,
    because robots passing each other keep to one side, which is no wheel's doing; so is a
    forward step that failed (a robot stuck against a wall is off the centre line for the
    wall's reason, step after step). Consecutive offsets of one robot are correlated (a robot
    off the centre line stays off it for a while): the standard error is inflated by
    (1 + ρ)/(1 − ρ), ρ their lag-1 autocorrelation.
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
    rho = 0.0 if rho is None else float(np.clip(rho, 0.0, 0.95))
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


def estimate_outside_interval(
    probabilities: Mapping[str, float],
    intervals: Mapping[str, tuple[float, float]],
    slack: float = 0.05,
) -> bool:
    """Whether some point estimate lies more than ``slack`` outside its 95 % interval (max
    entropy's 1.000 against a posterior's 0.99 is not worth a word)."""
    return any(
        not lo - slack <= probabilities[f] <= hi + slack
        for f, (lo, hi) in intervals.items()
        if f in probabilities
    )


def outside_interval_note(poses: bool) -> str:
    """Why an estimate can lie well outside its interval, for the reports."""
    veers = " and which way the robot veers" if poses else ""
    return (
        "(an estimate well outside its interval: the estimate is Eq. 4's fit of the step "
        "outcomes alone, which L plans with; the interval and the verdict also weigh that most "
        f"parts are healthy{veers})"
    )


# ---- the posterior ----------------------------------------------------------------------------
def _log_prior(x: np.ndarray, healthy: np.ndarray, prior: PriorSpec) -> np.ndarray:
    """Log density of logit-space draws ``x`` (n, F) under the prior, Jacobian included."""
    a, b = prior.strength * healthy, prior.strength * (1 - healthy)
    log_p, log_q = -np.logaddexp(0, -x), -np.logaddexp(0, x)  # log p, log (1 − p)
    beta = (a - 1) * log_p + (b - 1) * log_q - betaln(a, b)
    mix = np.logaddexp(np.log1p(-prior.damaged_share) + beta, np.log(prior.damaged_share))
    return (mix + log_p + log_q).sum(axis=1)


def _log_likelihood(x, incidence, successes, failures) -> np.ndarray:
    """Pooled binomial log-likelihood of logit-space draws (n, F) (Eq. 2)."""
    z = (-np.logaddexp(0, -x)) @ incidence.T  # (n, m) log success of each subset
    log_fail = np.log(-np.expm1(np.minimum(z, -1e-12)))
    return z @ successes + log_fail @ failures


def _sample_prior(rng, n: int, healthy: np.ndarray, prior: PriorSpec) -> np.ndarray:
    F = len(healthy)
    a, b = prior.strength * healthy, prior.strength * (1 - healthy)
    p = rng.beta(np.broadcast_to(a, (n, F)), np.broadcast_to(b, (n, F)))
    uniform = rng.random((n, F)) < prior.damaged_share
    p[uniform] = rng.random(int(uniform.sum()))
    p = np.clip(p, 1e-9, 1 - 1e-9)
    return np.log(p) - np.log1p(-p)


def posterior_draws(
    features: Sequence[str],
    observations: Sequence[tuple[Sequence[str], float, float]],
    healthy: Mapping[str, float],
    *,
    prior: PriorSpec = PriorSpec(),
    drift: LateralDrift | None = None,
    drift_spec: DriftSpec = DriftSpec(),
    n_draws: int = 2000,
    rounds: int = 2,
    random_state: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted draws of the features' success probabilities given pooled counts (and a
    lateral drift, when the features include both :data:`WHEELS`).

    Parameters
    ----------
    features : sequence of str
    observations : sequence of (subset, successes, trials)
        Counts may be fractional (soft labels, a dispersion divided out).
    healthy : mapping of str to float
        Each feature's healthy level (the prior's centre).
    prior : PriorSpec
    drift : LateralDrift, optional
        The robot's lateral drift (:func:`drift_log_likelihood`).
    drift_spec : DriftSpec
    n_draws : int, default 2000
        Draws per round of the sampler.
    rounds : int, default 2
        Adaptation rounds after the first, drawn from the prior.
    random_state : int, default 0

    Returns
    -------
    p : ndarray of shape (n_draws, F)
        Success probabilities, one row per draw.
    weights : ndarray of shape (n_draws,)
        Normalised importance weights.
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
    h = np.array([min(healthy.get(f, 0.95), 0.999) for f in features])
    rng = np.random.default_rng(random_state)

    wheels = (
        (pos[WHEELS[0]], pos[WHEELS[1]]) if drift is not None and set(WHEELS) <= set(pos) else None
    )

    def log_lik(x):
        out = _log_likelihood(x, incidence, succ, fail)
        if wheels is not None:
            gap = expit(x[:, wheels[1]]) - expit(x[:, wheels[0]])
            out = out + drift_log_likelihood(gap, drift, drift_spec)
        return out

    def log_post(x):
        return _log_prior(x, h, prior) + log_lik(x)

    x = _sample_prior(rng, n_draws, h, prior)
    log_w = log_lik(x)  # prior draws: weight = likelihood
    defensive = 0.1
    for _ in range(rounds):
        w = _normalised(log_w)
        n_centres = min(50, n_draws // 10)
        centres = x[_systematic(rng, w, n_centres)]
        mean = w @ x
        cov = (x - mean).T @ ((x - mean) * w[:, None])
        cov = 0.5 * cov + 1e-3 * np.eye(F)  # kernel bandwidth: half the posterior's spread
        chol = np.linalg.cholesky(cov)
        n_prior = int(defensive * n_draws)
        kern = centres[rng.integers(0, n_centres, n_draws - n_prior)]
        kern = kern + rng.standard_normal((len(kern), F)) @ chol.T
        x = np.vstack([kern, _sample_prior(rng, n_prior, h, prior)])
        inv = np.linalg.inv(chol)
        y, c = x @ inv.T, centres @ inv.T
        maha = (y**2).sum(axis=1)[:, None] + (c**2).sum(axis=1)[None, :] - 2 * y @ c.T
        log_kernel = (
            _logsumexp_rows(-0.5 * maha)
            - np.log(n_centres)
            - np.log(np.diag(chol)).sum()
            - 0.5 * F * np.log(2 * np.pi)
        )
        log_q = np.logaddexp(
            np.log1p(-defensive) + log_kernel, np.log(defensive) + _log_prior(x, h, prior)
        )
        log_w = log_post(x) - log_q
    return expit(x), _normalised(log_w)


def _logsumexp_rows(a: np.ndarray) -> np.ndarray:
    """log Σ_j exp(a[i, j]) per row (scipy's logsumexp costs more in checks than in sums)."""
    top = a.max(axis=1)
    return np.log(np.exp(a - top[:, None]).sum(axis=1)) + top


def _normalised(log_w: np.ndarray) -> np.ndarray:
    w = np.exp(log_w - log_w.max())
    return w / w.sum()


def _systematic(rng, w: np.ndarray, n: int) -> np.ndarray:
    """Systematic resampling: ``n`` indices drawn in proportion to ``w``."""
    u = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(np.cumsum(w), u), len(w) - 1)


def _quantile(values: np.ndarray, w: np.ndarray, q: float) -> float:
    order = np.argsort(values)
    cdf = np.cumsum(w[order])
    k = min(int(np.searchsorted(cdf, q)), len(values) - 1)
    return float(values[order[k]])


# ---- the verdict ------------------------------------------------------------------------------
def verdict_from_draws(
    features: Sequence[str], p: np.ndarray, weights: np.ndarray, definition: DamageDefinition
) -> Verdict:
    """The verdict of weighted posterior draws ``p`` (n, F).

    No part is damaged when that is at least as probable as not. Otherwise the verdict names
    the fewest parts — by decreasing probability of damage — that hold all but
    :data:`COVERAGE_SLACK` of the probability that some part is damaged, plus every part more
    probably damaged than not: one such part is the verdict, with the probability that it is
    damaged; several are "one of these, cannot tell which", with the probability that one of
    them is.
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
        if covered >= (1 - p_none) - COVERAGE_SLACK and marginal[k] < 0.5:
            break
        chosen.append(int(k))
        covered = float(weights @ damaged[:, chosen].any(axis=1))
    if len(chosen) == 1:
        return Verdict(features[chosen[0]], float(marginal[chosen[0]]), (), probs)
    names = tuple(features[k] for k in sorted(chosen))
    return Verdict(None, covered, names, probs)


def point_verdict(probabilities: Mapping[str, float], definition: DamageDefinition) -> Verdict:
    """The verdict of known probabilities (the truth): certain."""
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
    prior: PriorSpec = PriorSpec(),
    n_draws: int = 2000,
    random_state: int = 0,
) -> FeatureUncertainty:
    """Intervals and verdict of one robot from its pooled (possibly soft) counts and, with
    poses, its lateral drift.

    Parameters
    ----------
    features : sequence of str
    observations : sequence of (subset, successes, trials)
    definition : DamageDefinition
        What "damaged" means (and the prior's healthy levels, and how a weak wheel drifts the
        robot).
    dispersion : float, default 1
        The counts are divided by it (:func:`failure_dispersion`).
    drift : LateralDrift, optional
        Its lateral drift (:func:`lateral_drift`).
    prior, n_draws, random_state
        Passed to :func:`posterior_draws`.
    """
    if dispersion < 1:
        raise ValueError(f"`dispersion` must be at least 1, got {dispersion}")
    scaled = [(sub, k / dispersion, n / dispersion) for sub, k, n in observations if n > 0]
    healthy = {f: definition.healthy.get(f, 0.95) for f in features}
    p, w = posterior_draws(
        features, scaled, healthy, prior=prior, drift=drift, drift_spec=definition.drift,
        n_draws=n_draws, random_state=random_state,
    )  # fmt: skip
    tail = (1 - LEVEL) / 2
    intervals = {
        f: (_quantile(p[:, i], w, tail), _quantile(p[:, i], w, 1 - tail))
        for i, f in enumerate(features)
    }
    return FeatureUncertainty(
        intervals,
        verdict_from_draws(features, p, w, definition),
        dispersion=float(dispersion),
        effective_draws=float(1.0 / (w**2).sum()),
        drift=drift,
    )


def robot_uncertainty(
    domain: PatrolDomain,
    series: np.ndarray,
    labels: np.ndarray,
    transitions: sp.csr_array,
    probabilities: Mapping[str, float],
    definition: DamageDefinition,
    *,
    soft_policy: np.ndarray | None = None,
    own_policy: np.ndarray | None = None,
    lateral: np.ndarray | None = None,
    company: np.ndarray | None = None,
    held: np.ndarray | None = None,
    random_state: int = 0,
) -> FeatureUncertainty:
    """Intervals and verdict of one robot from what L saw of it (module docstring).

    Parameters
    ----------
    domain : PatrolDomain
    series : ndarray of shape (horizon,)
        The robot's observed states, -1 where occluded.
    labels : ndarray of shape (horizon,)
        The labels its feature probabilities were learned from (-1: none).
    transitions : sparse array of shape (S·A, S)
        The T learned from them.
    probabilities : mapping of str to float
        The feature probabilities learned from them.
    definition : DamageDefinition
    soft_policy : ndarray of shape (S, A), optional
        The learned maximum-entropy policy whose greedy actions gave the labels; without it
        the labels are taken as they are.
    own_policy : ndarray of shape (S,), optional
        That greedy policy (labels that differ from it came from the meeting rule).
    lateral : ndarray of shape (horizon,), optional
        Its lateral offsets (NaN unknown), from poses; None from grid states.
    company : ndarray of shape (horizon,), optional
        The steps at which another robot was near it (:func:`in_company`), left out of the
        drift.
    held : ndarray of shape (horizon,), optional
        The steps that start with another robot in its cell or the cell ahead
        (:func:`held_by_others`), left out of the counts, their dispersion and the drift: what
        they do is the other robot's doing.
    random_state : int, default 0
    """
    from mirl.learning.transitions import observed_steps

    t, s, s_next = observed_steps(series)
    if held is not None:
        free = ~np.asarray(held, dtype=bool)[t]
        t, s, s_next = t[free], s[free], s_next[free]
    lab = np.asarray(labels)[t]
    successes, trials = soft_counts(domain, s, lab, s_next, transitions, soft_policy, own_policy)
    observations = [
        (sub, k, n) for sub, k, n in zip(domain.subsets, successes, trials, strict=True) if n > 0
    ]
    dispersion = failure_dispersion(domain, t, s, lab, s_next, probabilities)
    drift = None if lateral is None else lateral_drift(domain, t, s, lab, s_next, lateral, company)
    return feature_uncertainty(
        domain.feature_map.features,
        observations,
        definition,
        dispersion=dispersion,
        drift=drift,
        random_state=random_state,
    )
