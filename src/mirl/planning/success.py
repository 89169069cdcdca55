"""The probability that L, going now along its plan, reaches its goal unseen: the belief filter
propagated along L's policy (docs/design.md, "The stated probability of success").

L's state and the patrollers' are tracked together as a mixture: for every state L may be in
after k steps (its moves fail with its model's failure probability, leaving it in place), the
probability of being there unseen and the belief about the patrollers given that. Each step the
patrollers' belief is propagated by the filter's own step (the learned policies, T and the
equilibrium at meetings), L moves, and the belief is conditioned on no patroller seeing L's new
cell — the detection rule checked after every step of a run. Beliefs reaching the same L state
are merged (their mixture is the exact conditional), so the work per step is one propagation per
L state still carrying probability. With the joint filter (two patrollers, or a team whose joint
fits) the result is exact under L's learned models up to ``prune`` (the probability of L states
dropped, at most ``prune`` each, counted as failure). The factored filter (teams whose joint does
not fit) is approximate twice over, and stated so (``exact=False``): it multiplies the robots'
probabilities of not seeing L as if independent, and L's possible states share one belief about
the patrollers (the mixture of theirs), so a step costs one propagation instead of one per L
state — on a large floor L's failed moves spread it over a dozen states per step, and per-state
beliefs cost ~1.5 s an evaluation on ``office`` against ~0.1 s shared. After the plan's last step
L follows a shortest path (in a run it re-plans there), at most ``extra`` steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirl.planning.belief import BeliefFilter
from mirl.planning.go import ObserverPlan
from mirl.planning.observer import ObserverModel, shortest_path_policy

__all__ = ["SuccessEstimate", "success_probability"]


@dataclass(frozen=True)
class SuccessEstimate:
    """What going now along a plan leads to, under L's models.

    Parameters
    ----------
    success : float
        P(goal reached unseen).
    detected : float
        P(seen first).
    unfinished : float
        The probability left on the way after the last step (and pruned).
    exact : bool
        Whether the computation is exact (joint filter, per-state beliefs) or approximate.
    """

    success: float
    detected: float
    unfinished: float
    exact: bool


def success_probability(
    belief_filter: BeliefFilter,
    model: ObserverModel,
    plan: ObserverPlan,
    *,
    k0: int = 0,
    extra: int = 0,
    prune: float = 1e-6,
    belief: np.ndarray | None = None,
    shared: bool | None = None,
) -> SuccessEstimate:
    """P(L reaches its goal unseen) when it leaves its start cell now and follows its plan.

    See the module doc for the computation.

    Parameters
    ----------
    belief_filter : BeliefFilter
        The patrollers' filter; its step propagates the belief.
    model : ObserverModel
        L's MDP.
    plan : ObserverPlan
        The plan whose ``policy`` L follows.
    k0 : int, default 0
        The plan's index at which L leaves.
    extra : int, default 0
        At most this many steps along a shortest path after the plan's last step.
    prune : float, default 1e-6
        L states carrying less probability are dropped (counted as failure).
    belief : ndarray, optional
        The patrollers' belief, in the filter's form; the filter's current one by default.
    shared : bool, optional
        Let L's states share one belief; by default only with the factored filter, where the
        result is approximate anyway.

    Returns
    -------
    SuccessEstimate
        Success, detection and unfinished probabilities; ``exact`` is False whenever either
        approximation is made.

    Raises
    ------
    ValueError
        The filter has no belief yet.
    """
    if belief is None:
        belief = belief_filter.belief
    if belief is None:
        raise ValueError("the filter has no belief yet: call update() first")
    dom = model.domain
    A = dom.n_actions
    T = model.transitions.tocsr()  # row s·A + a: the outcomes of L doing a in s
    fallback = shortest_path_policy(model)
    not_seeing = model.not_seeing
    exact = belief_filter.joint or belief_filter.n_robots == 1  # one robot: nothing to factor
    if shared is None:
        shared = not exact
    per_state = not shared
    mix: dict[int, tuple[float, np.ndarray]] = {model.start_state: (1.0, belief)}
    success = detected = dropped = 0.0
    steps = plan.horizon - k0 + extra
    for j in range(steps):
        k = k0 + j
        nxt: dict[int, tuple[float, np.ndarray]] = {}
        conditioned: dict[int, tuple[np.ndarray, float]] = {}  # L's next state → (post, kept)
        moved = None if per_state else belief_filter.propagate(next(iter(mix.values()))[1])
        for s, (w, b) in mix.items():
            a = int(plan.policy[k, s]) if k < plan.horizon else int(fallback[s])
            if per_state:
                moved = belief_filter.propagate(b)
            assert moved is not None
            lo, hi = T.indptr[s * A + a], T.indptr[s * A + a + 1]
            for s2, q in zip(T.indices[lo:hi], T.data[lo:hi], strict=True):
                if per_state or s2 not in conditioned:
                    conditioned[s2] = belief_filter.condition_unseen(moved, not_seeing(int(s2)))
                post, kept = conditioned[s2]
                mass = w * float(q)
                detected += mass * (1.0 - kept)
                mass *= kept
                if model.goal[s2]:
                    success += mass
                elif mass > prune:
                    _merge(nxt, int(s2), mass, post)
                else:
                    dropped += mass
        if shared and nxt:  # one belief for all of L's states: their mixture
            total = sum(w for w, _ in nxt.values())
            common: np.ndarray = np.sum([w * b for w, b in nxt.values()], axis=0) / total
            nxt = {s: (w, common) for s, (w, _) in nxt.items()}
        mix = nxt
        if not mix:
            break
    unfinished = dropped + sum(w for w, _ in mix.values())
    return SuccessEstimate(success, detected, unfinished, exact and per_state)


def _merge(mix: dict[int, tuple[float, np.ndarray]], s: int, w: float, b: np.ndarray) -> None:
    """Add probability ``w`` with belief ``b`` to L's state ``s`` (the mixture's belief)."""
    if s not in mix:
        mix[s] = (w, b)
        return
    w0, b0 = mix[s]
    mix[s] = (w0 + w, (w0 * b0 + w * b) / (w0 + w))
