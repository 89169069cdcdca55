"""Occluded maximum-entropy IRL with sparse interactions (mIRL*+Int, Bogert & Doshi 2014).

Per patroller the reward is R(s, a) = θ·φ(s, a). :class:`OccludedMaxEntIRL` learns θ from one
robot's occluded trajectory, with that robot's T (learned by mIRL*/T, or fixed);
:func:`weigh_equilibria` then scores the interaction game's candidate equilibria against both
robots' observations. All expectations are exact — distributions are propagated through T, never
sampled. π is the soft (maximum-entropy) policy of θ, π(a|s) ∝ exp(Q_soft(s, a)/τ); θ's scale is
learned (it is π's inverse temperature; τ only fixes units), kept finite by a small L2 term. The
policy handed on is the greedy policy of *hard* value iteration with θ and T.

**Objectives.**

* ``"counts"`` — the paper's. The expert's feature counts are taken on observed time steps only:
  Σ_t φ(s_t, a_t) over observed, labelled steps (an observed step whose action is unknown — the
  last one before the robot leaves view — contributes the model's expectation Σ_a π φ(s_t, a));
  occluded steps contribute nothing. The learner's counts are the expected counts on the same
  observable states and time steps, Σ_t Σ_{s visible} μ_t(s) Σ_a π(a|s) φ(s, a), μ_t propagated
  from the observed state: from the first observation (``anchor="first"``, default) or restarted
  at every re-entry into view (``"reentry"``; predicted visits during an occluded gap still count
  against the policy, late returns do not). Loss: squared difference per counted observed step.
* ``"likelihood"`` — log-likelihood of the observed labelled actions under π (the dual of
  maximum-causal-entropy IRL); it ignores occluded time. ``"both"`` adds it to ``"counts"``.
* ``"sequence"`` — log-likelihood of everything L saw of the robot, occlusion included:
  P(s_{t+1} | s_t) = Σ_a π(a|s_t) T(s_t, a, s_{t+1}) between observations, and across every
  occluded gap the exact probability of staying out of view and re-entering where it was seen
  (a forward filter, one column per gap). Time spent out of view is evidence about the hidden
  part of the route, which feature counts on visible cells cannot see: on boyd2 it is what
  identifies the lower-hallway and turn-around weights when only the upper hallway is visible.
  Actions are not needed (labels matter through T only).

**Optimisers.** Nelder–Mead (derivative-free, as in the paper) from seeded restarts, or
``"lbfgs"``: L-BFGS-B with the exact gradient — dπ/dθ through the soft successor features
(I − γP_π)⁻¹ φ_π; for the sequence objective the gap filter's gradient in forward mode (the
distributions and their K derivatives in one block-sparse step) on small models and in reverse
mode (:meth:`~mirl.learning.sequence.ObservedSequence.loglik_reverse`) on large ones
(``gradient``).

Soft values come from soft policy iteration (Newton's method on the soft Bellman equation,
quadratic convergence) warm-started from the previous evaluation.

**Defaults, measured** (``benchmarks/bench_learning.py --variants``: ``mirl-t`` on boyd2, 450
steps, 6 seeds, mean behaviour accuracy at observability 0.14 / 0.5 / 1.0): ``sequence`` 0.900 /
0.956 / 0.969 (L-BFGS and Nelder–Mead reach the same optima; median 0.9 s against 5.6 s per
learn); the paper's ``counts`` with Nelder–Mead 0.840 / 0.890 / 0.952 anchored at the first
observation, 0.509 / 0.878 / 0.952 re-anchored at re-entries (9–12 s); ``likelihood`` 0.878 /
0.837 / 0.940; ``both`` 0.637 / 0.872 / 0.938. Hence ``objective="sequence", optimizer="lbfgs",
n_restarts=1`` (restarts from random θ were measured to land on the same optimum); the paper's
configuration is ``objective="counts", optimizer="nelder-mead", n_restarts=3``.

Interactions (meetings, equilibria) are :mod:`mirl.learning.equilibria`.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import OptimizeResult, minimize

from mirl._estimator import EstimatorParams
from mirl._registry import Registry
from mirl.learning.options import IRL_OBJECTIVES as OBJECTIVES
from mirl.learning.options import IRL_OPTIMIZERS as OPTIMIZERS
from mirl.learning.sequence import BlockOperator, ObservedSequence
from mirl.learning.soft_policy import _Dynamics, soft_policy_iteration
from mirl.mdp import TabularMDP, value_iteration
from mirl.sparse import csr_matmul

__all__ = ["OBJECTIVES", "ANCHORS", "OPTIMIZERS", "IRLProblem", "OccludedMaxEntIRL"]

# the estimator's choices (module docstring), each carried out by this module's code;
# its objectives and optimizers are LearnOptions' choices (mirl.learning.options), read
# by the command line at start-up
ANCHORS = Registry.of_choices("anchor", {
    "first": "the counts' expected visits propagate from the first observation",
    "reentry": "and restart at every re-entry into view",
})  # fmt: skip
GRADIENTS = Registry.of_choices("gradient", {
    "auto": "reverse mode on large models, forward on small ones",
    "forward": "the derivatives propagated with the distributions",
    "reverse": "an adjoint pass over the filter's history",
})  # fmt: skip
# "auto" takes the sequence gradient in reverse mode from this many nonzeros of the forward
# operator ((2K + 1)·nnz(P_πᵀ)); below it the reverse pass's per-step bookkeeping eats what it
# saves (benchmarks/bench_gradients.py, forward/reverse per evaluation: boyd2 (3 888) 0.73-0.96,
# boydright-3 (8 346) 0.5-1.8 on a loaded machine, no clear gain; office (255 056) 2.25-2.29)
_REVERSE_FROM = 20_000
_HISTORY_BYTES = 1 << 30  # and while its two history arrays take at most this much memory


# ---- the problem -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class IRLProblem:
    """One robot's inverse problem: its MDP without a reward (reward features φ, transition
    model T, discount γ) and the states L can see it in. It is the data
    :meth:`OccludedMaxEntIRL.fit` learns θ against, with the robot's record; the estimator
    itself holds only how it fits, as a scikit-learn estimator does.

    Parameters
    ----------
    features : ndarray of shape (S, A, K)
        Reward features φ (kept as a float array).
    transitions : sparse array or ndarray of shape (S·A, S)
        The robot's transition model (learned by mIRL*/T, or fixed); kept as given, so that a
        caller can tell which model an estimator was fitted with.
    discount : float
        The robot's discount factor γ, in [0, 1).
    visible : ndarray of shape (S,) of bool, optional
        The states L can observe (all if None). Observed states are always treated as
        observable.

    Raises
    ------
    ValueError
        If ``features`` is not (S, A, K), ``transitions`` not (S·A, S), ``visible`` not (S,), or
        ``discount`` outside [0, 1).
    """

    features: np.ndarray
    transitions: sp.sparray | np.ndarray
    discount: float
    visible: np.ndarray | None = None

    def __post_init__(self) -> None:
        features = np.asarray(self.features, dtype=float)
        if features.ndim != 3:
            raise ValueError(f"features must be (S, A, K), got shape {features.shape}")
        S, A, _ = features.shape
        if self.transitions.shape != (S * A, S):
            raise ValueError(f"transitions must be ({S * A}, {S}), got {self.transitions.shape}")
        shape = None if self.visible is None else np.shape(self.visible)
        if shape not in (None, (S,)):
            raise ValueError(f"visible must be {(S,)}, got {shape}")
        if not 0 <= self.discount < 1:
            raise ValueError(f"discount must be in [0, 1), got {self.discount}")
        object.__setattr__(self, "features", features)
        if self.visible is not None:
            object.__setattr__(self, "visible", np.asarray(self.visible, dtype=bool))


# ---- the estimator -----------------------------------------------------------------------------
class OccludedMaxEntIRL(EstimatorParams):
    """Max-entropy IRL for one robot from an occluded trajectory (mIRL*, Sec. 2 of the paper).

    The estimator holds how it fits; the problem (the robot's features, T, discount and L's
    view, an :class:`IRLProblem`) and the robot's record are :meth:`fit`'s.

    .. versionchanged:: 0.2.0
       The problem's data (``features``, ``transitions``, ``discount``, ``visible``) moved from
       the constructor to :meth:`fit`, as an :class:`IRLProblem`. ``get_params``,
       ``set_params`` (validated as the constructor validates) and a ``repr`` of the settings
       that differ from the defaults (:class:`mirl._estimator.EstimatorParams`).

    Parameters
    ----------
    objective : {"sequence", "counts", "likelihood", "both"}, default "sequence"
        What is fitted (module docstring); the default is the measured best, the paper's is
        ``"counts"``.
    anchor : {"first", "reentry"}, default "first"
        Where the ``"counts"`` objective's expected counts are propagated from.
    optimizer : {"lbfgs", "nelder-mead"}, default "lbfgs"
        L-BFGS-B with the exact gradient, or the paper's derivative-free Nelder–Mead.
    temperature : float, default 1.0
        The soft policy's τ; θ's scale is learned, so τ only fixes the units.
    l2 : float, default 1e-4
        Weight of the L2 penalty on θ.
    n_restarts : int, default 1
        Optimiser starts: ``initial_weights`` (or θ = 0) first, then seeded N(0, 1) draws (the
        paper's configuration: 3, with Nelder–Mead).
    max_evaluations : int, default 300
        Objective evaluations allowed per start.
    tol : float or None, default 1e-5
        L-BFGS-B's ``ftol``, the relative decrease of the loss per iteration below which it
        stops. The default stops once an iteration gains less than 10⁻⁵ of the loss (a few
        hundredths of a nat on the office's records): measured to learn boyd2 ~17 % and the
        office ~25 % faster with the same equilibria and accuracy (docs/design.md, "A looser
        stopping rule"); None: scipy's 2.2e-9.
    gradient : {"auto", "forward", "reverse"}, default "auto"
        How the sequence objective's gradient is taken, both exact: ``"forward"`` (the K
        derivatives propagated with the distributions), ``"reverse"`` (an adjoint pass,
        :meth:`~mirl.learning.sequence.ObservedSequence.loglik_reverse`), or ``"auto"``:
        reverse on large models, where it is several times faster, forward on small ones
        (boyd2), where it is not.
    random_state : int, Generator or None, default None
        Seed for the restarts.

    Raises
    ------
    ValueError
        If a choice is not a name its table holds (the nearest suggested), ``temperature``,
        ``l2`` or ``tol`` is not a finite number, ``n_restarts`` or ``max_evaluations`` not
        an integer, any of them is out of its range, or ``random_state`` is no seed.

    Attributes
    ----------
    problem_ : IRLProblem
        The problem of the last fit.
    weights_ : ndarray of shape (K,)
        The learned reward weights θ.
    policy_ : ndarray of shape (S,)
        Greedy policy of hard value iteration with ``weights_`` and the transition model.
    q_values_ : ndarray of shape (S, A)
        That value iteration's Q.
    soft_policy_ : ndarray of shape (S, A)
        The soft policy π of ``weights_``.
    expert_counts_, expected_counts_ : ndarray of shape (K,)
        Feature counts on the observable states, observed and expected (whatever the
        objective; computed when first read).
    result_ : scipy.optimize.OptimizeResult
        ``x``, ``fun``, ``success``, ``message``, ``nfev`` and ``starts``, the (x, fun) of
        every start.
    """

    def __init__(
        self,
        *,
        objective: str = "sequence",
        anchor: str = "first",
        optimizer: str = "lbfgs",
        temperature: float = 1.0,
        l2: float = 1e-4,
        n_restarts: int = 1,
        max_evaluations: int = 300,
        tol: float | None = 1e-5,
        gradient: str = "auto",
        random_state: int | np.random.Generator | None = None,
    ) -> None:
        for value, table in (
            (objective, OBJECTIVES),
            (anchor, ANCHORS),
            (optimizer, OPTIMIZERS),
            (gradient, GRADIENTS),
        ):
            table.lookup(value)  # an unknown name: UnknownNameError (a ValueError), one line
        # the kind of each number first: a fractional count of starts or evaluations ran (and
        # scipy took maxfun=10.5), a string failed as a comparison, an infinite temperature or
        # L2 weight gave a meaningless fit, and a bad seed was found only by fit()
        for name, got, kind, what in (
            ("temperature", temperature, numbers.Real, "a finite number"),
            ("l2", l2, numbers.Real, "a finite number"),
            ("max_evaluations", max_evaluations, numbers.Integral, "an integer"),
            ("n_restarts", n_restarts, numbers.Integral, "an integer"),
            ("tol", tol, numbers.Real, "a finite number or None"),
        ):
            if name == "tol" and got is None:
                continue
            if isinstance(got, bool) or not isinstance(got, kind) or not np.isfinite(got):
                raise ValueError(f"{name} must be {what}, got {got!r}")
        seeded = isinstance(random_state, numbers.Integral) and 0 <= random_state < 2**63
        if not (
            random_state is None
            or isinstance(random_state, np.random.Generator)
            or (seeded and not isinstance(random_state, bool))
        ):
            raise ValueError(
                "random_state must be an integer in [0, 2^63 - 1], a numpy Generator or None, "
                f"got {random_state!r}"
            )
        for name, got, ok, needed in (
            ("temperature", temperature, temperature > 0, "positive"),
            ("l2", l2, l2 >= 0, "at least 0"),
            ("max_evaluations", max_evaluations, max_evaluations >= 1, "at least 1"),
            ("n_restarts", n_restarts, n_restarts >= 1, "at least 1"),
        ):  # each would run and return a meaningless fit (0/0 policies, an unbounded loss)
            if not ok:
                raise ValueError(f"{name} must be {needed}, got {got}")
        if tol is not None and not tol > 0:
            raise ValueError(f"tol must be positive (or None for scipy's default), got {tol}")
        self.objective = objective
        self.anchor = anchor
        self.optimizer = optimizer
        self.temperature = temperature
        self.l2 = l2
        self.n_restarts = n_restarts
        self.max_evaluations = max_evaluations
        self.tol = tol
        self.gradient = gradient
        self.random_state = random_state

    # -- data preparation --
    def _prepare(self, problem: IRLProblem, series, labels, exclude) -> None:
        self._features = problem.features
        self._transitions = sp.csr_array(problem.transitions)
        self._discount = problem.discount
        self._visible = problem.visible
        self._V_warm: np.ndarray | None = None  # soft values of the last evaluation (warm start)
        self._forward_operator = BlockOperator()  # P_πᵀ with its derivatives, forward mode
        S, A, K = self._features.shape
        x = np.asarray(series, dtype=int)
        H = len(x)
        lab = np.full(H, -1, dtype=int) if labels is None else np.asarray(labels, dtype=int)
        if lab.shape != x.shape:
            raise ValueError("labels must have the same shape as series")
        if x.size and x.max() >= S:
            raise ValueError(f"states must be in [0, {S}) or -1 for occluded")
        seen = x >= 0
        if not seen.any():
            raise ValueError("the robot was never observed: nothing to learn from")
        counted = np.ones(H, dtype=bool) if exclude is None else ~np.asarray(exclude, dtype=bool)
        t0 = int(np.flatnonzero(seen)[0])
        counted[:t0] = False
        vis = np.zeros(S, dtype=bool) if self._visible is None else self._visible.copy()
        if self._visible is None:
            vis[:] = True
        vis[x[seen]] = True
        self._vis = vis
        obs = seen & counted
        lab = np.where(seen, lab, -1)
        self._n_obs = max(int(obs.sum()), 1)
        known = obs & (lab >= 0)
        self._lab_s, self._lab_a = x[known], lab[known]
        self._unl_s = x[obs & (lab < 0)]
        self._expert_fixed = self._features[self._lab_s, self._lab_a].sum(axis=0)
        # segments of the propagation: anchored at the first observation, and at re-entries
        start = seen.copy()
        start[:t0] = False
        if self.anchor == "reentry":
            start[1:] &= ~seen[:-1]
        else:
            start[:] = False
            start[t0] = True
        anchors = np.flatnonzero(start)
        ends = np.append(anchors[1:], H)
        L = int((ends - anchors).max())
        W = np.zeros((L, len(anchors)))
        for k, (a0, a1) in enumerate(zip(anchors, ends, strict=True)):
            W[: a1 - a0, k] = counted[a0:a1]
        self._W = W
        self._U0 = np.zeros((S, len(anchors)))
        self._U0[x[anchors], np.arange(len(anchors))] = 1.0
        self._dyn = _Dynamics(self._transitions, A)
        self._prepare_sequence(x, counted | ~seen)

    def _prepare_sequence(self, x: np.ndarray, own: np.ndarray) -> None:
        """Pieces of log P(observed series) (:class:`~mirl.learning.sequence.ObservedSequence`).
        Steps leaving an excluded time (``own`` False) are not the robot's own choice: skipped."""
        self._sequence = ObservedSequence(x, own, self._dyn, self._features.shape[0])
        self._n_steps = max(len(x) - 1, 1)

    def _sequence_loglik(self, pi, B, dpi=None):
        return self._sequence.loglik(pi, B, self._vis, dpi)

    def _reverse_mode(self) -> bool:
        if self.gradient != "auto":
            return self.gradient == "reverse"
        K = self._features.shape[2]
        # reverse mode keeps the filter's history and its adjoint: two S × (columns over all
        # steps) arrays, which on a huge map and a long record would not fit in memory
        history = 2 * 8 * self._sequence.history_size
        return (2 * K + 1) * len(self._dyn._pt_indices) >= _REVERSE_FROM and (
            history <= _HISTORY_BYTES
        )

    # -- objective --
    def _soft(self, theta: np.ndarray):
        R = self._features @ theta
        V, Q, pi, _ = soft_policy_iteration(
            self._dyn,
            R,
            self._discount,
            temperature=self.temperature,
            initial_values=self._V_warm,
            tol=1e-9,
        )
        if np.all(np.isfinite(V)):
            self._V_warm = V
        return V, Q, pi

    def _occupancy(self, B: sp.csr_array, K: int) -> tuple[np.ndarray, np.ndarray]:
        """Σ_t w_t μ_t over all segments, (S,), and its derivative (S, K) (empty if K = 0)."""
        S, n_seg = self._U0.shape
        Z = np.zeros(((K + 1) * S, n_seg))
        Z[:S] = self._U0
        out = Z @ self._W[0]
        for n in range(1, len(self._W)):
            Z = csr_matmul(B, Z)  # B @ Z without scipy's dispatch, bit for bit
            out += Z @ self._W[n]
        out = out.reshape(K + 1, S)
        return out[0], out[1:].T

    def _counts(self, phi_pi: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(expected, expert) feature counts on the observable states (module docstring)."""
        expected = (D * self._vis) @ phi_pi
        expert = self._expert_fixed + phi_pi[self._unl_s].sum(axis=0)
        return expected, expert

    def _loss(self, theta: np.ndarray, grad: bool = False):
        S, A, K = self._features.shape
        V, Q, pi = self._soft(theta)
        PT = self._dyn.transposed_policy(pi)
        loss = self.l2 * float(theta @ theta)
        g = 2 * self.l2 * theta
        terms = OBJECTIVES[self.objective]
        counts, actions = terms.counts, terms.likelihood
        dpi: np.ndarray | None = None
        dPT: sp.csr_array | None = None
        if grad:
            # dQ/dθ = φ + γ T dV/dθ, dV/dθ = Σ_a π dQ/dθ (soft Bellman): successor features
            phi_pi = np.einsum("sa,sak->sk", pi, self._features)
            dV = self._dyn.solve_policy(pi, self._discount, phi_pi)
            dQ = self._features + self._discount * self._dyn.next_values(dV)
            # dπ(a|s)/dθ = π (dQ(s,a) − Σ_b π dQ(s,b)) / τ
            dQ_c = dQ - np.einsum("sa,sak->sk", pi, dQ)[:, None, :]
            dpi = pi[:, :, None] * dQ_c / self.temperature  # (S, A, K)
        reverse = grad and terms.sequence and self._reverse_mode()
        if dpi is not None and (counts or not reverse):  # forward mode needs dP_πᵀ/dθ itself
            dPT = self._dyn.transposed_policy(dpi)
        B = self._forward_operator(PT, dPT)
        if counts:
            phi_pi = np.einsum("sa,sak->sk", pi, self._features)
            D, dD = self._occupancy(B, K if grad else 0)
            expected, expert = self._counts(phi_pi, D)
            diff = (expected - expert) / self._n_obs
            loss += float(diff @ diff)
            if grad:
                assert dpi is not None
                dphi_pi = np.einsum("saj,sak->skj", dpi, self._features)  # dφ_π[:, k]/dθ_j
                expected_g = np.einsum("s,sk,sj->kj", self._vis, phi_pi, dD) + np.einsum(
                    "s,skj->kj", D * self._vis, dphi_pi
                )
                expert_g = dphi_pi[self._unl_s].sum(axis=0)
                g = g + 2 * (diff @ (expected_g - expert_g)) / self._n_obs
        if terms.sequence:
            if reverse:
                ll, g_ll = self._sequence.loglik_reverse(pi, PT, self._vis, dpi)
            else:
                ll, g_ll = self._sequence_loglik(pi, B, dpi)
            loss -= ll / self._n_steps
            if grad:
                g = g - g_ll / self._n_steps
        if actions:
            log_pi = np.log(np.maximum(pi[self._lab_s, self._lab_a], 1e-300))
            n = max(len(log_pi), 1)
            loss -= float(log_pi.sum()) / n
            if grad:
                g = g - dQ_c[self._lab_s, self._lab_a].sum(axis=0) / (self.temperature * n)
        return (loss, g) if grad else loss

    # -- fitting --
    def fit(
        self,
        problem: IRLProblem,
        series: np.ndarray,
        labels: np.ndarray | None = None,
        *,
        exclude: np.ndarray | None = None,
        initial_weights: np.ndarray | None = None,
    ) -> OccludedMaxEntIRL:
        """Learn θ from one robot's state series.

        Parameters
        ----------
        problem : IRLProblem
            The robot's features, transition model, discount and the states L can see.
        series : ndarray of shape (horizon,) of int
            The state L saw the robot in at each time step, -1 where occluded.
        labels : ndarray of shape (horizon,) of int, optional
            The action taken at each time step, -1 where unknown.
        exclude : ndarray of shape (horizon,) of bool, optional
            Time steps left out of both sides of the counts and of the likelihood (e.g. steps
            whose action was dictated by the interaction game, not the robot's own policy).
        initial_weights : ndarray of shape (K,), optional
            The first start (θ = 0 if None).

        Returns
        -------
        OccludedMaxEntIRL
            ``self``, fitted (attributes in the class docstring).
        """
        self._prepare(problem, series, labels, exclude)
        S, A, K = self._features.shape
        rng = np.random.default_rng(self.random_state)
        x0 = np.zeros(K) if initial_weights is None else np.asarray(initial_weights, float)
        starts = [x0] + [rng.normal(0.0, 1.0, K) for _ in range(max(self.n_restarts, 1) - 1)]
        self._V_warm = None
        results: list[OptimizeResult] = []
        for x_start in starts:
            self._V_warm = None
            res = _minimise_from(
                self._loss,
                np.asarray(x_start, dtype=float),
                optimizer=self.optimizer,
                max_evaluations=self.max_evaluations,
                tol=self.tol,
            )
            results.append(res)
        self._sequence.free_workspace()  # its filter history (tens of MB on large maps)
        best = min(results, key=lambda r: r.fun)  # the first of equal optima, as before
        theta = np.asarray(best.x, dtype=float)
        self._V_warm = None
        V, Q, pi = self._soft(theta)
        self._final_counts: tuple[np.ndarray, np.ndarray] | None = None
        hard = value_iteration(
            TabularMDP(self._transitions, self._features @ theta, self._discount)
        )
        self.problem_ = problem
        self.weights_ = theta
        self.soft_policy_ = pi
        self.q_values_ = hard.q_values
        self.policy_ = hard.policy
        self.result_ = OptimizeResult(
            x=theta,
            fun=float(best.fun),
            success=bool(best.success),
            message=str(best.message),
            nfev=int(sum(r.nfev for r in results)),
            starts=[(np.asarray(r.x), float(r.fun)) for r in results],
        )
        return self

    # the counts are a diagnostic, computed when first read: on a 3 804-state office their
    # propagation over the whole record cost as much as a tenth of the sequence objective's fit
    @property
    def expected_counts_(self) -> np.ndarray:
        """(K,) expected feature counts on the observable states, computed when first read."""
        return self._counts_of_fit()[0]

    @property
    def expert_counts_(self) -> np.ndarray:
        """(K,) observed feature counts on the observable states, computed when first read."""
        return self._counts_of_fit()[1]

    def _counts_of_fit(self) -> tuple[np.ndarray, np.ndarray]:
        if getattr(self, "_final_counts", None) is None:
            if not hasattr(self, "soft_policy_"):
                raise AttributeError("expected_counts_ and expert_counts_ exist after fit()")
            pi = self.soft_policy_
            D, _ = self._occupancy(self._dyn.transposed_policy(pi), 0)
            phi_pi = np.einsum("sa,sak->sk", pi, self._features)
            self._final_counts = self._counts(phi_pi, D)
        assert self._final_counts is not None
        return self._final_counts


# ---- the optimiser -----------------------------------------------------------------------------
def _minimise_from(
    loss: Callable,
    x_start: np.ndarray,
    *,
    optimizer: str,
    max_evaluations: int,
    tol: float | None,
) -> OptimizeResult:
    """Minimise ``loss`` from ``x_start``, one start of Nelder–Mead (derivative-free, the
    paper's) or L-BFGS-B with the exact gradient, with the options the estimator's defaults
    were measured with. ``loss(x)`` returns the value, ``loss(x, True)`` (value, gradient).
    Nelder–Mead starts from a simplex of half the start's scale (at least
    0.5); L-BFGS-B stops at ``tol`` relative gain (None: scipy's default ftol)."""
    if optimizer == "nelder-mead":
        K = len(x_start)
        step = 0.5 * max(1.0, float(np.abs(x_start).max()))
        simplex = np.vstack([x_start, x_start + step * np.eye(K)])
        options = {"initial_simplex": simplex, "maxfev": max_evaluations}
        return minimize(
            loss, x_start, method="Nelder-Mead", options=options | {"xatol": 1e-3, "fatol": 1e-7}
        )
    options = {"maxfun": max_evaluations, "gtol": 1e-7, **({} if tol is None else {"ftol": tol})}
    return minimize(loss, x_start, args=(True,), jac=True, method="L-BFGS-B", options=options)
