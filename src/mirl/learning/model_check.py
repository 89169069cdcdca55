"""Does a robot's record fit L's motion models? A posterior-predictive check before a verdict
(docs/design.md, "Fault verdicts").

A verdict is a probability computed under L's models of motion
(:mod:`mirl.learning.motion_models`); where the record shows what no model of them produces,
that probability is not one of the world. Each check compares a statistic of the record with
what the models, at their posterior, predict for it (a posterior-predictive check, Gelman, Meng
& Stern 1996), or with a tolerance where the models predict none at all:

* **Unexplained steps** — a next state that no action's intended state is (a move across two
  cells, a jump sideways, a turn and a move in one step). No model produces one; a tracker's
  misreads do, now and then. The check fails when they are more than a tolerated share of
  misreads (:data:`MISREAD_RATE`) makes plausible (a binomial tail below :data:`ALPHA`); moves
  longer than one cell say the record's time step is too long for the robot's pace.
* **Slides** — moves to the cell behind the robot that it then stays in (the next observed
  step starts there and leaves no cell). No action moves a robot backwards; a tracker's misread
  of a still robot does, but the next read takes it back, so a backward move that stays needs
  two misreads in a row. The check fails when they are more than that (a binomial tail below
  :data:`ALPHA` at the square of :data:`MISREAD_RATE`): a robot pushed back by another, or
  wedged on a wall and sliding while it drives, whose stays are no failures of its parts. A
  wedge that lasts the whole record is what the stall check cannot see: the robot's own
  failure rate, fitted to it, explains the stays.
* **Stalls** — the longest run of consecutive steps on which the robot stayed put. Under the
  models each step stays put with its own probability (a failed move, a stop), consecutive
  steps correlated as far as the record's dispersion grants (a two-state Markov chain with the
  lag-1 correlation of :func:`~mirl.learning.verdicts.failure_dispersion`); the chance of a run
  this long somewhere in the record is the Poisson clumping approximation (Arratia, Goldstein
  & Gordon 1990), averaged over the posterior. A robot jammed against an unseen robot or wedged
  on a wall stalls longer than any failure rate explains.
* **In the way** — the steps with another robot L saw in the robot's cell or ahead of it, at
  the step's start or end (:func:`~mirl.learning.verdicts.held_by_others`), are no evidence
  of its parts: they are left out whatever the record shows, and the check says whether the
  robot stayed put on them more often than elsewhere (:func:`held_back`). It fails where they
  are most of the robot's steps and fewer than :data:`~mirl.observations.discretise.AUTO_MIN_MOVES`
  free steps are left: L's policy for the robot, learned from its whole record, then learned
  the other robot's pace as the robot's own wish, and the few steps left are judged by labels
  from it (a healthy robot queueing behind a slow one for a whole record looks like one that
  fails every move it does not make).
* **Jams** — steps on which the robot stayed put while another robot L saw was within one cell
  (beside, behind, diagonally: those in its way are left out already).
  The models say a step stays put as often next to another robot as anywhere; physical robots
  touching say otherwise.
* **Moves** — how often the robot moved forward, turned and stayed put, against how often the
  models with L's policy say it would (a χ² discrepancy averaged over the posterior; turns
  left and right pooled, because which way a robot turns round at a patrol's end is a tie L
  may break otherwise than the robot, which says nothing of its parts). L's policy is L's
  estimate of what the robot meant to do; where it is wrong — a robot that stood in a queue
  for half its record can teach the IRL that it likes to stop — every failure lands on the
  wrong part.
* **Few steps** — fewer than :data:`~mirl.observations.discretise.AUTO_MIN_MOVES` steps of
  evidence (:func:`check_record_length`): the verdict would rest on the prior, and how often L
  sees a robot, which the steps do not weigh, can depend on its damage.
* **Pace** — the verdicts' healthy levels are rates of moves made at a healthy robot's pace,
  and the auto step (:func:`~mirl.observations.discretise.auto_step_seconds`) takes the pace
  from the robots' own moves. Where nothing in the record moves at a healthy pace, a failed
  step is no evidence of a part: a sparse tracker's record whose moves stay within one cell
  only at a multiple of its interval fits two paces (robots slowed down alike, or a tracker
  faster than their decisions; :func:`~mirl.observations.discretise.off_pace`), and so do
  one read at the interval itself in which no robot is seen to cross a cell on most of its
  free steps (:func:`no_pace_setter`, a test at the checks' level) and a
  smooth track in which no robot keeps a decision rhythm at the step
  (:func:`~mirl.observations.discretise.decision_rhythm`). A
  record-level check from the poses (:func:`check_pace`): a grid CSV carries no pace.
* **Few trials** — a feature whose Eq. 4 estimate is pinned at 0 by fewer than
  :data:`PINNED_TRIALS` trials of the subsets that fix it: a part called dead on a handful of
  failures, which a few misread steps make. (Pinned at 1 by few trials is a short record of a
  healthy part, no claim: counted as a failure of the check, it failed 10 % of the grid's
  records, which fit.)

Steps a failed check points at (the unexplained steps, the stalled runs, the stays in a jam)
are *misfit steps*: the verdict leaves them out, never counting them as failures of a part, and
says what it left out and why. A failed check also tempers the verdict
(:data:`~mirl.learning.verdicts.MODEL_TRUST`): a probability computed under models the record
does not fit is not L's to state as high.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.special import bdtr, bdtrc, chdtrc, ndtr

from mirl.observations.discretise import AUTO_MIN_MOVES

__all__ = [
    "ALPHA",
    "MISREAD_RATE",
    "PINNED_TRIALS",
    "MOVES_SHARE",
    "Check",
    "ModelFit",
    "check_unexplained",
    "check_slides",
    "check_stalls",
    "check_jams",
    "held_back",
    "check_moves",
    "MOVE_KINDS",
    "check_pinned",
    "check_record_length",
    "check_pace",
    "PACE_SETTER",
    "CRAWL_SHARE",
    "no_pace_setter",
    "sets_the_pace",
    "stay_runs",
    "longest_run_tail",
    "model_fit",
]

ALPHA = 1e-3
"""A check fails when the record's statistic is this improbable under the models."""
MISREAD_RATE = 0.03
"""The share of steps a tracker may misread (a heading or a cell at a boundary) before
unexplained steps count against the models."""
PINNED_TRIALS = 10
"""Fewer trials than this do not pin a feature at 0 or 1."""
MOVES_SHARE = 0.05
"""The share of steps by which the kinds of moves must be off for the moves check to fail: a
third of the damage margin (0.15), so that what the check lets pass cannot move a part's
success probability across the margin by itself."""
CRAWL_SHARE = 0.5
"""A robot that stays in its cell on this share of its free steps that kept their heading
crosses a cell at most every other step: a crawl, not a healthy pace. A robot sets the pace only
where its stays fall below this share beyond chance (:func:`no_pace_setter`)."""


@dataclass(frozen=True)
class Check:
    """One check's outcome.

    Parameters
    ----------
    name : str
        ``"unexplained"``, ``"slides"``, ``"stalls"``, ``"jams"``, ``"moves"``, ``"few
        trials"``, ``"in the way"``, ``"few steps"`` or ``"pace"``.
    ok : bool
        Whether the record passes it.
    p_value : float or None
        How probable a statistic this extreme is under the models (None: not a tail test).
    reason : str
        What the record shows, in words (empty when ok).
    fix : str
        What would make the record fit (empty when nothing in the user's hands would).
    misfit : ndarray of int
        Indices (into the steps checked) of the steps the failure points at.
    """

    name: str
    ok: bool
    p_value: float | None = None
    reason: str = ""
    fix: str = ""
    misfit: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def to_dict(self) -> dict:
        """The check's JSON record.

        Returns
        -------
        dict
            ``ok``, and ``p_value`` and ``reason`` where it has them.
        """
        out: dict = {"ok": self.ok}
        if self.p_value is not None:
            out["p_value"] = float(f"{self.p_value:.3g}")
        if self.reason:
            out["reason"] = self.reason
        return out


@dataclass(frozen=True)
class ModelFit:
    """Whether a robot's record fits L's motion models, and what was left out.

    Parameters
    ----------
    checks : tuple of Check
        The checks the record was put to.
    left_out : mapping of str to int
        Steps left out of the verdict's evidence, by reason (misfit steps, and steps in
        another robot's way).
    untempered : float or None
        For a record that fails a check, the verdict's probability under L's motion models
        alone, before the tempering (:data:`~mirl.learning.verdicts.MODEL_TRUST`) gave the
        prior the rest; None for a record that fits.
    """

    checks: tuple[Check, ...] = ()
    left_out: Mapping[str, int] = field(default_factory=dict)
    untempered: float | None = None

    @property
    def ok(self) -> bool:
        """Whether the record passes every check."""
        return all(c.ok for c in self.checks)

    @property
    def reason(self) -> str:
        """The failed checks in words (empty when the record fits)."""
        return "; ".join(c.reason for c in self.checks if not c.ok)

    @property
    def fix(self) -> str:
        """What would make the record fit."""
        return "; ".join(dict.fromkeys(c.fix for c in self.checks if not c.ok and c.fix))

    def to_dict(self) -> dict:
        """The fit's JSON record (``verdict.fit``).

        Returns
        -------
        dict
            ``ok``, ``reason``, ``fix`` (where there is one), ``untempered`` (4 decimals,
            where it is set), ``checks`` (by name) and ``left_out`` (by reason).
        """
        out: dict = {"ok": self.ok, "reason": self.reason}
        if self.fix:
            out["fix"] = self.fix
        if self.untempered is not None:
            out["untempered"] = round(float(self.untempered), 4)
        out["checks"] = {c.name: c.to_dict() for c in self.checks}
        out["left_out"] = {k: int(v) for k, v in self.left_out.items() if v}
        return out


# ---- unexplained steps --------------------------------------------------------------------------
def _rare_steps(flags: np.ndarray, rate: float) -> tuple[int, int, float, np.ndarray]:
    """The k of n steps flagged, P(at least k of n) when each is flagged with probability
    ``rate`` (1 when none is), and their indices."""
    flags = np.asarray(flags, dtype=bool)
    n, k = len(flags), int(flags.sum())
    p = 1.0 if k == 0 else float(bdtrc(k - 1, n, rate))
    return k, n, p, np.flatnonzero(flags)


def check_unexplained(
    unexplained: np.ndarray, long_moves: np.ndarray, *, rate: float = MISREAD_RATE
) -> Check:
    """Unexplained steps against a tolerated misread rate.

    Parameters
    ----------
    unexplained : ndarray of bool, shape (n,)
        Per observed step, whether no action explains it.
    long_moves : ndarray of bool, shape (n,)
        Per observed step, whether it moved more than one cell.
    rate : float, default :data:`MISREAD_RATE`
        The share of steps a tracker may misread.

    Returns
    -------
    Check
        ``"unexplained"``; its misfit steps are the unexplained ones.
    """
    unexplained = np.asarray(unexplained, dtype=bool)
    k, n, p, misfit = _rare_steps(unexplained, rate)
    if p >= ALPHA:
        return Check("unexplained", True, p, misfit=misfit)
    n_long = int(np.asarray(long_moves, dtype=bool)[unexplained].sum())
    reason = f"{k} of {n} observed steps are explained by no action"
    fix = ""
    if n_long:
        reason += f" ({n_long} moved more than one cell in one step)"
        fix = "a shorter time step (`step_seconds`), at which a move is one cell"
    return Check("unexplained", False, p, reason, fix, misfit)


# ---- slides -------------------------------------------------------------------------------------
def check_slides(slid: np.ndarray, *, rate: float = MISREAD_RATE) -> Check:
    """Backward moves the robot stayed at, against two misreads in a row.

    Parameters
    ----------
    slid : ndarray of bool, shape (n,)
        Per observed step, whether it moved the robot to the cell behind it and the next
        observed step started there and stayed in that cell.
    rate : float, default :data:`MISREAD_RATE`
        The share of steps a tracker may misread; a kept backward move needs two in a row.

    Returns
    -------
    Check
        ``"slides"``; its misfit steps are the backward moves.
    """
    k, n, p, misfit = _rare_steps(slid, rate**2)
    if p >= ALPHA:
        return Check("slides", True, p, misfit=misfit)
    reason = (
        f"{k} of {n} observed steps moved it to the cell behind it, where it stayed: no action "
        "moves a robot backwards, so it was pushed or slid (wedged on a wall or another robot), "
        "and its stays are not its parts' failures"
    )
    return Check("slides", False, p, reason, "", misfit)


# ---- stalls -------------------------------------------------------------------------------------
def stay_runs(t: np.ndarray, stayed: np.ndarray) -> list[np.ndarray]:
    """The runs of consecutive steps on which the robot stayed put.

    Parameters
    ----------
    t : ndarray of int, shape (n,)
        The steps' times (consecutive when one apart).
    stayed : ndarray of bool, shape (n,)
        Whether the robot stayed put.

    Returns
    -------
    list of ndarray of int
        Each run's indices into ``t``.
    """
    t, stayed = np.asarray(t, dtype=int), np.asarray(stayed, dtype=bool)
    runs: list[np.ndarray] = []
    start = None
    for i in range(len(t) + 1):
        going_on = i < len(t) and stayed[i] and start is not None and t[i] == t[i - 1] + 1
        if going_on:
            continue
        if start is not None:
            runs.append(np.arange(start, i))
            start = None
        if i < len(t) and stayed[i]:
            start = i
    return runs


def longest_run_tail(q: np.ndarray, t: np.ndarray, length: int, rho: float = 0.0) -> np.ndarray:
    """P(some run of at least ``length`` consecutive stays) under stay probabilities.

    Consecutive steps follow a two-state Markov chain with lag-1 correlation ``rho``
    (P(stay | stayed) = q + ρ (1 − q), P(stay | moved) = q (1 − ρ)), and the probability is the
    Poisson clumping approximation 1 − exp(−E[runs of that length begun]).

    Parameters
    ----------
    q : ndarray of shape (r, n)
        Each step's probability of staying put under r posterior draws.
    t : ndarray of int, shape (n,)
        The steps' times (a gap breaks a run).
    length : int
        The run's length.
    rho : float, default 0
        The lag-1 correlation of consecutive steps.

    Returns
    -------
    ndarray of shape (r,)
        The probability under each draw.
    """
    q = np.clip(np.atleast_2d(np.asarray(q, dtype=float)), 1e-12, 1 - 1e-12)
    t = np.asarray(t, dtype=int)
    r, n = q.shape
    if length < 1 or n < length:
        return np.zeros(r) if length >= 1 else np.ones(r)
    follows = np.zeros(n, dtype=bool)
    follows[1:] = np.diff(t) == 1
    stay_after_stay = q + rho * (1 - q)
    stay_after_move = q * (1 - rho)
    # log P(stays at i+1 … i+length-1 | stayed at i), 0 where a gap breaks the stretch
    csum = np.concatenate([np.zeros((r, 1)), np.cumsum(np.log(stay_after_stay), axis=1)], axis=1)
    breaks = np.concatenate([[0], np.cumsum(~follows)])
    idx = np.arange(n - length + 1)
    log_chain = csum[:, idx + length] - csum[:, idx + 1]
    unbroken = breaks[idx + length] == breaks[idx + 1]
    log_chain = np.where(unbroken[None, :], log_chain, -np.inf)
    # a run begins at i: a stay after a move (or after a gap, or at the first step)
    first = q.copy()
    after = np.flatnonzero(follows)
    first[:, after] = (1 - q[:, after - 1]) * stay_after_move[:, after]
    expected = (first[:, idx] * np.exp(log_chain)).sum(axis=1)
    return -np.expm1(-expected)


def check_stalls(
    t: np.ndarray, stayed: np.ndarray, q: np.ndarray, rho: float = 0.0
) -> tuple[Check, int]:
    """The record's longest stall against the posterior predictive.

    Parameters
    ----------
    t : ndarray of int, shape (n,)
        The steps' times.
    stayed : ndarray of bool, shape (n,)
        Whether the robot stayed put.
    q : ndarray of shape (r, n)
        Each step's probability of staying put under r posterior draws.
    rho : float, default 0
        The lag-1 correlation of consecutive steps the record's dispersion grants.

    Returns
    -------
    check : Check
        ``"stalls"``; its misfit steps are those of runs the models make improbable.
    limit : int
        The shortest stall the models make improbable (0 when the check passes).
    """
    runs = stay_runs(t, stayed)
    longest = max((len(r) for r in runs), default=0)
    if longest == 0:
        return Check("stalls", True, 1.0), 0
    p = float(longest_run_tail(q, t, longest, rho).mean())
    if p >= ALPHA:
        return Check("stalls", True, p), 0
    limit = longest
    while limit > 1 and float(longest_run_tail(q, t, limit - 1, rho).mean()) < ALPHA:
        limit -= 1
    misfit = np.concatenate([r for r in runs if len(r) >= limit])
    n_runs = sum(len(r) >= limit for r in runs)
    reason = (
        f"stood still for {longest} steps in a row ({n_runs} stall"
        f"{'s' if n_runs > 1 else ''} of {limit} or more), longer than its failures explain "
        f"(p = {p:.1g}): jammed or wedged"
    )
    return Check("stalls", False, p, reason, "", misfit), limit


# ---- jams ---------------------------------------------------------------------------------------
def check_jams(
    stayed: np.ndarray, near: np.ndarray, q: np.ndarray, dispersion: float = 1.0
) -> Check:
    """Stays beside another robot against the posterior predictive.

    A normal tail of the stays on steps with another robot within one cell, its variance
    inflated by the record's dispersion.

    Parameters
    ----------
    stayed : ndarray of bool, shape (n,)
        Whether the robot stayed put.
    near : ndarray of bool, shape (n,)
        Whether another robot was seen within one cell.
    q : ndarray of shape (r, n)
        Each step's probability of staying put under r posterior draws.
    dispersion : float, default 1
        The record's variance inflation.

    Returns
    -------
    Check
        ``"jams"``; its misfit steps are the stays beside another robot.
    """
    stayed, near = np.asarray(stayed, dtype=bool), np.asarray(near, dtype=bool)
    k = int((stayed & near).sum())
    if k == 0:
        return Check("jams", True, 1.0)
    qn = np.atleast_2d(q)[:, near]
    mean, var = qn.sum(axis=1), (qn * (1 - qn)).sum(axis=1) * dispersion
    p = float(ndtr(-(k - 0.5 - mean) / np.sqrt(np.maximum(var, 1e-12))).mean())
    if p >= ALPHA:
        return Check("jams", True, p)
    reason = (
        f"stood still on {k} of {int(near.sum())} steps beside another robot, where its "
        f"failures explain about {float(mean.mean()):.0f} (p = {p:.1g}): robots jammed"
    )
    return Check("jams", False, p, reason, "", np.flatnonzero(stayed & near))


def held_back(
    stayed: np.ndarray,
    held: np.ndarray,
    labels: np.ndarray,
    dispersion: float = 1.0,
    min_free: int = AUTO_MIN_MOVES,
) -> Check:
    """The steps another robot was in the way of, and whether the robot stayed put on them
    more often than on the others.

    The held steps are always the check's misfit steps, left out of the evidence: they are
    chosen by where another robot was, not by what the step did, so leaving them out biases
    nothing, while counting them lets a robot queueing behind a slow one look broken (a
    robot held on a few steps gives a test too few of them to tell). The check itself is a
    one-sided Mantel–Haenszel test over the steps' labels (Mantel & Haenszel 1959), its
    variance inflated by the record's dispersion, says whether physical robots in each other's
    way blocked or pushed each other, as on a grid they do not. The check fails when they did,
    the held steps are more than half the robot's steps and fewer than ``min_free`` are left:
    L's policy for the robot is learned from its whole record, so it then takes the other
    robot's pace for the robot's own wish, and the labels of the few steps left are not the
    robot's intentions. With ``min_free`` free steps or more — the steps L needs to read a
    robot's own pace — the robot's own moves outweigh the queue in what L learned of it.

    .. versionchanged:: 0.2.0
       The held steps are left out whatever the test says, and the check enters the record's
       fit, failing only where the held steps are most of the record and few free steps are
       left.

    Parameters
    ----------
    stayed : ndarray of bool, shape (n,)
        Whether the robot stayed put.
    held : ndarray of bool, shape (n,)
        Whether another robot was in its way
        (:func:`~mirl.learning.verdicts.held_by_others`).
    labels : ndarray of int, shape (n,)
        The steps' labels (the strata).
    dispersion : float, default 1
        The record's variance inflation.
    min_free : int, default AUTO_MIN_MOVES
        Free steps (not held) from which the robot's own moves outweigh the queue
        (:data:`~mirl.observations.discretise.AUTO_MIN_MOVES`, 20).

    Returns
    -------
    Check
        ``"in the way"``; its misfit steps are the held steps (left out whether it fails or
        not).
    """
    stayed, held = np.asarray(stayed, dtype=bool), np.asarray(held, dtype=bool)
    labels = np.asarray(labels, dtype=int)
    misfit = np.flatnonzero(held)
    if not held.any() or held.all():
        return Check("in the way", True, 1.0, misfit=misfit)
    observed = expected = variance = 0.0
    for a in np.unique(labels):
        m = labels == a
        n, n_held, k = m.sum(), (m & held).sum(), (m & stayed).sum()
        if n < 2 or n_held in (0, n):
            continue
        observed += (m & held & stayed).sum()
        expected += n_held * k / n
        variance += n_held * (n - n_held) * k * (n - k) / (n**2 * (n - 1))
    if variance <= 0:
        return Check("in the way", True, 1.0, misfit=misfit)
    p = float(ndtr(-(observed - expected - 0.5) / np.sqrt(dispersion * variance)))
    free = int((~held).sum())
    if p >= ALPHA or 2 * held.sum() <= len(held) or free >= min_free:
        return Check("in the way", True, p, misfit=misfit)
    reason = (
        f"another robot was in its way on {int(held.sum())} of its {len(held)} steps, and it "
        f"stayed put on {observed:.0f} of them, more than its stays elsewhere account for "
        f"({expected:.0f}; p = {p:.1g}): most of its record is the other robot's pace, which "
        f"L's policy for it learned as its own, and {free} free steps cannot outweigh it"
    )
    return Check("in the way", False, p, reason, "", misfit)


# ---- the kinds of moves -------------------------------------------------------------------------
MOVE_KINDS = ("forward", "turn", "stay")
"""The kinds of move the moves check counts: the intended states of forward, of either turn,
and staying put (which a forward step into a wall is too)."""


def check_moves(
    observed: np.ndarray,
    probabilities: np.ndarray,
    dispersion: float = 1.0,
    min_share: float = MOVES_SHARE,
) -> Check:
    """The record's counts of each kind of move against the posterior predictive.

    For a draw, the counts of a record drawn from it have mean E = Σ_t q_t and covariance
    φ Σ_t (diag q_t − q_t q_tᵀ), and the record's Mahalanobis distance from E is χ² with k − 1
    degrees of freedom (the central limit theorem); p is its tail averaged over the draws. The
    check fails when p is below :data:`ALPHA` and the counts are off by at least ``min_share`` of
    the steps (half the sum of the kinds' differences): on a long record a few mislabelled steps
    are significant and harmless.

    Parameters
    ----------
    observed : ndarray of int, shape (n,)
        Each step's kind, an index into :data:`MOVE_KINDS`.
    probabilities : ndarray of shape (r, n, k)
        The probability of each kind at each step under r posterior draws.
    dispersion : float, default 1
        The record's variance inflation φ.
    min_share : float, default :data:`MOVES_SHARE`
        How far off the counts must be, as a share of the steps.

    Returns
    -------
    Check
        ``"moves"``.
    """
    observed = np.asarray(observed, dtype=int)
    q = np.asarray(probabilities, dtype=float)
    r, n, k = q.shape
    if n == 0 or r == 0:
        return Check("moves", True, 1.0)
    q = q / np.maximum(q.sum(axis=2, keepdims=True), 1e-300)
    counts = np.bincount(observed, minlength=k)[:k].astype(float)
    expected = q.sum(axis=1)  # (r, k)
    cov = np.einsum("rnk,kl->rkl", q, np.eye(k)) - np.einsum("rnk,rnl->rkl", q, q)
    cov = dispersion * cov + 1e-6 * np.eye(k)
    diff = counts[None, :] - expected
    d2 = np.einsum("rk,rk->r", diff, np.linalg.solve(cov, diff[:, :, None])[:, :, 0])
    p = float(chdtrc(k - 1, d2).mean())
    mean = expected.mean(axis=0)
    if p >= ALPHA or 0.5 * np.abs(counts - mean).sum() < min_share * n:
        return Check("moves", True, p)
    far = int(np.argmax(np.abs(counts - mean) / np.sqrt(np.maximum(mean, 1))))
    reason = (
        f"{_kind_words(far)} on {counts[far]:.0f} of {n} steps where L's policy and models "
        f"expect about {mean[far]:.0f} (p = {p:.1g}): L's policy does not say what the robot "
        "meant to do"
    )
    return Check("moves", False, p, reason)


def _kind_words(kind: int) -> str:
    return ("moved forward", "turned", "stayed put")[kind]


# ---- few trials ---------------------------------------------------------------------------------
def check_pinned(
    probabilities: Mapping[str, float],
    counts: Sequence[tuple[Sequence[str], float, float]],
    *,
    min_trials: int = PINNED_TRIALS,
) -> Check:
    """Eq. 4's estimates pinned at 0 by few trials.

    Parameters
    ----------
    probabilities : mapping of str to float
        Eq. 4's feature probabilities.
    counts : sequence of (subset, successes, trials)
        The labelled steps' pooled counts.
    min_trials : int, default :data:`PINNED_TRIALS`
        Fewer trials than this of the subsets holding a feature do not pin it.

    Returns
    -------
    Check
        ``"few trials"``.
    """
    pinned = []
    for f, p in probabilities.items():
        if p > 0.005:
            continue
        trials = sum(n for sub, _, n in counts if f in sub)
        if 0 < trials < min_trials:
            pinned.append(f"{f.replace('_', ' ')} at {p:.0f} by {trials:g} trials")
    if not pinned:
        return Check("few trials", True)
    return Check("few trials", False, None, "Eq. 4 pins " + ", ".join(pinned))


# ---- few steps ----------------------------------------------------------------------------------
def check_record_length(n_steps: int, *, min_steps: int = AUTO_MIN_MOVES) -> Check:
    """A record of fewer than ``min_steps`` steps of evidence.

    The verdict weighs the steps L saw whole, not how often L saw the robot, and how often it
    sees a robot can hang on the robot's damage: at L's door on the grid (boyd2-healthy, 450
    steps, 14 %), J with a wheel at 0.7 was seen on a median 18.5 steps and never in a quarter
    of 60 runs, a healthy J on 52.5. Of J's records with fewer than 20 steps seen at both ends,
    86 % were a damaged robot's, and the steps alone said "no part" at 0.9 or more on 15 of
    them, 6 falsely. A verdict from so few steps holds mostly the prior's confidence, and a
    record that short cannot rule out what made it short: the check fails, and the verdict is
    tempered as on any record that fails a check.

    Parameters
    ----------
    n_steps : int
        The steps the verdict's evidence holds (observed at both ends, none left out).
    min_steps : int, default AUTO_MIN_MOVES
        Fewer steps than this fail the check
        (:data:`~mirl.observations.discretise.AUTO_MIN_MOVES`, 20).

    Returns
    -------
    Check
        ``"few steps"``.
    """
    if n_steps >= min_steps:
        return Check("few steps", True)
    return Check(
        "few steps", False, None,
        f"the verdict rests on {n_steps} {'step' if n_steps == 1 else 'steps'} L saw from start "
        f"to end, fewer than {min_steps}; a robot that fails its moves comes into view less "
        "often, which those steps cannot show",
        "watch it longer or see more of its route (a longer record, a wider view)",
    )  # fmt: skip


# ---- pace ---------------------------------------------------------------------------------------
PACE_SETTER = (
    "the robots' decision interval as `step_seconds`, if the step given is not it; if it is, a "
    "robot seen in the same record crossing a cell on most of its free steps, for no step tells "
    "robots slowed down alike from healthy ones that decide less often"
)
"""What fits a record whose every robot crawls at the step the user gave (:func:`no_pace_setter`):
the robots' decision interval where the step given is not it (a step too short for them), and
where it is, only a robot moving at a healthy pace beside them; asking for the step again would
send the user round in a circle."""


def check_pace(off_pace: str, *, step_given: bool = False) -> Check:
    """The record's step against the robots' pace (module doc).

    Parameters
    ----------
    off_pace : str
        Why the record's step may be no healthy robot's pace
        (:attr:`~mirl.observations.trajectories.Trajectories.off_pace`); empty when nothing
        says so.
    step_given : bool, default False
        Whether the user gave the record's step. Then the remedy says what fits where the
        step given is the robots' decision interval too (:data:`PACE_SETTER`).

    Returns
    -------
    Check
        ``"pace"``; no misfit steps (which of the steps that stayed in their cell a healthy
        robot would have completed, nothing in the record says).
    """
    if not off_pace:
        return Check("pace", True)
    return Check(
        "pace",
        False,
        None,
        off_pace,
        PACE_SETTER if step_given else "the robots' decision interval as `step_seconds`",
    )


def no_pace_setter(
    steps: Mapping[str, tuple[int, int]],
    interval: float,
    min_steps: int = AUTO_MIN_MOVES,
    *,
    given: bool = False,
) -> str:
    """Why nothing in a record read at its tracker's interval, or at a step the user gave,
    moves at a healthy pace; empty when a robot does.

    A sparse tracker's record is read one pose a step where no multiple of its interval keeps
    the robots' moves within one cell (:func:`~mirl.observations.discretise.auto_step_seconds`).
    The interval is then the tracker's, not necessarily the robots' decisions'. Where no robot
    L saw on enough free steps is seen to cross a cell on most of them, the poses fit two paces,
    as a multiple of the interval does (:func:`~mirl.observations.discretise.off_pace`): robots
    slowed down alike, or healthy robots slower than their tracker, whose unfinished moves read
    as failed ones. One robot crossing a cell on most of its free steps is the healthy pace the
    others' failures are judged against. A step the user gives is the robots' pace by their
    word, and the same moves ask it: read at 0.5 s, healthy grid robots that decide every 2 s
    stay in their cells on three steps of four, and every one of them would be called damaged
    at full confidence.

    "Seen to cross a cell on most of them" is a test, not a share: the robot's stays are fewer
    than :data:`CRAWL_SHARE` of its free steps beyond chance, their binomial lower tail at
    that share below :data:`ALPHA`, the other checks' level. Healthy robots read at half their
    decision interval stay on half their free steps, so a share compared with one half is a
    coin toss there: a healthy physical pair's poses as Nav2's AMCL publishes them, read at 1 s,
    had one robot stay on 230 of 466 free steps, 0.49, which as a share set the pace and let
    both robots be called damaged at confidence 1.00. A robot the record shows moving faster
    than that still sets it: one with a motor at 0.6, read at the auto step, stayed on 109 of
    303.

    Parameters
    ----------
    steps : mapping of str to (int, int)
        Per robot, its free steps (no other robot L saw in its way,
        :func:`~mirl.learning.verdicts.held_by_others`) that kept its heading: those that
        stayed in its cell and those that moved to the next.
    interval : float
        The record's step (s): the tracker's interval, or the step the user gave.
    min_steps : int, default AUTO_MIN_MOVES
        Fewer such steps do not judge a robot's pace (the auto step's own minimum,
        :data:`~mirl.observations.discretise.AUTO_MIN_MOVES`, 20).
    given : bool, default False
        Whether ``interval`` is a step the user gave rather than the tracker's interval.

    Returns
    -------
    str
        The reason in words (the pace check's, :func:`check_pace`), or "" when a robot L saw
        on ``min_steps`` such steps or more sets the pace (:func:`sets_the_pace`), or none was
        seen that long.

    .. versionchanged:: 0.2.0
        A robot sets the pace by a binomial test at :data:`ALPHA`, not by a share of at most
        :data:`CRAWL_SHARE`.
    """
    judged = {
        name: (stay, stay + move)
        for name, (stay, move) in steps.items()
        if stay + move >= min_steps
    }
    if not judged or any(sets_the_pace(stay, n) for stay, n in judged.values()):
        return ""
    shares = ", ".join(f"{name} {stay}/{n}" for name, (stay, n) in judged.items())
    unseen = (
        f"no robot is seen to cross a cell on most of its free steps that keep their heading "
        f"(stayed in its cell: {shares})"
    )
    if given:
        return (
            f"at the step given ({interval:g} s), {unseen}: robots slowed down alike, or "
            "healthy robots that decide less often than that — the poses cannot tell which, "
            "and a move a robot had not finished by the step is a failed move"
        )
    return (
        f"at the tracker's interval ({interval:g} s), the record's step, {unseen}: robots "
        "slowed down alike, or healthy robots slower than their tracker — the poses cannot "
        "tell which, and a move a slow robot had not finished by the step is a failed move"
    )


def sets_the_pace(stayed: int, steps: int, alpha: float = ALPHA) -> bool:
    """Whether a robot's free steps show it crossing a cell on most of them beyond chance: its
    ``stayed`` of ``steps`` below :data:`CRAWL_SHARE` of them, the binomial probability of so
    few stays at that share below ``alpha`` (:func:`no_pace_setter`).

    Parameters
    ----------
    stayed : int
        The free steps that kept the robot's heading and stayed in its cell.
    steps : int
        All its free steps that kept their heading.
    alpha : float, default ALPHA
        The test's level.

    Returns
    -------
    bool
        Whether the robot sets the pace.
    """
    return steps > 0 and float(bdtr(stayed, steps, CRAWL_SHARE)) < alpha


def model_fit(checks: Sequence[Check], left_out: Mapping[str, int]) -> ModelFit:
    """The record's fit from its checks and the steps left out of the evidence.

    Parameters
    ----------
    checks : sequence of Check
        The checks.
    left_out : mapping of str to int
        Steps left out, by reason.

    Returns
    -------
    ModelFit
        The fit.
    """
    return ModelFit(tuple(checks), dict(left_out))
