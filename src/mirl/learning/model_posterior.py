"""Model sets drawn from a posterior of the patrollers' models, for the chance L acts on.

L's stated chance of getting through is exact under its point models, and L goes at the
moments their error favours going (docs/design.md, "The stated probability of success"). Under
a posterior of the models the chance's own uncertainty is carried: the chance averaged over
model sets drawn from the posterior is the posterior predictive probability of success, and a
posterior predictive probability stays calibrated whatever data-dependent rule picks the moment
it is stated at (the decision is a function of the data; the average is the expectation given
the data). :func:`draw_models` draws such sets, each a whole
:class:`~mirl.learning.results.LearnResult` that the belief filter and the planner take as they
take the point models:

* **each robot's T** from the posterior over its transition-feature probabilities that the
  fault verdicts already use (:func:`mirl.learning.verdicts.posterior_draws`: the labelled
  steps' pooled counts, softened by the soft policy, and a prior under which most parts are
  healthy). A robot L never saw gets draws from that prior, not the uninformed 0.5 of Eq. 4's
  maximum-entropy solution (a robot that fails half its moves, which L's filter moves as
  nearly immobile);
* **each robot's reward** from a block bootstrap of what L saw of it: its record cut into
  *visits* (a run of observed steps and the occluded gap after it, up to the next re-entry),
  visits drawn with replacement and joined with the junctions left out of the likelihood (the
  IRL's ``exclude``), and the sequence objective refitted from the point solution's weights,
  under that draw's T. Or a Laplace approximation at the IRL optimum (``reward="laplace"``).
  A robot L never saw borrows, draw by draw, the mean reward of the robots it saw;
* **the interaction**: the equilibrium drawn by its posterior weights (``equilibrium_weights``).

Each draw's policy is the greedy policy of hard value iteration with its reward under its T,
as for the point models.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from mirl.learning.equilibria import potential_meetings
from mirl.learning.irl import IRLProblem, OccludedMaxEntIRL
from mirl.learning.methods import REWARD_SOURCES, get_method
from mirl.learning.results import LearnResult, RobotModel
from mirl.learning.soft_policy import soft_policy_iteration
from mirl.learning.transitions import (
    observed_steps,
    perception_labels,
    policy_labels,
    true_policy_labels,
)
from mirl.learning.verdicts import failure_dispersion, posterior_draws
from mirl.mdp import TabularMDP, value_iteration
from mirl.world.motion import transition_matrix
from mirl.world.scenario import Scenario

__all__ = ["PARTS", "REWARD_DRAWS", "draw_models", "visits", "bootstrap_series"]

PARTS = ("transitions", "rewards", "equilibrium")
"""What a draw may vary; the parts not drawn stay at the point models'."""
REWARD_DRAWS = (
    "bootstrap",
    "newton",
    "newton1",
    "laplace",
    "laplace-sir",
    "laplace-sir-prior",
    "point",
)


@dataclass
class _Robot:
    """What the draws of one robot start from."""

    series: np.ndarray
    model: RobotModel
    labels: np.ndarray | None


def draw_models(
    learned: LearnResult,
    series: Sequence[np.ndarray],
    scenario: Scenario,
    *,
    visible: np.ndarray,
    n_draws: int = 8,
    parts: Sequence[str] = PARTS,
    reward: str = "bootstrap",
    shared: bool | str = False,
    irl_options: dict | None = None,
    random_state: int = 0,
    info: dict | None = None,
    motion: str = "method",
) -> list[LearnResult]:
    """``n_draws`` model sets from the posterior of ``learned``'s models (module doc).

    Parameters
    ----------
    learned : LearnResult
        The point models (as :func:`~mirl.learning.learn.learn` returns them).
    series : sequence of ndarray of shape (horizon,)
        Per robot the states L saw it in, -1 where unseen: the record ``learned`` was learned
        from.
    scenario : Scenario
        The scenario L models (its domain, discount, game, error model and faults).
    visible : ndarray of shape (S,) of bool
        The states L sees.
    n_draws : int, default 8
        Model sets drawn.
    parts : sequence of {"transitions", "rewards", "equilibrium"}
        What is drawn; a method's part that is not learned (a fixed p, a true reward) is never
        drawn.
    reward : {"bootstrap", "newton", "laplace", "point"}, default "bootstrap"
        How a robot's reward is drawn: refitted on block-bootstrap records; the same, refitted
        by a few Newton steps with the record's Hessian; a Laplace approximation; or its point
        weights (its uncertainty then only from ``shared``).
    shared : bool or "pooled", default False
        Mix each robot's reward draws with the other robots' by how well its record supports
        "one kind, one reward" against "a reward of its own" (:func:`_shared_kind`); or,
        ``"pooled"``, weigh the team's hypotheses "every robot its own reward" and "one reward,
        learned from every robot's record" (:func:`_pooled_kind`).
    irl_options : dict, optional
        The IRL's options for the refits (default: the estimator's).
    random_state : int, default 0
        Seeds the draws.
    info : dict, optional
        Receives diagnostics: ``shared_kind``, per robot the weight of the shared hypothesis.
    motion : {"method", "posterior"}, default "method"
        Where the draws' T come from: the method's own (drawn from the feature posterior only
        for a method whose T is made of features), or the feature posterior for every method
        (a fixed p or DBN-EM's tabular T then serve L's planning alone, not its chance).

    Returns
    -------
    list of LearnResult
        Equally weighted draws.
    """
    unknown = set(parts) - set(PARTS)
    if unknown:
        raise ValueError(f"unknown parts {sorted(unknown)} (known: {', '.join(PARTS)})")
    if reward not in REWARD_DRAWS:
        raise ValueError(f"unknown reward draws '{reward}' (known: {', '.join(REWARD_DRAWS)})")
    if n_draws < 1:
        raise ValueError(f"n_draws must be at least 1, got {n_draws}")
    row = get_method(learned.method)
    domain = scenario.domain
    rng = np.random.default_rng(random_state)
    series = [np.asarray(x, dtype=int) for x in series]
    true_reward = not REWARD_SOURCES[row.reward].built  # given: the true policies label
    labels = _labels(learned, series, scenario, true_reward, row.relabels)
    robots = [_Robot(x, m, lab) for x, m, lab in zip(series, learned.robots, labels, strict=True)]
    features = row.learns and row.has_feature_probabilities  # a T made of features, learned
    draw_T = "transitions" in parts and (features or motion == "posterior")
    draw_R = "rewards" in parts and REWARD_SOURCES[row.reward].built
    # T per robot per draw
    Ts: list[list[sp.csr_array]] = []
    probs: list[list[dict[str, float]]] = []
    for r in robots:
        if draw_T:
            p = _feature_draws(scenario, r, n_draws, int(rng.integers(2**31)), row.relabels)
            probs.append(p)
            Ts.append([transition_matrix(domain, q, scenario.error_model) for q in p])
        else:
            probs.append([dict(r.model.feature_probabilities)] * n_draws)
            Ts.append([r.model.transitions] * n_draws)
    # reward per robot per draw
    if draw_R:
        W = _reward_draws(scenario, robots, Ts, visible, reward, shared, irl_options or {}, rng,
                          info)  # fmt: skip
    else:
        W = [[np.asarray(r.model.weights, dtype=float)] * n_draws for r in robots]
    # equilibrium per draw
    eqs = [learned.equilibrium] * n_draws
    if "equilibrium" in parts and learned.equilibrium_weights:
        w = np.asarray(learned.equilibrium_weights, dtype=float)
        candidates = scenario.game.equilibria()
        pick = rng.choice(len(w), size=n_draws, p=w / w.sum())
        eqs = [candidates[k] for k in pick]
    out = []
    start: dict[tuple[int, bytes], np.ndarray] = {}  # policy iteration's starts
    for k in range(n_draws):
        models = []
        for i, r in enumerate(robots):
            T, drawn = Ts[i][k], W[i][k]
            assert drawn is not None
            w = drawn
            if T is r.model.transitions and w is r.model.weights:
                policy = r.model.policy
            else:
                R = domain.rewards(w.tolist())
                key = (i, w.tobytes())
                if key not in start:  # the greedy policy of this reward under the point T
                    point = TabularMDP(r.model.transitions, R, scenario.discount)
                    start[key] = value_iteration(point).policy
                policy = greedy_policy_of(T, R, scenario.discount, start[key])
            models.append(
                replace(
                    r.model, weights=w, feature_probabilities=probs[i][k], transitions=T,
                    policy=policy, behavior_accuracy=None,
                )
            )  # fmt: skip
        pairs = {p: eqs[k] for p in scenario.pairs} if eqs[k] is not learned.equilibrium else None
        out.append(
            replace(
                learned, robots=tuple(models), equilibrium=eqs[k],
                pair_equilibria=learned.pair_equilibria if pairs is None else pairs,
            )
        )  # fmt: skip
    return out


def _reward_draws(scenario, robots, Ts, visible, reward, shared, options, rng, info):
    """Each robot's reward weights per draw (:func:`draw_models`' ``reward`` and ``shared``),
    the steps where two robots may meet left out of every likelihood, as the IRL leaves them."""
    domain = scenario.domain
    n, n_draws = len(robots), len(Ts[0])
    exclude = np.zeros(len(robots[0].series), dtype=bool)
    for i in range(n):
        for j in range(i + 1, n):
            exclude |= potential_meetings(domain, robots[i].series, robots[j].series)
    draws: dict[str, Callable[..., list[np.ndarray | None]]] = {
        "bootstrap": _bootstrap_rewards, "newton": _newton_rewards,
        "newton1": partial(_newton_rewards, steps=1),
        "laplace": _laplace_rewards, "point": _point_rewards,
        "laplace-sir": partial(_laplace_rewards, candidates=4),
        "laplace-sir-prior": partial(_laplace_rewards, candidates=4, prior=1.0),
    }  # fmt: skip
    W: list[list[np.ndarray | None]] = []
    for i, r in enumerate(robots):
        if not (r.series >= 0).any():
            W.append([None] * n_draws)
            continue
        W.append(draws[reward](scenario, r, Ts[i], exclude, visible, options, rng))
    if shared == "pooled":
        W = _pooled_kind(scenario, robots, W, exclude, visible, options, rng, info)
    elif shared:
        W = _shared_kind(scenario, robots, W, exclude, visible, options, rng, info)
    seen = [[v for v in w if v is not None] for w in W if w[0] is not None]
    for i, r in enumerate(robots):
        if W[i][0] is None and seen:  # never seen: the mean of the seen robots', per draw
            W[i] = [np.mean([w[k] for w in seen], axis=0) for k in range(n_draws)]
        elif W[i][0] is None:  # L saw no robot: the point weights (learn()'s zeros)
            W[i] = [np.asarray(r.model.weights, dtype=float)] * n_draws
    return W


def greedy_policy_of(
    transitions: sp.csr_array,
    rewards: np.ndarray,
    discount: float,
    policy: np.ndarray,
    max_iter: int = 50,
) -> np.ndarray:
    """The greedy optimal policy by policy iteration (Howard 1960) from ``policy``: evaluate
    exactly, improve, until no state changes its action; the result's actions are the first
    maxima of Q, as value iteration's greedy policy takes them. From the greedy policy of a
    nearby model it ends in two or three linear solves where value iteration sweeps hundreds of
    times to its tolerance."""
    S, A = rewards.shape
    T = sp.csr_array(transitions)
    pol = np.asarray(policy, dtype=int).copy()
    for _ in range(max_iter):
        P = T[np.arange(S) * A + pol]
        V = spla.spsolve(
            sp.identity(S, format="csc") - discount * sp.csc_array(P), rewards[np.arange(S), pol]
        )
        Q = rewards + discount * (T @ V).reshape(S, A)
        new = Q.argmax(axis=1)
        # keep an action that is still optimal (no cycling between tied actions)
        keep = Q[np.arange(S), pol] >= Q[np.arange(S), new] - 1e-12
        if keep.all():
            return Q.argmax(axis=1)
        pol = np.where(keep, pol, new)
    return pol


def _labels(
    learned: LearnResult,
    series: list[np.ndarray],
    scenario: Scenario,
    true_reward: bool,
    relabels: bool,
) -> list[np.ndarray]:
    """The labels the point T was learned from: for a true reward the true policies', for a
    method that relabels the fixed point of its rounds (the point policies' and equilibrium's
    labels), else perception's."""
    if not true_reward and not relabels:
        out = []
        for x in series:
            lab = np.full(len(x), -1, dtype=int)
            t, s, s_next = observed_steps(x)
            lab[t] = perception_labels(scenario.domain, s, s_next)
            out.append(lab)
        return out
    if true_reward:
        return true_policy_labels(scenario, series)
    policies = [r.policy for r in learned.robots]
    return policy_labels(scenario.domain, series, policies, learned.equilibrium)


# The pooled counts the feature posterior is drawn from: each labelled step spread over the
# actions that could have produced it. The verdicts weigh steps under every candidate motion
# model instead (mirl.learning.verdicts.robot_uncertainty); a draw of T here needs one T per
# draw under the scenario's motion model, which the pooled counts under that model give.
def _soft_counts(
    domain,
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


def _feature_draws(
    scenario: Scenario, robot: _Robot, n_draws: int, seed: int, soften: bool
) -> list[dict[str, float]]:
    """``n_draws`` feature probabilities resampled from the verdicts' posterior of one robot,
    its labels softened by its soft policy when they came from its learned policy
    (``soften``), as the verdicts do."""
    domain = scenario.domain
    features = domain.feature_map.features
    m = robot.model
    t, s, s_next = observed_steps(robot.series)
    assert robot.labels is not None
    lab = robot.labels[t]
    soft = None
    if len(t) and soften:
        R = domain.rewards(np.asarray(m.weights, dtype=float).tolist())
        _, _, soft, _ = soft_policy_iteration(m.transitions, R, scenario.discount)
    successes, trials = _soft_counts(domain, s, lab, s_next, m.transitions, soft, m.policy)
    dispersion = (
        failure_dispersion(domain, t, s, lab, s_next, m.feature_probabilities)
        if m.feature_probabilities
        else 1.0
    )
    observations = [
        (sub, k / dispersion, c / dispersion)
        for sub, k, c in zip(domain.subsets, successes, trials, strict=True)
        if c > 0
    ]
    definition = scenario.faults
    healthy = {f: definition.healthy_level(f) for f in features}
    p, w = posterior_draws(features, observations, healthy, random_state=seed)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(w), size=n_draws, p=w)
    return [{f: float(p[k, j]) for j, f in enumerate(features)} for k in pick]


def visits(series: np.ndarray) -> list[tuple[int, int]]:
    """The record of one robot cut into visits: (first, last) step indices, inclusive, of a run
    of observed steps and the occluded gap after it up to and including the next re-entry (the
    record's last visit may end unseen).

    Parameters
    ----------
    series : ndarray of shape (horizon,) of int
        The states L saw the robot in, -1 where unseen.

    Returns
    -------
    list of (int, int)
        The visits' first and last steps, in order.
    """
    x = np.asarray(series)
    seen = x >= 0
    entries = np.flatnonzero(seen & ~np.concatenate(([False], seen[:-1])))
    out = []
    for k, a in enumerate(entries):
        b = int(entries[k + 1]) if k + 1 < len(entries) else len(x) - 1
        if b > a:
            out.append((int(a), b))
    return out


def bootstrap_series(
    series: np.ndarray, exclude: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """One bootstrap record: as many visits as the record has, drawn with replacement and
    joined; the step leaving each visit's last state is excluded (it is no move of the robot:
    the next visit starts elsewhere), as are the steps the record excludes.

    Parameters
    ----------
    series : ndarray of shape (horizon,) of int
        The states L saw the robot in, -1 where unseen.
    exclude : ndarray of shape (horizon,) of bool
        The steps left out of the likelihood.
    rng : numpy.random.Generator
        The random stream.

    Returns
    -------
    series : ndarray of int
        The joined visits.
    exclude : ndarray of bool
        Their excluded steps.
    """
    x = np.asarray(series)
    parts = visits(x)
    if not parts:
        return x, np.asarray(exclude)
    pick = rng.integers(0, len(parts), size=len(parts))
    # a visit that ends unseen (the record's last) says the robot stayed away to the end: its
    # gap goes last, once; the other copies keep their observed steps only (followed by another
    # visit, the gap would read as a re-entry where that visit starts)
    trailing = len(parts) - 1 if x[parts[-1][1]] < 0 else None
    pick = np.sort(pick) if trailing is not None else pick
    xs, ex = [], []
    for n, k in enumerate(pick):
        a, b = parts[k]
        if k == trailing and n < len(pick) - 1:
            b = a + int(np.flatnonzero(x[a : b + 1] < 0)[0]) - 1  # its last observed step
        xs.append(x[a : b + 1])
        e = np.asarray(exclude[a : b + 1], dtype=bool).copy()
        e[-1] = True
        ex.append(e)
    return np.concatenate(xs), np.concatenate(ex)


def _bootstrap_rewards(scenario, robot: _Robot, Ts, exclude, visible, options, rng):
    """Reward weights refitted on block-bootstrap records, one per draw, each under that draw's
    T, started from the point weights."""
    domain = scenario.domain
    out = []
    for T in Ts:
        x, ex = bootstrap_series(robot.series, exclude, rng)
        if not (x >= 0).any():
            out.append(np.asarray(robot.model.weights, dtype=float))
            continue
        problem = IRLProblem(domain.reward_features, T, scenario.discount, visible)
        irl = OccludedMaxEntIRL(**{**options, "n_restarts": 1})
        irl.fit(
            problem, x, exclude=ex, initial_weights=np.asarray(robot.model.weights, dtype=float)
        )
        out.append(irl.weights_)
    return out


def _total_loss(scenario, T, series, exclude, visible, options):
    """The IRL's negative log-posterior of one record as a function of θ, with its gradient
    (``loss(θ)``; ``loss(θ, False)``: the value alone): the estimator's loss times the steps it
    is averaged over (the loss is per step)."""
    problem = IRLProblem(scenario.domain.reward_features, T, scenario.discount, visible)
    irl = OccludedMaxEntIRL(**{**options, "n_restarts": 1})
    irl._prepare(problem, series, None, exclude)

    def loss(theta, grad=True):
        if not grad:
            return irl._loss(theta) * irl._n_steps
        value, g = irl._loss(theta, True)
        return value * irl._n_steps, g * irl._n_steps

    return loss


def _hessian(loss, theta, eps=1e-4) -> np.ndarray:
    """The Hessian of ``loss`` at ``theta`` by central differences of its exact gradient."""
    K = len(theta)
    H = np.zeros((K, K))
    for j in range(K):
        e = np.zeros(K)
        e[j] = eps
        H[:, j] = (loss(theta + e)[1] - loss(theta - e)[1]) / (2 * eps)
    return 0.5 * (H + H.T)


def _point_rewards(scenario, robot: _Robot, Ts, exclude, visible, options, rng):
    """The point weights in every draw (the reward's uncertainty left to the shared-kind
    mixture alone)."""
    return [np.asarray(robot.model.weights, dtype=float) for _ in Ts]


def _laplace_rewards(
    scenario, robot: _Robot, Ts, exclude, visible, options, rng, candidates=0, prior=None
):
    """Reward weights drawn from a Laplace approximation at the point weights: N(θ̂, H⁻¹), H the
    Hessian of the negative log-posterior, under the point T. With ``candidates`` > 0, that
    many times more draws from the approximation widened 1.5 times, weighed by the exact
    posterior over their density and resampled (sampling importance resampling, Rubin 1988):
    the quadratic approximation does not see where the likelihood falls off a cliff (weights
    under which the robot would not move as L saw it move), the weights do."""
    loss = _total_loss(scenario, robot.model.transitions, robot.series, exclude, visible, options)
    theta = np.asarray(robot.model.weights, dtype=float)
    if prior is not None:  # N(0, s² I), s = prior × |θ̂|: weights of the learned scale
        s2 = (prior * max(float(np.linalg.norm(theta)), 1.0)) ** 2
        plain = loss

        def loss(x, grad=True):
            out = plain(x, grad)
            extra = 0.5 * float(x @ x) / s2
            return (out[0] + extra, out[1] + x / s2) if grad else out + extra

    vals, vecs = np.linalg.eigh(_hessian(loss, theta))
    # the optimiser's stopping rule can leave θ̂ short of the optimum, even at a saddle: a
    # direction of negative curvature is taken at its size (the importance weights then move
    # the draws to where the posterior is), and a flat one is wide, not infinite
    vals = np.maximum(np.abs(vals), 1e-4 * max(float(np.abs(vals).max()), 1e-2))
    scale = vecs / np.sqrt(vals)
    K = len(Ts)
    if not candidates:
        return [theta + scale @ rng.standard_normal(len(theta)) for _ in range(K)]
    base = loss(theta, False)
    return importance_resample(
        theta, scale, lambda x: base - loss(x, False), K, candidates * K, rng
    )


def importance_resample(center, scale, log_posterior, n_draws, n_candidates, rng, widen=1.5):
    """``n_draws`` draws from a density known up to a constant (``log_posterior``) by sampling
    importance resampling (Rubin 1988): ``n_candidates`` from the Gaussian N(center,
    (widen · scale)(widen · scale)ᵀ), weighed by the density over theirs, resampled
    systematically. The proposal is widened so that the target's tails stay covered."""
    z = rng.standard_normal((n_candidates, len(center)))
    draws = center + widen * z @ np.asarray(scale).T
    log_q = -0.5 * (z**2).sum(axis=1)  # the proposal's log density, up to a constant
    log_w = np.array([log_posterior(x) for x in draws]) - log_q
    log_w[~np.isfinite(log_w)] = -np.inf  # a density that could not be evaluated: weight 0
    if not np.isfinite(log_w).any():
        return [np.asarray(center, dtype=float)] * n_draws
    w = np.exp(log_w - log_w.max())
    w /= w.sum()
    u = (rng.random() + np.arange(n_draws)) / n_draws
    pick = np.minimum(np.searchsorted(np.cumsum(w), u), len(w) - 1)
    return [draws[k] for k in pick]


def _newton_rewards(scenario, robot: _Robot, Ts, exclude, visible, options, rng, steps=3):
    """Reward weights of a block bootstrap refitted by Newton's method with the record's
    Hessian: from θ̂, θ ← θ − H⁻¹ g_b(θ) (halved while the bootstrap record's loss rises), at
    most ``steps`` steps, g_b the gradient of a bootstrap record's negative log-posterior, H the
    record's Hessian at θ̂, all under the point T. With the Hessian of a record close to a
    bootstrap record's it lands near the refit's optimum in a few gradients instead of an
    L-BFGS run (``steps=1``: the linearised bootstrap)."""
    T = robot.model.transitions
    loss = _total_loss(scenario, T, robot.series, exclude, visible, options)
    theta = np.asarray(robot.model.weights, dtype=float)
    H = _hessian(loss, theta)
    vals, vecs = np.linalg.eigh(H)
    inverse = (vecs / np.maximum(vals, 1e-6)) @ vecs.T
    out = []
    for _ in Ts:
        x, ex = bootstrap_series(robot.series, exclude, rng)
        if not (x >= 0).any():
            out.append(theta.copy())
            continue
        loss_b = _total_loss(scenario, T, x, ex, visible, options)
        th = theta.copy()
        f, g = loss_b(th)
        for _ in range(steps):
            step = inverse @ g
            for _ in range(6):
                f_new, g_new = loss_b(th - step)
                if f_new <= f:
                    break
                step = step / 2
            else:
                break
            th, f, g = th - step, f_new, g_new
        out.append(th)
    return out


def _shared_kind(scenario, robots, W, exclude, visible, options, rng, info):
    """Each seen robot's reward draws as a mixture of two hypotheses, weighed by its own record
    (Bayesian model averaging, even prior odds): it has a reward of its own (its draws;
    evidence: its record's log-likelihood at its point weights less the Schwarz penalty, d/2
    times the log of its likelihood terms, Schwarz 1978) or it is of one kind with another
    robot L saw and shares its reward (that robot's draws; evidence: its record's likelihood at
    that robot's point weights, averaged over the other robots). One likelihood per other
    robot: on a large floor a likelihood is a pass over the whole record."""
    n = len(robots)
    out = list(W)
    for i, r in enumerate(robots):
        if W[i][0] is None:
            continue
        others = [j for j in range(n) if j != i and W[j][0] is not None]
        if not others:
            continue
        loss = _total_loss(scenario, r.model.transitions, r.series, exclude, visible, options)
        x = r.series
        terms = int(((x[:-1] >= 0) & (x[1:] >= 0)).sum()) + len(visits(x))
        penalty = 0.5 * len(r.model.weights) * np.log(max(terms, 2))
        log_own = -loss(np.asarray(r.model.weights, dtype=float))[0] - penalty
        ll = np.array([-loss(np.asarray(robots[j].model.weights, dtype=float))[0] for j in others])
        top = ll.max()
        log_team = float(np.log(np.mean(np.exp(ll - top))) + top)
        p_team = float(1.0 / (1.0 + np.exp(np.clip(log_own - log_team, -50, 50))))
        which = np.exp(ll - top) / np.exp(ll - top).sum()  # whose kind, given one kind
        pick = rng.random(len(W[i])) < p_team
        out[i] = [
            W[others[rng.choice(len(others), p=which)]][k] if shared else own
            for k, (shared, own) in enumerate(zip(pick, W[i], strict=True))
        ]
        if info is not None:
            info.setdefault("shared_kind", {})[r.model.name] = p_team
    return out


def _pooled_kind(scenario, robots, W, exclude, visible, options, rng, info):
    """The team's reward draws under two hypotheses, weighed by the whole record (Bayesian
    model averaging, even prior odds, each evidence by Schwarz's approximation, Schwarz 1978):
    every seen robot has a reward of its own (their own draws; d parameters per robot), or the
    robots are of one kind and share one reward (d parameters in all), learned from every seen
    robot's record at once — each under its own T — and drawn as the robots' own are (a Laplace
    approximation at the pooled optimum, importance-resampled). Each draw takes one hypothesis
    for the whole team."""
    from scipy.optimize import minimize

    seen = [i for i, w in enumerate(W) if w[0] is not None]
    if len(seen) < 2:
        return W
    K = len(W[seen[0]])
    losses = [
        _total_loss(scenario, robots[i].model.transitions, robots[i].series, exclude, visible,
                    options)
        for i in seen
    ]  # fmt: skip

    def total(theta, grad=True):
        parts = [f(theta, grad) for f in losses]
        if not grad:
            return float(sum(parts))
        return float(sum(v for v, _ in parts)), np.sum([g for _, g in parts], axis=0)

    d = len(robots[seen[0]].model.weights)
    terms = []
    for i in seen:
        x = robots[i].series
        terms.append(int(((x[:-1] >= 0) & (x[1:] >= 0)).sum()) + len(visits(x)))
    own = sum(
        -f(np.asarray(robots[i].model.weights, dtype=float), False) - 0.5 * d * np.log(max(n, 2))
        for f, i, n in zip(losses, seen, terms, strict=True)
    )
    start = np.mean([robots[i].model.weights for i in seen], axis=0)
    res = minimize(total, start, jac=True, method="L-BFGS-B", options={"maxfun": 100})
    pooled = np.asarray(res.x, dtype=float)
    one = -total(pooled, False) - 0.5 * d * np.log(max(sum(terms), 2))
    p_one = float(1.0 / (1.0 + np.exp(np.clip(own - one, -50, 50))))
    if info is not None:
        info["one_kind"] = p_one
    pick = rng.random(K) < p_one
    if not pick.any():
        return W
    vals, vecs = np.linalg.eigh(_hessian(total, pooled))
    vals = np.maximum(np.abs(vals), 1e-4 * max(float(np.abs(vals).max()), 1e-2))
    base = total(pooled, False)
    draws = importance_resample(
        pooled, vecs / np.sqrt(vals), lambda x: base - total(x, False), K, 4 * K, rng
    )
    out = list(W)
    for i in seen:
        out[i] = [draws[k] if pick[k] else W[i][k] for k in range(K)]
    return out
