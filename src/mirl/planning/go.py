"""L's go decision: vectorised backward induction over (L state, t) with the first-order detection
hazard, scoring every go time in one pass.

Reaching the goal earns goal_reward (once: the goal is absorbing); being seen costs
detection_penalty and ends the run, so the value of a state is goal_reward·P(goal reached
unseen) − detection_penalty·P(seen first) within the horizon; with both at 1 a positive value
means L predicts success to be more likely than detection, with the run's default penalty 0.5
(see :mod:`mirl.experiments.episode`) that success beats half the detection risk. In L's start
cell only *leaving* is allowed: the go time is chosen outside the MDP (waiting in the room is
safe), so V_t(start) is the value of going at t and one backward pass scores every go time. L
goes at the argmax over the window if it is positive.

**Detection hazard.** The probability of being seen on a step is not independent of the previous
steps: a patroller that did not see L a step ago is mostly still not looking. Treating the
per-step detection probabilities d_t(c) as independent multiplies the same uncertainty at every
step and is far too pessimistic (on boyd2 with the true models it predicts ≈0.01 success where
the exact survival is ≈0.2). The MDP therefore uses the *first-order* hazard h_t(c | c') =
P(seen on c at t | not seen on c' at t−1), computed per robot from its predicted marginal and
one-step matrix and combined over robots as independent; it depends on L's move (c' → c), so the
arrival term is evaluated per non-zero of L's transition matrix. hazard="independent" gives
the naive d_t(c) for comparison.

The continuation (1 − h) multiplies the next value, i.e. the dynamics are time-indexed, which
:func:`mirl.mdp.backward_induction` (stationary transitions) cannot express; the loop below is
the same one-sparse-product-per-step recursion with that factor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirl.planning.belief import Prediction
from mirl.planning.observer import ObserverModel
from mirl.world.domain import STOP

__all__ = ["GO_RULES", "ObserverPlan", "solve_observer_mdp", "waiting_value"]

GO_RULES = ("adaptive", "value")
"""How L decides to go (docs/design.md, "The go rule"): ``adaptive`` stops on its stated
probability of success against the value of waiting; ``value`` is the published rule (the best
go value in the window, if positive)."""


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
    mask = _start_cell_mask(model)  # cached per model: re-plans do not rebuild it
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


_MASKS: dict[int, tuple[ObserverModel, np.ndarray]] = {}


def _start_cell_mask(model: ObserverModel) -> np.ndarray:
    cached = _MASKS.get(id(model))
    if cached is None or cached[0] is not model:
        if len(_MASKS) > 32:
            _MASKS.clear()
        cached = _MASKS[id(model)] = (model, _build_start_cell_mask(model))
    return cached[1]


def _build_start_cell_mask(model: ObserverModel) -> np.ndarray:
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


# ---- the adaptive rule's value of waiting ----------------------------------------------------
def waiting_value(chances, opportunities: int) -> float:
    """The chance of success L can expect by waiting for ``opportunities`` more chances to go,
    each drawn from the empirical distribution ``chances`` (the success probabilities it has
    stated so far), taking the first one better than what waiting on would bring, and going
    at the last one whatever it is — the finite-horizon optimal-stopping recursion
    v₀ = 0, vⱼ = E[max(X, vⱼ₋₁)]. Zero when no opportunity is left (L goes now) or nothing
    was stated yet."""
    x = np.asarray(chances, dtype=float)
    v = 0.0
    if x.size == 0:
        return v
    for _ in range(max(0, int(opportunities))):
        new = float(np.maximum(x, v).mean())
        if new <= v + 1e-12:  # converged: the best chance stated
            break
        v = new
    return v
