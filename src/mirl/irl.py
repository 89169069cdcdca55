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
(I − γP_π)⁻¹ φ_π, and forward-mode propagation of the distributions and their K derivatives in
one block-sparse step.

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

**Interactions.** Observed steps at which both robots are in view and *could* meet are left out of
the per-robot fit (their actions may be the game's). The candidate equilibria (all Nash equilibria
of the bimatrix) are weighed by the exact likelihood of both robots' observations under the joint
dynamics — a forward filter over the S² joint states where the equilibrium's moves replace the
policies' at meeting states (:func:`joint_log_likelihood`) — which contains the likelihood of the
evident meetings (:func:`meeting_log_likelihood`). The joint filter costs ~0.1 s per equilibrium
on boyd2 (450 steps), 10–25 times a marginal objective evaluation, so it weighs equilibria once
per learned model rather than inside the optimiser.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import OptimizeResult, minimize

from mirl.domain import STOP, TURN_LEFT, PatrolDomain
from mirl.game import Equilibrium, meeting
from mirl.mdp import TabularMDP, value_iteration

__all__ = [
    "OBJECTIVES",
    "ANCHORS",
    "OPTIMIZERS",
    "soft_policy_iteration",
    "OccludedMaxEntIRL",
    "potential_meetings",
    "EquilibriumWeights",
    "joint_log_likelihood",
    "meeting_log_likelihood",
    "weigh_equilibria",
]

OBJECTIVES = ("counts", "likelihood", "both", "sequence")
ANCHORS = ("first", "reentry")
OPTIMIZERS = ("nelder-mead", "lbfgs")
_DENSE_LIMIT = 600  # states up to which linear solves are dense


# ---- soft values -------------------------------------------------------------------------------
class _Dynamics:
    """T with the operations the solvers need; dense (S, A, S) for small models, sparse else."""

    def __init__(self, transitions: sp.csr_array, n_actions: int) -> None:
        self.T = sp.csr_array(transitions)
        self.S = self.T.shape[1]
        self.A = n_actions
        self.rows = np.repeat(np.arange(self.S * self.A), np.diff(self.T.indptr))
        self.dense = None
        if self.S <= _DENSE_LIMIT:
            self.dense = self.T.toarray().reshape(self.S, self.A, self.S)
        # fixed sparsity pattern of P_πᵀ: entry (s', s) collects T(s, a, s') over actions a
        S = self.S
        key = self.T.indices * S + self.rows // self.A
        uniq, self._pt_pos = np.unique(key, return_inverse=True)
        self._pt_indices = uniq % S
        self._pt_indptr = np.searchsorted(uniq // S, np.arange(S + 1))

    def transposed_policy(self, w: np.ndarray) -> sp.csr_array:
        """P_πᵀ (S, S) as CSR for π = ``w`` (S, A); for ``w`` of shape (S, A, K) the K matrices
        Σ_a w[s, a, k] T(s, a, ·), transposed and stacked into one (K·S, S) CSR."""
        S, nnz = self.S, len(self._pt_indices)
        flat = w.reshape(S * self.A, -1)[self.rows] * self.T.data[:, None]
        data = np.concatenate(
            [
                np.bincount(self._pt_pos, weights=flat[:, k], minlength=nnz)
                for k in range(flat.shape[1])
            ]
        )
        K = flat.shape[1]
        indptr = (self._pt_indptr[None, :-1] + nnz * np.arange(K)[:, None]).ravel()
        indptr = np.append(indptr, K * nnz)
        indices = np.tile(self._pt_indices, K)
        return sp.csr_array((data, indices, indptr), shape=(K * S, S))

    def transition_values(self, s: np.ndarray, s_next: np.ndarray) -> np.ndarray:
        """T(s_i, a, s_next_i) for every action, (n, A)."""
        if self.dense is not None:
            return self.dense[s, :, s_next]
        rows = (np.asarray(s)[:, None] * self.A + np.arange(self.A)).ravel()
        sub = self.T[rows].toarray().reshape(len(s), self.A, self.S)
        return sub[np.arange(len(s)), :, s_next]

    def next_values(self, V: np.ndarray) -> np.ndarray:
        """E[V(s') | s, a] as (S, A) (or (S, A, K) for V of shape (S, K))."""
        if self.dense is not None:
            return np.tensordot(self.dense, V, axes=(2, 0))
        return (self.T @ V).reshape(self.S, self.A, *V.shape[1:])

    def policy_matrix(self, pi: np.ndarray):
        """P_π (S, S): dense ndarray for small models, CSR otherwise (π may be any weights)."""
        if self.dense is not None:
            return np.einsum("sa,sat->st", pi, self.dense)
        return _policy_matrix(self.T, self.rows, pi, self.S)

    def solve(self, P, discount: float, b: np.ndarray) -> np.ndarray:
        """Solve (I − γ P) x = b for one or several right-hand sides."""
        if self.dense is not None:
            return sla.solve(np.eye(self.S) - discount * P, b, check_finite=False)
        A = sp.csc_array(sp.eye_array(self.S) - discount * P)
        return spla.splu(A).solve(np.asarray(b, dtype=float))


def _policy_matrix(T: sp.csr_array, rows: np.ndarray, pi: np.ndarray, n_states: int):
    """P_π (S, S) as CSR from T (S·A, S) and a stochastic policy (S, A)."""
    n_actions = pi.shape[1]
    data = T.data * pi.ravel()[rows]
    return sp.csr_array((data, (rows // n_actions, T.indices)), shape=(n_states, n_states))


def _softmax(Q: np.ndarray, temperature: float) -> tuple[np.ndarray, np.ndarray]:
    m = Q.max(axis=1)
    z = np.exp((Q - m[:, None]) / temperature)
    tot = z.sum(axis=1)
    return z / tot[:, None], m + temperature * np.log(tot)


def soft_policy_iteration(
    transitions: sp.csr_array | _Dynamics,
    rewards: np.ndarray,
    discount: float,
    *,
    temperature: float = 1.0,
    initial_values: np.ndarray | None = None,
    tol: float = 1e-8,
    max_iter: int = 100,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Maximum-entropy values by soft policy iteration: evaluate π exactly, then π ∝ exp(Q/τ).

    This is Newton's method on the soft Bellman equation V = τ log Σ_a exp(Q/τ): it converges
    quadratically, typically in 3–6 linear solves from a warm start. Returns (V, Q, π, iterations).
    """
    S, A = rewards.shape
    dyn = transitions if isinstance(transitions, _Dynamics) else _Dynamics(transitions, A)
    V = np.zeros(S) if initial_values is None else np.asarray(initial_values, dtype=float)
    Q = rewards + discount * dyn.next_values(V)
    pi, V_soft = _softmax(Q, temperature)
    for it in range(1, max_iter + 1):
        # evaluate π: V = Σ_a π (R − τ log π) + γ P_π V
        log_pi = (Q - V_soft[:, None]) / temperature
        b = (pi * (rewards - temperature * log_pi)).sum(axis=1)
        V = dyn.solve(dyn.policy_matrix(pi), discount, b)
        Q = rewards + discount * dyn.next_values(V)
        pi, V_soft = _softmax(Q, temperature)
        if np.abs(V_soft - V).max() < tol:
            return V_soft, Q, pi, it
    return V_soft, Q, pi, max_iter


# ---- the estimator -----------------------------------------------------------------------------
class OccludedMaxEntIRL:
    """Max-entropy IRL for one robot from an occluded trajectory (mIRL*, Sec. 2 of the paper).

    Parameters
    ----------
    features : (S, A, K) reward features φ.
    transitions : (S·A, S) CSR transition model of the robot (learned or fixed).
    discount : the robot's discount factor.
    visible : (S,) bool, the states L can observe (all if None). Observed states are always
        treated as observable.
    objective, anchor, optimizer : see the module docstring (defaults: the measured best; the
        paper's is ``objective="counts", optimizer="nelder-mead", n_restarts=3``).
    temperature : τ of the soft policy; θ's scale is learned, so τ only fixes the units.
    l2 : weight of the L2 penalty on θ.
    n_restarts : optimiser starts: ``initial_weights`` (or θ = 0) first, then seeded N(0, 1) draws.
    max_evaluations : objective evaluations allowed per start.
    random_state : seed for the restarts.

    Attributes after ``fit``: ``weights_`` (K,), ``policy_`` (S,) greedy policy of hard value
    iteration with ``weights_`` and the transition model, ``soft_policy_`` (S, A),
    ``expert_counts_`` and ``expected_counts_`` (K,) on the observable states (whatever the
    objective), ``result_`` (a ``scipy.optimize.OptimizeResult`` with ``x``, ``fun``,
    ``success``, ``message``, ``nfev`` and ``starts``, the (x, fun) of every start).
    """

    def __init__(
        self,
        features: np.ndarray,
        transitions: sp.csr_array,
        *,
        discount: float = 0.95,
        visible: np.ndarray | None = None,
        objective: str = "sequence",
        anchor: str = "first",
        optimizer: str = "lbfgs",
        temperature: float = 1.0,
        l2: float = 1e-4,
        n_restarts: int = 1,
        max_evaluations: int = 300,
        random_state: int | np.random.Generator | None = None,
    ) -> None:
        for name, value, allowed in (
            ("objective", objective, OBJECTIVES),
            ("anchor", anchor, ANCHORS),
            ("optimizer", optimizer, OPTIMIZERS),
        ):
            if value not in allowed:
                raise ValueError(f"unknown {name} '{value}' (known: {', '.join(allowed)})")
        self.features = np.asarray(features, dtype=float)
        if self.features.ndim != 3:
            raise ValueError(f"features must be (S, A, K), got shape {self.features.shape}")
        self.transitions = sp.csr_array(transitions)
        S, A, _ = self.features.shape
        if self.transitions.shape != (S * A, S):
            raise ValueError(f"transitions must be ({S * A}, {S}), got {self.transitions.shape}")
        self.discount = discount
        self.visible = None if visible is None else np.asarray(visible, dtype=bool)
        self.objective = objective
        self.anchor = anchor
        self.optimizer = optimizer
        self.temperature = temperature
        self.l2 = l2
        self.n_restarts = n_restarts
        self.max_evaluations = max_evaluations
        self.random_state = random_state

    # -- data preparation --
    def _prepare(self, series, labels, exclude) -> None:
        S, A, K = self.features.shape
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
        vis = np.zeros(S, dtype=bool) if self.visible is None else self.visible.copy()
        if self.visible is None:
            vis[:] = True
        vis[x[seen]] = True
        self._vis = vis
        obs = seen & counted
        lab = np.where(seen, lab, -1)
        self._n_obs = max(int(obs.sum()), 1)
        known = obs & (lab >= 0)
        self._lab_s, self._lab_a = x[known], lab[known]
        self._unl_s = x[obs & (lab < 0)]
        self._expert_fixed = self.features[self._lab_s, self._lab_a].sum(axis=0)
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
        self._dyn = _Dynamics(self.transitions, A)
        self._prepare_sequence(x, counted | ~seen)

    def _prepare_sequence(self, x: np.ndarray, own: np.ndarray) -> None:
        """Pieces of log P(observed series): steps between two observations, and occluded gaps
        (propagated as columns, masked to the occluded states, ending on the next observation).
        Steps leaving an excluded time (``own`` False) are not the robot's own choice: skipped."""
        S = self.features.shape[0]
        H = len(x)
        seen = x >= 0
        t = np.flatnonzero(seen[:-1] & seen[1:] & own[:-1])
        self._pair = (x[t], x[t + 1])
        self._Tab = self._dyn.transition_values(x[t], x[t + 1])
        starts, steps, ends = [], [], []
        t = int(np.flatnonzero(seen)[0])  # condition on the first observation
        while t < H:
            if seen[t]:
                t += 1
                continue
            u = t
            while t < H and not seen[t]:
                t += 1
            # occluded run u .. t-1, entered from the observed x[u-1]
            e = np.zeros(S)
            e[x[u - 1]] = 1.0
            starts.append(e)
            steps.append(t - u + 1)
            ends.append(x[t] if t < H else -1)
            if t >= H:  # trailing gap: the last prediction is still occluded, no end state
                steps[-1] -= 1
        self._gap_U0 = np.array(starts).T if starts else np.zeros((S, 0))
        self._gap_steps = np.array(steps, dtype=int)
        self._gap_ends = np.array(ends, dtype=int)
        # per step n: (gaps re-entering view, their states, gaps still unseen at the end)
        self._gap_events = {}
        for n in np.unique(self._gap_steps):
            g = np.flatnonzero(self._gap_steps == n)
            e = self._gap_ends[g]
            self._gap_events[int(n)] = (g[e >= 0], e[e >= 0], g[e < 0])
        self._gap_max = int(self._gap_steps.max(initial=0))
        self._n_steps = max(H - 1, 1)

    def _sequence_loglik(self, pi, B, dpi=None):
        """log P(observed series | first observation, π, T), occlusion included; with ``dpi``
        (S, A, K) = dπ/dθ also its gradient. ``B`` is :meth:`_forward_operator`'s matrix."""
        K = 0 if dpi is None else dpi.shape[2]
        a, b = self._pair
        p_ab = np.maximum((pi[a] * self._Tab).sum(axis=1), 1e-300)
        total = float(np.log(p_ab).sum())
        grad = np.zeros(K)
        if K:
            grad += ((dpi[a] * self._Tab[:, :, None]).sum(axis=1) / p_ab[:, None]).sum(axis=0)
        G = self._gap_U0.shape[1]
        if G == 0:
            return total, grad
        S = self._gap_U0.shape[0]
        hidden = np.tile(~self._vis, K + 1).astype(float)[:, None]
        # rows [k·S, (k+1)·S) of Z: the gaps' state distributions (k = 0, one column per gap)
        # and their derivatives wrt θ_k; columns are rescaled as a whole, so ratios stay exact
        Z = np.zeros(((K + 1) * S, G))
        Z[:S] = self._gap_U0
        log_scale = np.zeros(G)
        alive = np.ones(G)
        for n in range(1, self._gap_max + 1):
            Z = B @ Z
            event = self._gap_events.get(n)
            if event is None:
                Z *= hidden
            else:
                hit, ends, tail = event
                if hit.size:  # re-entry into view at the observed state
                    v = np.maximum(Z[ends, hit], 1e-300)
                    total += float((np.log(v) + log_scale[hit]).sum())
                    if K:
                        grad += (Z.reshape(K + 1, S, G)[1:, ends, hit] / v).sum(axis=1)
                Z *= hidden
                if tail.size:  # still unseen at the end of the record
                    m = np.maximum(Z[:S, tail].sum(axis=0), 1e-300)
                    total += float((np.log(m) + log_scale[tail]).sum())
                    if K:
                        grad += (Z.reshape(K + 1, S, G)[1:, :, tail].sum(axis=1) / m).sum(axis=1)
                alive[hit] = 0.0
                alive[tail] = 0.0
            if n % 8 == 0:  # rescale against underflow
                mass = Z[:S].sum(axis=0)
                mass = np.where(mass > 0, mass, 1.0)
                Z /= mass
                log_scale += alive * np.log(mass)
        return total, grad

    # -- objective --
    def _soft(self, theta: np.ndarray):
        R = self.features @ theta
        V, Q, pi, _ = soft_policy_iteration(
            self._dyn,
            R,
            self.discount,
            temperature=self.temperature,
            initial_values=self._V_warm,
            tol=1e-9,
        )
        if np.all(np.isfinite(V)):
            self._V_warm = V
        return V, Q, pi

    @staticmethod
    def _forward_operator(PT: sp.csr_array, dPT: sp.csr_array | None) -> sp.csr_array:
        """P_πᵀ, or with derivatives the block matrix [[Pᵀ, 0, …], [dPᵀ_1, Pᵀ, 0, …], …] that
        moves a distribution and its K derivatives one step on together (forward mode)."""
        if dPT is None:
            return PT
        S = PT.shape[0]
        K = dPT.shape[0] // S
        pt, d = PT.tocoo(), dPT.tocoo()
        off = np.repeat(np.arange(K + 1) * S, pt.nnz)
        rows = np.concatenate([np.tile(pt.row, K + 1) + off, d.row + S])
        cols = np.concatenate([np.tile(pt.col, K + 1) + off, d.col])
        data = np.concatenate([np.tile(pt.data, K + 1), d.data])
        n = (K + 1) * S
        return sp.csr_array(sp.coo_array((data, (rows, cols)), shape=(n, n)).tocsr())

    def _occupancy(self, B: sp.csr_array, K: int) -> tuple[np.ndarray, np.ndarray]:
        """Σ_t w_t μ_t over all segments, (S,), and its derivative (S, K) (empty if K = 0)."""
        S, n_seg = self._U0.shape
        Z = np.zeros(((K + 1) * S, n_seg))
        Z[:S] = self._U0
        out = Z @ self._W[0]
        for n in range(1, len(self._W)):
            Z = B @ Z
            out += Z @ self._W[n]
        out = out.reshape(K + 1, S)
        return out[0], out[1:].T

    def _counts(self, phi_pi: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(expected, expert) feature counts on the observable states (module docstring)."""
        expected = (D * self._vis) @ phi_pi
        expert = self._expert_fixed + phi_pi[self._unl_s].sum(axis=0)
        return expected, expert

    def _loss(self, theta: np.ndarray, grad: bool = False):
        S, A, K = self.features.shape
        V, Q, pi = self._soft(theta)
        PT = self._dyn.transposed_policy(pi)
        loss = self.l2 * float(theta @ theta)
        g = 2 * self.l2 * theta
        counts = self.objective in ("counts", "both")
        actions = self.objective in ("likelihood", "both")
        dpi = dPT = None
        if grad:
            # dQ/dθ = φ + γ T dV/dθ, dV/dθ = Σ_a π dQ/dθ (soft Bellman): successor features
            phi_pi = np.einsum("sa,sak->sk", pi, self.features)
            dV = self._dyn.solve(self._dyn.policy_matrix(pi), self.discount, phi_pi)
            dQ = self.features + self.discount * self._dyn.next_values(dV)
            # dπ(a|s)/dθ = π (dQ(s,a) − Σ_b π dQ(s,b)) / τ
            dQ_c = dQ - np.einsum("sa,sak->sk", pi, dQ)[:, None, :]
            dpi = pi[:, :, None] * dQ_c / self.temperature  # (S, A, K)
            if counts or self.objective == "sequence":
                dPT = self._dyn.transposed_policy(dpi)
        B = self._forward_operator(PT, dPT)
        if counts:
            phi_pi = np.einsum("sa,sak->sk", pi, self.features)
            D, dD = self._occupancy(B, K if grad else 0)
            expected, expert = self._counts(phi_pi, D)
            diff = (expected - expert) / self._n_obs
            loss += float(diff @ diff)
            if grad:
                dphi_pi = np.einsum("saj,sak->skj", dpi, self.features)  # dφ_π[:, k]/dθ_j
                expected_g = np.einsum("s,sk,sj->kj", self._vis, phi_pi, dD) + np.einsum(
                    "s,skj->kj", D * self._vis, dphi_pi
                )
                expert_g = dphi_pi[self._unl_s].sum(axis=0)
                g = g + 2 * (diff @ (expected_g - expert_g)) / self._n_obs
        if self.objective == "sequence":
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
        series: np.ndarray,
        labels: np.ndarray | None = None,
        *,
        exclude: np.ndarray | None = None,
        initial_weights: np.ndarray | None = None,
    ) -> OccludedMaxEntIRL:
        """Learn θ from one robot's (horizon,) state series (-1 = occluded).

        ``labels``: (horizon,) action per time step (-1 = unknown). ``exclude``: (horizon,) bool,
        time steps left out of both sides of the counts and of the likelihood (e.g. steps whose
        action was dictated by the interaction game rather than the robot's own policy).
        """
        self._prepare(series, labels, exclude)
        S, A, K = self.features.shape
        rng = np.random.default_rng(self.random_state)
        x0 = np.zeros(K) if initial_weights is None else np.asarray(initial_weights, float)
        starts = [x0] + [rng.normal(0.0, 1.0, K) for _ in range(max(self.n_restarts, 1) - 1)]
        self._V_warm = None
        best, results = None, []
        for x_start in starts:
            self._V_warm = None
            if self.optimizer == "nelder-mead":
                step = 0.5 * max(1.0, float(np.abs(x_start).max()))
                simplex = np.vstack([x_start, x_start + step * np.eye(K)])
                res = minimize(
                    self._loss,
                    x_start,
                    method="Nelder-Mead",
                    options={
                        "initial_simplex": simplex,
                        "maxfev": self.max_evaluations,
                        "xatol": 1e-3,
                        "fatol": 1e-7,
                    },
                )
            else:
                res = minimize(
                    self._loss,
                    x_start,
                    args=(True,),
                    jac=True,
                    method="L-BFGS-B",
                    options={"maxfun": self.max_evaluations, "gtol": 1e-7},
                )
            results.append(res)
            if best is None or res.fun < best.fun:
                best = res
        theta = np.asarray(best.x, dtype=float)
        self._V_warm = None
        V, Q, pi = self._soft(theta)
        D, _ = self._occupancy(self._dyn.transposed_policy(pi), 0)
        phi_pi = np.einsum("sa,sak->sk", pi, self.features)
        self.expected_counts_, self.expert_counts_ = self._counts(phi_pi, D)
        hard = value_iteration(TabularMDP(self.transitions, self.features @ theta, self.discount))
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


# ---- interactions ------------------------------------------------------------------------------
def potential_meetings(domain: PatrolDomain, series_i: np.ndarray, series_j: np.ndarray):
    """(horizon,) bool: both robots observed and *some* pair of actions would make them meet.

    Used to leave game-driven steps out of the per-robot IRL without knowing the policies yet.
    """
    x, y = np.asarray(series_i), np.asarray(series_j)
    both = np.flatnonzero((x >= 0) & (y >= 0))
    out = np.zeros(len(x), dtype=bool)
    if both.size == 0:
        return out
    A = domain.n_actions
    ai, aj = np.meshgrid(np.arange(A), np.arange(A), indexing="ij")
    hit = meeting(
        domain,
        x[both][:, None],
        y[both][:, None],
        ai.ravel()[None, :],
        aj.ravel()[None, :],
    )
    out[both] = hit.any(axis=1)
    return out


def _game_actions(equilibrium_side: Sequence[float], own: np.ndarray, n_actions: int):
    """(n, A) action distribution of a robot playing ``equilibrium_side`` (go/stop/turn)."""
    p = np.asarray(equilibrium_side, dtype=float)
    out = np.zeros((len(own), n_actions))
    out[np.arange(len(own)), own] += p[0]
    out[:, STOP] += p[1]
    out[:, TURN_LEFT] += p[2]
    return out


@dataclass(frozen=True)
class _JointModel:
    """Per robot: ε-greedy P_πᵀ and the equilibrium's game-move matrix Gᵀ (both (S, S) CSR);
    ``meet`` (S, S) bool marks the joint states where the robots' intended moves meet."""

    PT: tuple[sp.csr_array, sp.csr_array]
    GT: tuple[sp.csr_array, sp.csr_array]
    meet: np.ndarray

    def step(self, M: np.ndarray) -> np.ndarray:
        """Joint distribution one step on: Pᵢᵀ (M off meetings) Pⱼ + Gᵢᵀ (M at meetings) Gⱼ.

        A robot's game move depends only on its own state (its policy action, stop or turn), so
        the meeting part factorises like the rest."""
        at = np.where(self.meet, M, 0.0)
        off = M - at
        return self.PT[0] @ (self.PT[1] @ off.T).T + self.GT[0] @ (self.GT[1] @ at.T).T


def _joint_model(domain, policies, transitions, equilibrium, epsilon) -> _JointModel:
    S, A = domain.n_states, domain.n_actions
    pol = [np.asarray(p, dtype=int) for p in policies]
    PT, GT = [], []
    for p, t, side in zip(pol, transitions, (equilibrium.row, equilibrium.col), strict=True):
        dyn = _Dynamics(sp.csr_array(t), A)
        own = np.zeros((S, A))
        own[np.arange(S), p] = 1.0
        PT.append(dyn.transposed_policy((1 - epsilon) * own + epsilon / A))
        game = _game_actions(side, p, A)
        GT.append(dyn.transposed_policy((1 - epsilon) * game + epsilon / A))
    si, sj = np.divmod(np.arange(S * S), S)
    meet = meeting(domain, si, sj, pol[0][si], pol[1][sj]).reshape(S, S)
    return _JointModel((PT[0], PT[1]), (GT[0], GT[1]), meet)


def _condition(M: np.ndarray, x: int, visible: np.ndarray, axis: int) -> None:
    """In-place: keep only what is consistent with one robot's observation at this step."""
    view = M if axis == 0 else M.T
    if x >= 0:
        keep = view[x].copy()
        view[:] = 0.0
        view[x] = keep
    else:
        view[visible] = 0.0


def joint_log_likelihood(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    equilibrium: Equilibrium,
    visible: np.ndarray,
    *,
    epsilon: float = 1e-3,
) -> float:
    """log P(observations of both robots | policies, T, equilibrium), exactly.

    A forward (HMM) filter over the joint state (s_I, s_J): S² states, propagated as an S × S
    matrix M ← P_Iᵀ (M off meetings) P_J + the equilibrium's joint moves at meeting states, then
    conditioned on what L saw (the observed state, or "somewhere not visible"). Policies are the
    greedy ones mixed with ε of uniform actions so that no observation has probability 0.
    """
    x, y = (np.asarray(s, dtype=int) for s in series)
    S = domain.n_states
    vis = np.asarray(visible, dtype=bool).copy()
    vis[x[x >= 0]] = True
    vis[y[y >= 0]] = True
    jm = _joint_model(domain, policies, transitions, equilibrium, epsilon)
    M = np.full((S, S), 1.0 / (S * S))
    total = 0.0
    for t in range(len(x)):
        if t > 0:
            M = jm.step(M)
        _condition(M, x[t], vis, 0)
        _condition(M, y[t], vis, 1)
        c = M.sum()
        if c <= 0.0:  # impossible under the model (e.g. noisy data): restart the filter
            total += np.log(1e-300)
            M = np.full((S, S), 1.0)
            _condition(M, x[t], vis, 0)
            _condition(M, y[t], vis, 1)
            c = M.sum()
        else:
            total += np.log(c)
        M /= c
    return float(total)


def meeting_log_likelihood(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    equilibrium: Equilibrium,
    *,
    epsilon: float = 1e-3,
) -> tuple[float, int]:
    """log-likelihood of the *evident* meetings — both robots observed at t and t+1 and meeting
    under the policies — under the equilibrium, and how many there were."""
    x, y = (np.asarray(s, dtype=int) for s in series)
    t = np.flatnonzero((x[:-1] >= 0) & (y[:-1] >= 0) & (x[1:] >= 0) & (y[1:] >= 0))
    pol = [np.asarray(p, dtype=int) for p in policies]
    t = t[meeting(domain, x[t], y[t], pol[0][x[t]], pol[1][y[t]])]
    if t.size == 0:
        return 0.0, 0
    A = domain.n_actions
    total = 0.0
    for s, s2, p, T, side in (
        (x[t], x[t + 1], pol[0], transitions[0], equilibrium.row),
        (y[t], y[t + 1], pol[1], transitions[1], equilibrium.col),
    ):
        act = (1 - epsilon) * _game_actions(side, p[s], A) + epsilon / A
        Td = sp.csr_array(T)[(s[:, None] * A + np.arange(A)).ravel()][:, s2]
        prob_next = Td.toarray().reshape(len(s), A, len(s))[np.arange(len(s)), :, np.arange(len(s))]
        total += float(np.log(np.maximum((act * prob_next).sum(axis=1), 1e-300)).sum())
    return total, int(t.size)


@dataclass(frozen=True)
class EquilibriumWeights:
    """Candidate equilibria scored against the observations."""

    candidates: tuple[Equilibrium, ...]
    log_likelihoods: np.ndarray  # joint-filter log-likelihood per candidate
    weights: np.ndarray  # posterior under a uniform prior
    meeting_log_likelihoods: np.ndarray  # evident meetings only, per candidate
    n_meetings: int  # evident meetings seen
    best: int

    @property
    def equilibrium(self) -> Equilibrium:
        return self.candidates[self.best]


def weigh_equilibria(
    domain: PatrolDomain,
    series: Sequence[np.ndarray],
    policies: Sequence[np.ndarray],
    transitions: Sequence[sp.csr_array],
    candidates: Sequence[Equilibrium],
    visible: np.ndarray,
    *,
    epsilon: float = 1e-3,
) -> EquilibriumWeights:
    """Weight each candidate equilibrium by the likelihood of everything L saw of both robots
    (:func:`joint_log_likelihood`); ties go to the earlier candidate."""
    if len(series) != 2:
        raise ValueError("equilibrium weighting is defined for two robots")
    ll = np.array(
        [
            joint_log_likelihood(domain, series, policies, transitions, e, visible, epsilon=epsilon)
            for e in candidates
        ]
    )
    meet = [
        meeting_log_likelihood(domain, series, policies, transitions, e, epsilon=epsilon)
        for e in candidates
    ]
    w = np.exp(ll - ll.max())
    w /= w.sum()
    best = int(np.flatnonzero(ll >= ll.max() - 1e-9)[0])
    return EquilibriumWeights(
        tuple(candidates),
        ll,
        w,
        np.array([m[0] for m in meet]),
        meet[0][1] if meet else 0,
        best,
    )
