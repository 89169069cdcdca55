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
the naive d_t(c) for comparison. The two are the rows of :data:`HAZARDS`, each a function
that fetches the rows the backward pass multiplies by.

The continuation (1 − h) multiplies the next value, i.e. the dynamics are time-indexed, which
:func:`mirl.mdp.backward_induction` (stationary transitions) cannot express; the loop below is
the same one-sparse-product-per-step recursion with that factor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mirl._registry import Registry
from mirl._validation import Boolean, Interval, check_argument
from mirl.planning.belief import Prediction, StreamedPrediction
from mirl.planning.observer import ObserverModel
from mirl.world.domain import STOP

__all__ = [
    "HAZARDS",
    "HazardModel",
    "ObserverPlan",
    "TimedPolicy",
    "solve_observer_mdp",
    "waiting_value",
]

# The go rules that call this planner are strategies of the run (mirl.experiments.go_rules),
# in the table the command line reads, mirl.experiments.options.GO_RULES.

Rows = Callable[[Prediction | StreamedPrediction, int, int], np.ndarray]


@dataclass(frozen=True)
class HazardModel:
    """How the backward pass reads the chance of L being seen on a step (module doc).

    Parameters
    ----------
    name : str
        What ``solve_observer_mdp(hazard=...)`` takes.
    description : str
        What it assumes, in a few words.
    rows : callable
        ``rows(prediction, lo, hi)`` -> (hi − lo, n_pairs): steps lo … hi − 1 of the
        probability that L is seen on the second cell of each of L's cell pairs
        (``prediction.pairs``).
    """

    name: str
    description: str
    rows: Rows


def _markov_rows(prediction: Prediction | StreamedPrediction, lo: int, hi: int) -> np.ndarray:
    return prediction.hazard_rows(lo, hi)


def _independent_rows(
    prediction: Prediction | StreamedPrediction, lo: int, hi: int
) -> np.ndarray:
    return prediction.detection_rows(lo, hi)[:, prediction.pairs[:, 1]]


HAZARDS: Registry[HazardModel] = Registry("hazard model", (
    HazardModel(
        "markov", "first order: P(seen at t | not seen a step before), per L's move",
        _markov_rows,
    ),
    HazardModel(
        "independent", "each step's detection probability taken as independent of the last",
        _independent_rows,
    ),
))  # fmt: skip
"""The hazard models of the backward pass, by name (the first-order one is the default)."""

# hazard rows fetched from a prediction at once by the backward pass (a streamed prediction
# computes them block by block from its checkpoints, so its blocks bound the memory)
_ROWS_AT_ONCE = 64


class TimedPolicy:
    """L's greedy action at each (step k, state s) of a plan, kept as the changes between steps.

    The last step's row in full, then per earlier step only the states whose action differs from
    the step after. Most states keep their action from one step to the next, so this holds
    O(S + changes) instead of the K × S table; ``policy[k, s]`` is the action.

    Parameters
    ----------
    K : int
        The plan's steps.
    S : int
        L's states.
    """

    def __init__(self, K: int, S: int) -> None:
        self.shape = (K, S)
        self._steps: list[np.ndarray] = []
        self._states: list[np.ndarray] = []
        self._actions: list[np.ndarray] = []
        self._last: np.ndarray | None = None
        self._keys: np.ndarray | None = None

    def _record(self, k: int, row: np.ndarray) -> None:
        """The row of step k; rows come in from the last step down to step 0."""
        changed = np.arange(len(row)) if self._last is None else np.flatnonzero(row != self._last)
        self._steps.append(np.full(len(changed), k, dtype=np.int64))
        self._states.append(changed)
        self._actions.append(row[changed].astype(np.int8))
        self._last = row.copy()

    def _finish(self) -> None:
        K, _ = self.shape
        steps, states = np.concatenate(self._steps), np.concatenate(self._states)
        keys = states.astype(np.int64) * K + steps
        order = np.argsort(keys, kind="stable")
        self._keys, self.actions = keys[order], np.concatenate(self._actions)[order]
        self._steps = self._states = self._actions = []
        self._last = None

    @property
    def n_changes(self) -> int:
        """Entries kept: the last step's row and every later change."""
        assert self._keys is not None
        return len(self._keys)

    def __getitem__(self, index: tuple[int, int]) -> int:
        k, s = index
        K, S = self.shape
        if not (0 <= k < K and 0 <= s < S):
            raise IndexError(f"policy index {index} outside {self.shape}")
        assert self._keys is not None
        # the first kept entry of state s at a step >= k: every state has one at step K - 1
        return int(self.actions[np.searchsorted(self._keys, s * K + k)])

    def to_array(self) -> np.ndarray:
        """The (K, S) table (for small plans and tests).

        Returns
        -------
        ndarray of int8, shape (K, S)
            ``policy[k, s]`` for every step and state.
        """
        K, S = self.shape
        return np.array([[self[k, s] for s in range(S)] for k in range(K)], dtype=np.int8)


# ---- planning --------------------------------------------------------------------------------
@dataclass(frozen=True)
class ObserverPlan:
    """Solution of L's time-indexed MDP from time ``t0`` (index k ↔ time t0 + k).

    Parameters
    ----------
    t0 : int
        The time of step 0.
    values : ndarray of shape (K+1, S_L), or None
        V_k(s) when asked for (``keep_values``), else None.
    policy : TimedPolicy
        The greedy action at each step: ``policy[k, s]``.
    go_values : ndarray of shape (window+1,)
        ``go_values[k]`` is the value of leaving the start cell at t0 + k.
    go_time : int or None
        The k with the highest go value above the threshold (None if there is none).
    """

    t0: int
    values: np.ndarray | None  # (K+1, S_L) when asked for (``keep_values``), else None
    policy: TimedPolicy  # greedy action at each step: ``policy[k, s]``
    go_values: np.ndarray  # (window+1,)
    go_time: int | None

    @property
    def horizon(self) -> int:
        """K, the plan's steps."""
        return self.policy.shape[0]

    @property
    def value(self) -> float:
        """The go value at :attr:`go_time`, or the best go value when there is no go time."""
        return (
            float(self.go_values[self.go_time])
            if self.go_time is not None
            else float(self.go_values.max(initial=-np.inf))
        )


def solve_observer_mdp(
    model: ObserverModel,
    prediction: Prediction | StreamedPrediction,
    *,
    window: int | None = None,
    goal_reward: float = 1.0,
    detection_penalty: float = 1.0,
    min_value: float = 0.0,
    hazard: str = "markov",
    keep_values: bool = False,
) -> ObserverPlan:
    """Backward induction over K = ``prediction.steps`` steps (see the module doc).

    Without ``keep_values`` the pass holds one step's values at a time, the hazards a block of rows
    at a time, and the policy as its changes (:class:`TimedPolicy`), so its memory does not grow
    with K × S_L.

    Parameters
    ----------
    model : ObserverModel
        L's MDP.
    prediction : Prediction or StreamedPrediction
        The patrollers' predicted detection and hazards, at least one step.
    window : int, optional
        The go times considered are k ≤ ``window``; all k < K by default.
    goal_reward : float, default 1.0
        Earned on reaching the goal (once: the goal is absorbing).
    detection_penalty : float, default 1.0
        Paid on being seen, which ends the run.
    min_value : float, default 0.0
        A go time needs a go value above this.
    hazard : {"markov", "independent"}, default "markov"
        A row of :data:`HAZARDS`: the first-order hazard, or per-step detection probabilities
        taken as independent.
    keep_values : bool, default False
        Keep the (K+1, S_L) values in the plan.

    Returns
    -------
    ObserverPlan
        The go values of every go time in the window, the best one, and the policy.

    Raises
    ------
    ValueError
        A prediction of no step.
    OptionError
        A ``window`` that is not an integer ≥ 0, a reward, penalty or ``min_value`` that is
        not a finite number, or a ``keep_values`` that is not a bool (a ValueError).
    UnknownNameError
        An unknown hazard model.
    """
    K = prediction.steps
    if K < 1:
        raise ValueError("the plan needs at least one step of prediction")
    # checked here: a negative window failed as numpy's empty argmax, 2.5 was cut to 2, and a
    # NaN reward gave NaN go values
    check_argument("window", window, Interval(int, 0, None), None)
    for name, value in (
        ("goal_reward", goal_reward), ("detection_penalty", detection_penalty),
        ("min_value", min_value),
    ):  # fmt: skip
        check_argument(name, value, Interval(float))
    check_argument("keep_values", keep_values, Boolean())
    hazard_rows = HAZARDS.lookup(hazard).rows
    window = K - 1 if window is None else min(int(window), K - 1)
    dom = model.domain
    S, A = dom.n_states, dom.n_actions
    rows, cols, probs, pair = model._transition_entries
    mask = _start_cell_mask(model)  # cached per model: re-plans do not rebuild it
    values = np.zeros((K + 1, S)) if keep_values else None
    V = np.zeros(S)
    V[model.goal] = goal_reward
    if values is not None:
        values[K] = V
    go_values = np.empty(window + 1)
    policy = TimedPolicy(K, S)
    block, lo = np.empty((0, 0)), K + 1  # hazard rows lo … lo + len(block) − 1
    for k in range(K - 1, -1, -1):
        if k + 1 < lo:  # the next block of rows, going back in time
            lo = max(1, k + 2 - _ROWS_AT_ONCE)
            block = hazard_rows(prediction, lo, k + 2)
        h = block[k + 1 - lo, pair]
        cont = V[cols]  # the goal is absorbing: V[goal] = goal_reward
        Q = np.bincount(
            rows, weights=probs * ((1.0 - h) * cont - detection_penalty * h), minlength=S * A
        ).reshape(S, A)
        Q += mask
        policy._record(k, Q.argmax(axis=1))  # first maximum: forward wins ties
        V = Q.max(axis=1)
        V[model.goal] = goal_reward
        if values is not None:
            values[k] = V
        if k <= window:
            go_values[k] = V[model.start_state]
    policy._finish()
    best = int(np.argmax(go_values))
    go_time = best if go_values[best] > min_value else None
    return ObserverPlan(prediction.t0, values, policy, go_values, go_time)


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
    """The chance of success L can expect by waiting for ``opportunities`` more chances to go.

    Each chance is drawn from the empirical distribution ``chances`` (the success probabilities
    it has stated so far); L takes the first one better than what waiting on would bring, and
    goes at the last one whatever it is — the finite-horizon optimal-stopping recursion
    v₀ = 0, vⱼ = E[max(X, vⱼ₋₁)].

    Parameters
    ----------
    chances : array_like of float
        The success probabilities stated so far.
    opportunities : int
        The chances to go still to come.

    Returns
    -------
    float
        v at ``opportunities``; zero when no opportunity is left (L goes now) or nothing was
        stated yet.
    """
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
