"""Tests for ``mirl.mdp`` against independent dense-numpy / brute-force computations.

Every random MDP here is tiny (S <= 5, A <= 3) so that the reference computations can be exact:
policy evaluation by solving (I - γ P_π) V = R_π for *every* deterministic policy, enumeration of
all action sequences or all Markov policies for short horizons, and dense matrix powers. The
references only use the dense (S, A, S) transition tensor that the MDP was generated from, never
the module's own helpers.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.mdp import (
    FiniteHorizonResult,
    SolveResult,
    TabularMDP,
    backward_induction,
    greedy_policy,
    optimal_action_mask,
    policy_matrix,
    soft_value_iteration,
    state_visitation,
    validate_transitions,
)
from mirl.mdp import value_iteration as vi

FAST = settings(max_examples=30, deadline=None)


# --------------------------------------------------------------------------- random tiny MDPs


@dataclass
class Tiny:
    T3: np.ndarray  # dense (S, A, S) reference transitions
    R: np.ndarray  # (S, A)
    gamma: float
    rng: np.random.Generator

    @property
    def S(self) -> int:
        return self.R.shape[0]

    @property
    def A(self) -> int:
        return self.R.shape[1]

    @property
    def csr(self) -> sp.csr_array:
        # Row s*A + a is T(s, a, ·): C-order reshape of (S, A, S).
        return sp.csr_array(self.T3.reshape(self.S * self.A, self.S))

    @property
    def mdp(self) -> TabularMDP:
        return TabularMDP(self.csr, self.R, self.gamma)


def make_transitions(
    rng: np.random.Generator, S: int, A: int, *, deterministic: bool = False
) -> np.ndarray:
    T3 = np.zeros((S, A, S))
    for s in range(S):
        for a in range(A):
            if deterministic:
                T3[s, a, rng.integers(S)] = 1.0
                continue
            w = rng.random(S)
            w[rng.random(S) < 0.4] = 0.0  # sparsify
            if w.sum() == 0.0:
                w[rng.integers(S)] = 1.0
            T3[s, a] = w / w.sum()
    return T3


@st.composite
def tiny_mdps(draw, *, max_gamma: float = 0.95, deterministic: bool | None = None) -> Tiny:
    S = draw(st.integers(1, 5))
    A = draw(st.integers(1, 3))
    seed = draw(st.integers(0, 2**32 - 1))
    gamma = draw(st.sampled_from([0.0, 0.3, 0.5, 0.8, 0.9, max_gamma]))
    det = draw(st.booleans()) if deterministic is None else deterministic
    rng = np.random.default_rng(seed)
    T3 = make_transitions(rng, S, A, deterministic=det)
    if draw(st.booleans()):
        R = rng.uniform(-1.0, 1.0, size=(S, A))
    else:  # small integers: produces ties between actions
        R = rng.integers(-2, 3, size=(S, A)).astype(float)
    return Tiny(T3, R, gamma, rng)


# --------------------------------------------------------------------------- references


def all_deterministic_policies(S: int, A: int) -> np.ndarray:
    return np.array(list(itertools.product(range(A), repeat=S)), dtype=int).reshape(-1, S)


def evaluate_policies(T3: np.ndarray, R: np.ndarray, gamma: float, pis: np.ndarray) -> np.ndarray:
    """Exact V^π for a stack of deterministic policies (N, S): solve (I - γ P_π) V = R_π."""
    S = R.shape[0]
    idx = np.arange(S)
    P = T3[idx, pis]  # (N, S, S)
    r = R[idx, pis]  # (N, S)
    return np.linalg.solve(np.eye(S) - gamma * P, r[..., None])[..., 0]


def evaluate_stochastic(T3, R, gamma, pi, bonus=None) -> np.ndarray:
    P = np.einsum("sa,sat->st", pi, T3)
    r = (pi * R).sum(axis=1) + (0.0 if bonus is None else bonus)
    return np.linalg.solve(np.eye(R.shape[0]) - gamma * P, r)


def lse(x: np.ndarray, axis: int) -> np.ndarray:
    m = x.max(axis=axis, keepdims=True)
    return (m + np.log(np.exp(x - m).sum(axis=axis, keepdims=True))).squeeze(axis)


def dense_soft_vi(T3, R, gamma, tau, iters=5000) -> np.ndarray:
    V = np.zeros(R.shape[0])
    for _ in range(iters):
        V_new = tau * lse((R + gamma * T3 @ V) / tau, axis=1)
        if np.max(np.abs(V_new - V), initial=0.0) < 1e-13:
            return V_new
        V = V_new
    return V


# --------------------------------------------------------------------------- value_iteration


@FAST
@given(tiny_mdps())
def test_value_iteration_matches_best_deterministic_policy(m: Tiny):
    res = vi(m.mdp, tol=1e-10)
    assert isinstance(res, SolveResult)
    assert res.success
    assert res.values.shape == (m.S,)
    assert res.q_values.shape == (m.S, m.A)
    assert res.policy.shape == (m.S,)
    assert np.issubdtype(res.policy.dtype, np.integer)

    pis = all_deterministic_policies(m.S, m.A)
    V_all = evaluate_policies(m.T3, m.R, m.gamma, pis)  # (A^S, S)
    V_star = V_all.max(axis=0)
    # A single policy attains the optimum in every state simultaneously.
    assert np.any(np.all(V_all >= V_star - 1e-9, axis=1))
    np.testing.assert_allclose(res.values, V_star, atol=1e-7)

    # VI's greedy policy is one of the optimal deterministic policies.
    optimal = np.all(V_all >= V_star - 1e-7, axis=1)
    assert any(np.array_equal(res.policy, p) for p in pis[optimal])

    # Q is the Bellman backup of V (Q from the previous sweep: within tolerance).
    np.testing.assert_allclose(res.q_values, m.R + m.gamma * m.T3 @ V_star, atol=1e-7)


@FAST
@given(tiny_mdps(), st.integers(0, 2**32 - 1))
def test_value_iteration_independent_of_initial_values(m: Tiny, seed: int):
    V0 = np.random.default_rng(seed).normal(scale=10.0, size=m.S)
    a = vi(m.mdp, tol=1e-11)
    b = vi(m.mdp, tol=1e-11, initial_values=V0)
    np.testing.assert_allclose(a.values, b.values, atol=1e-8)
    np.testing.assert_array_equal(V0, np.random.default_rng(seed).normal(scale=10.0, size=m.S))


def test_value_iteration_hand_made_chain():
    # 0 --right--> 1 --right--> 2 (absorbing, reward 1 per step when staying); "left" stays put.
    S, A, g = 3, 2, 0.9
    T3 = np.zeros((S, A, S))
    T3[0, 0, 0] = T3[1, 0, 1] = T3[2, 0, 2] = 1.0  # action 0: stay
    T3[0, 1, 1] = T3[1, 1, 2] = T3[2, 1, 2] = 1.0  # action 1: move right
    R = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 1.0]])
    res = vi(TabularMDP(sp.csr_array(T3.reshape(S * A, S)), R, g), tol=1e-12)
    v2 = 1.0 / (1.0 - g)
    np.testing.assert_allclose(res.values, [g * g * v2, g * v2, v2], atol=1e-9)
    # In state 2 both actions tie: the lowest index wins.
    np.testing.assert_array_equal(res.policy, [1, 1, 0])


def test_value_iteration_zero_discount_is_myopic():
    rng = np.random.default_rng(0)
    T3 = make_transitions(rng, 4, 3)
    R = rng.normal(size=(4, 3))
    res = vi(TabularMDP(sp.csr_array(T3.reshape(12, 4)), R, 0.0))
    np.testing.assert_allclose(res.values, R.max(axis=1))
    np.testing.assert_array_equal(res.policy, R.argmax(axis=1))


def test_value_iteration_reports_max_iter():
    rng = np.random.default_rng(1)
    T3 = make_transitions(rng, 3, 2)
    res = vi(TabularMDP(sp.csr_array(T3.reshape(6, 3)), rng.normal(size=(3, 2)), 0.9), max_iter=3)
    assert not res.success
    assert res.iterations == 3
    assert "max_iter" in res.message


# --------------------------------------------------------------------------- soft_value_iteration


@FAST
@given(tiny_mdps(max_gamma=0.9), st.sampled_from([0.1, 0.5, 1.0, 3.0]))
def test_soft_value_iteration_fixed_point(m: Tiny, tau: float):
    res = soft_value_iteration(m.mdp, temperature=tau, tol=1e-11)
    assert res.success
    V, Q, pi = res.values, res.q_values, res.policy
    assert pi.shape == (m.S, m.A)

    # Soft Bellman fixed point, computed densely and independently.
    Q_ref = m.R + m.gamma * m.T3 @ V
    np.testing.assert_allclose(Q, Q_ref, atol=1e-8)
    np.testing.assert_allclose(V, tau * lse(Q_ref / tau, axis=1), atol=1e-8)
    np.testing.assert_allclose(V, dense_soft_vi(m.T3, m.R, m.gamma, tau), atol=1e-8)

    # Boltzmann policy whose rows are distributions.
    assert np.all(pi >= 0.0)
    np.testing.assert_allclose(pi.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(pi, np.exp((Q_ref - V[:, None]) / tau), atol=1e-8)

    # V is the entropy-regularised return of that policy: (I - γ P_π) V = R_π + τ H(π).
    with np.errstate(divide="ignore", invalid="ignore"):
        ent = -np.where(pi > 0, pi * np.log(pi), 0.0).sum(axis=1)
    np.testing.assert_allclose(evaluate_stochastic(m.T3, m.R, m.gamma, pi, tau * ent), V, atol=1e-7)


@FAST
@given(tiny_mdps(max_gamma=0.9))
def test_soft_values_approach_hard_values_as_temperature_shrinks(m: Tiny):
    hard = vi(m.mdp, tol=1e-12).values
    gaps = []
    for tau in [1.0, 0.1, 0.01, 0.001]:
        soft = soft_value_iteration(m.mdp, temperature=tau, tol=1e-12).values
        gap = soft - hard
        # max ≤ τ logsumexp(x/τ) ≤ max + τ log A, propagated through the γ-contraction.
        assert np.all(gap >= -1e-9)
        assert np.all(gap <= tau * math.log(m.A) / (1.0 - m.gamma) + 1e-9)
        gaps.append(gap.max())
    assert gaps[-1] <= 1e-3 * math.log(max(m.A, 1)) / (1.0 - m.gamma) + 1e-9
    assert all(g2 <= g1 + 1e-9 for g1, g2 in zip(gaps, gaps[1:], strict=False))


@FAST
@given(tiny_mdps(max_gamma=0.9))
def test_soft_value_iteration_single_action_equals_policy_evaluation(m: Tiny):
    R1 = m.R[:, :1]
    T1 = m.T3[:, :1, :]
    mdp = TabularMDP(sp.csr_array(T1.reshape(m.S, m.S)), R1, m.gamma)
    res = soft_value_iteration(mdp, temperature=0.7, tol=1e-12)
    V = np.linalg.solve(np.eye(m.S) - m.gamma * T1[:, 0, :], R1[:, 0])
    np.testing.assert_allclose(res.values, V, atol=1e-9)
    np.testing.assert_allclose(res.policy, 1.0)


@pytest.mark.parametrize("tau", [0.0, -1.0])
def test_soft_value_iteration_rejects_nonpositive_temperature(tau):
    mdp = TabularMDP(sp.csr_array(np.eye(2)), np.zeros((2, 1)), 0.5)
    with pytest.raises(ValueError, match="temperature"):
        soft_value_iteration(mdp, temperature=tau)


# --------------------------------------------------------------------------- backward_induction


def recursive_dp(T3, R, H, terminal, gamma):
    """Plain recursive finite-horizon DP with explicit loops (R is (S, A) or (H, S, A))."""
    S, A = T3.shape[:2]
    memo: dict[tuple[int, int], float] = {}

    def r(t, s, a):
        return R[t, s, a] if R.ndim == 3 else R[s, a]

    def q(t, s, a):
        return r(t, s, a) + gamma * sum(T3[s, a, s2] * v(t + 1, s2) for s2 in range(S))

    def v(t, s):
        if t == H:
            return terminal[s]
        if (t, s) not in memo:
            memo[t, s] = max(q(t, s, a) for a in range(A))
        return memo[t, s]

    V = np.array([[v(t, s) for s in range(S)] for t in range(H + 1)])
    Q = np.array([[[q(t, s, a) for a in range(A)] for s in range(S)] for t in range(H)])
    return V, Q.reshape(H, S, A)


def best_action_sequence(T3, R, H, terminal, gamma, s0):
    """Deterministic dynamics only: maximise over all A^H open-loop action sequences."""
    S, A = T3.shape[:2]
    nxt = T3.argmax(axis=2)
    best = -np.inf
    for seq in itertools.product(range(A), repeat=H):
        s, total = s0, 0.0
        for t, a in enumerate(seq):
            total += gamma**t * (R[t, s, a] if R.ndim == 3 else R[s, a])
            s = nxt[s, a]
        best = max(best, total + gamma**H * terminal[s])
    return best


def best_markov_policy(T3, R, H, terminal, gamma):
    """Stochastic dynamics: maximise over all (A^S)^H time-indexed deterministic policies."""
    S = T3.shape[0]
    idx = np.arange(S)
    pis = all_deterministic_policies(S, T3.shape[1])
    best = np.full(S, -np.inf)
    for plan in itertools.product(range(len(pis)), repeat=H):
        V = terminal.astype(float)
        for t in range(H - 1, -1, -1):
            pi = pis[plan[t]]
            R_t = R[t] if R.ndim == 3 else R
            V = R_t[idx, pi] + gamma * T3[idx, pi] @ V
        best = np.maximum(best, V)
    return best


@st.composite
def finite_horizon_problems(draw, *, deterministic: bool | None = None, small: bool = False):
    m = draw(tiny_mdps(deterministic=deterministic))
    if small:  # keep (A^S)^H tiny for brute force over Markov policies
        S, A = min(m.S, 3), min(m.A, 2)
        m = Tiny(make_transitions(m.rng, S, A), m.R[:S, :A], m.gamma, m.rng)
    H = draw(st.integers(0, 2 if small else 3))
    time_indexed = draw(st.booleans())
    R = m.rng.uniform(-1, 1, size=(H, m.S, m.A)) if time_indexed else m.R
    terminal = m.rng.uniform(-2, 2, size=m.S) if draw(st.booleans()) else None
    gamma = draw(st.sampled_from([1.0, 0.9, 0.5, 0.0]))
    return m, R, H, terminal, gamma


def run_bi(m: Tiny, R, H, terminal, gamma) -> FiniteHorizonResult:
    return backward_induction(m.csr, R, H, terminal_values=terminal, discount=gamma)


@FAST
@given(finite_horizon_problems())
def test_backward_induction_matches_recursive_dp(problem):
    m, R, H, terminal, gamma = problem
    res = run_bi(m, R, H, terminal, gamma)
    term = np.zeros(m.S) if terminal is None else terminal
    V_ref, Q_ref = recursive_dp(m.T3, R, H, term, gamma)
    assert res.values.shape == (H + 1, m.S)
    assert res.q_values.shape == (H, m.S, m.A)
    assert res.policy.shape == (H, m.S)
    np.testing.assert_allclose(res.values, V_ref, atol=1e-12)
    np.testing.assert_allclose(res.q_values, Q_ref, atol=1e-12)
    np.testing.assert_allclose(res.values[H], term)
    # The policy attains the value, and is the lowest-index maximiser.
    for t in range(H):
        for s in range(m.S):
            a = res.policy[t, s]
            assert res.q_values[t, s, a] == res.values[t, s]
            assert np.all(res.q_values[t, s, :a] < res.values[t, s])


@FAST
@given(finite_horizon_problems(deterministic=True))
def test_backward_induction_matches_action_sequence_enumeration(problem):
    m, R, H, terminal, gamma = problem
    res = run_bi(m, R, H, terminal, gamma)
    term = np.zeros(m.S) if terminal is None else terminal
    ref = [best_action_sequence(m.T3, R, H, term, gamma, s0) for s0 in range(m.S)]
    np.testing.assert_allclose(res.values[0], ref, atol=1e-12)


@FAST
@given(finite_horizon_problems(deterministic=False, small=True))
def test_backward_induction_matches_markov_policy_enumeration(problem):
    m, R, H, terminal, gamma = problem
    res = run_bi(m, R, H, terminal, gamma)
    term = np.zeros(m.S) if terminal is None else terminal
    np.testing.assert_allclose(
        res.values[0], best_markov_policy(m.T3, R, H, term, gamma), atol=1e-12
    )


def test_backward_induction_hand_made():
    # Two states; action 1 in state 0 jumps to state 1 which pays 5 at the end.
    T3 = np.zeros((2, 2, 2))
    T3[0, 0, 0] = T3[0, 1, 1] = T3[1, 0, 1] = T3[1, 1, 0] = 1.0
    R = np.array([[1.0, 0.0], [0.0, 0.0]])
    res = backward_induction(
        sp.csr_array(T3.reshape(4, 2)), R, 2, terminal_values=np.array([0.0, 5.0]), discount=0.5
    )
    # t=1: state 0: max(1 + .5*0, 0 + .5*5) = 2.5 (a=1); state 1: max(.5*5, .5*0) = 2.5 (a=0)
    # t=0: state 0: max(1 + .5*2.5, 0 + .5*2.5) = 2.25 (a=0); state 1: max(1.25, 1.25) = 1.25
    np.testing.assert_allclose(res.values, [[2.25, 1.25], [2.5, 2.5], [0.0, 5.0]])
    np.testing.assert_array_equal(res.policy, [[0, 0], [1, 0]])


def reference_bi_skipping_zeros(T3, R, H, terminal, gamma):
    """Plain loops, summing T(s, a, s') V(s') over the s' with T > 0 only (as a sparse product
    does, so a NaN stays where it was put), actions chosen by numpy's argmax (first maximiser,
    or first NaN)."""
    S, A = T3.shape[:2]
    V, Q = np.zeros((H + 1, S)), np.zeros((H, S, A))
    V[H] = terminal
    for t in range(H - 1, -1, -1):
        for s, a in itertools.product(range(S), range(A)):
            nxt = np.flatnonzero(T3[s, a])
            ev = sum((T3[s, a, s2] * V[t + 1, s2] for s2 in nxt), 0.0)
            Q[t, s, a] = (R[t, s, a] if R.ndim == 3 else R[s, a]) + gamma * ev
        V[t] = Q[t].max(axis=1)
    return V, Q, Q.argmax(axis=2)


@FAST
@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.sampled_from([1.0, 0.5, 0.0]))
def test_backward_induction_equals_reference_bit_for_bit_with_exact_ties(seed, A, gamma):
    # Probabilities in quarters, integer rewards, γ a power of two: every sum is exact, so the
    # reference and the sweeps agree bit for bit and ties among up to 9 actions are exact ties.
    rng = np.random.default_rng(seed)
    S, H = 5, 4
    T3 = rng.multinomial(4, np.ones(S) / S, size=(S, A)) / 4.0
    R = rng.integers(-1, 2, size=(H, S, A) if rng.random() < 0.5 else (S, A)).astype(float)
    terminal = rng.integers(-1, 2, size=S).astype(float)
    res = backward_induction(sp.csr_array(T3.reshape(S * A, S)), R, H,
                             terminal_values=terminal, discount=gamma)  # fmt: skip
    V_ref, Q_ref, pol_ref = reference_bi_skipping_zeros(T3, R, H, terminal, gamma)
    np.testing.assert_array_equal(res.values, V_ref)
    np.testing.assert_array_equal(res.policy, pol_ref)
    np.testing.assert_array_equal(res.q_values, Q_ref)
    assert res.q_values is res.q_values  # computed once


def test_backward_induction_nan_rewards_pick_the_first_nan_as_argmax_does():
    rng = np.random.default_rng(3)
    S, A, H = 4, 3, 3
    T3 = rng.multinomial(4, np.ones(S) / S, size=(S, A)) / 4.0
    R = rng.integers(-1, 2, size=(S, A)).astype(float)
    R[1, 2] = R[2, 1] = np.nan
    res = backward_induction(sp.csr_array(T3.reshape(S * A, S)), R, H, discount=0.5)
    V_ref, Q_ref, pol_ref = reference_bi_skipping_zeros(T3, R, H, np.zeros(S), 0.5)
    assert np.isnan(res.values[0]).any()
    np.testing.assert_array_equal(res.values, V_ref)
    np.testing.assert_array_equal(res.policy, pol_ref)


def test_backward_induction_values_are_read_only_and_policy_compact():
    res = backward_induction(sp.csr_array(np.eye(2)), np.zeros((2, 1)), 2)
    with pytest.raises(ValueError, match="read-only"):
        res.values[0, 0] = 1.0  # the lazily computed q_values derive from them
    assert res.policy.dtype == np.uint8
    assert backward_induction(sp.csr_array(np.eye(2)), np.zeros((2, 1)), 0).q_values.shape == (
        0, 2, 1,
    )  # fmt: skip


def test_value_iteration_leaves_initial_values_untouched():
    rng = np.random.default_rng(0)
    m = Tiny(make_transitions(rng, 4, 2), rng.uniform(-1, 1, (4, 2)), 0.9, rng)
    init = rng.normal(size=4)
    kept = init.copy()
    res = vi(m.mdp, initial_values=init)  # the sweeps reuse two value buffers
    np.testing.assert_array_equal(init, kept)
    assert res.values is not init


def test_backward_induction_rejects_wrong_number_of_reward_slices():
    with pytest.raises(ValueError, match="3 slices, got 2"):
        backward_induction(sp.csr_array(np.eye(2)), np.zeros((2, 2, 1)), 3)


# --------------------------------------------------------------------------- greedy / mask


def reference_first_argmax(q: np.ndarray) -> np.ndarray:
    flat = q.reshape(-1, q.shape[-1])
    out = np.empty(flat.shape[0], dtype=int)
    for i, row in enumerate(flat):
        out[i] = min(j for j, x in enumerate(row) if x == max(row))
    return out.reshape(q.shape[:-1])


def test_greedy_policy_and_mask_hand_made():
    Q = np.array([[1.0, 2.0, 2.0], [3.0, 3.0, 0.0], [0.0, 0.0, 0.0], [-1.0, -2.0, -3.0]])
    np.testing.assert_array_equal(greedy_policy(Q), [1, 0, 0, 0])
    np.testing.assert_array_equal(
        optimal_action_mask(Q),
        [[False, True, True], [True, True, False], [True, True, True], [True, False, False]],
    )
    # Differences below the tolerance count as ties; real differences do not.
    np.testing.assert_array_equal(optimal_action_mask(np.array([1.0, 1.0 + 1e-12])), [True, True])
    assert greedy_policy(np.array([1.0, 1.0 + 1e-12])) == 0
    assert greedy_policy(np.array([1.0, 1.0 + 1e-6])) == 1


@FAST
@given(
    st.integers(0, 2**32 - 1),
    st.lists(st.integers(1, 4), min_size=0, max_size=2),
    st.integers(1, 3),
)
def test_greedy_policy_lowest_index_among_ties(seed, batch, A):
    rng = np.random.default_rng(seed)
    Q = rng.integers(-2, 3, size=(*batch, A)).astype(float) * 0.37  # many exact ties
    mask = optimal_action_mask(Q)
    assert mask.shape == Q.shape
    np.testing.assert_array_equal(mask, Q == Q.max(axis=-1, keepdims=True))
    np.testing.assert_array_equal(greedy_policy(Q), reference_first_argmax(Q))
    assert np.all(mask.any(axis=-1))


# --------------------------------------------------------------------------- policy_matrix


def random_stochastic_policy(rng, S, A):
    pi = rng.random((S, A))
    pi[rng.random((S, A)) < 0.3] = 0.0
    pi[np.arange(S), rng.integers(A, size=S)] += 0.1
    return pi / pi.sum(axis=1, keepdims=True)


@FAST
@given(tiny_mdps())
def test_policy_matrix_matches_dense(m: Tiny):
    pi_det = m.rng.integers(m.A, size=m.S)
    P = policy_matrix(m.csr, pi_det)
    assert sp.issparse(P) and P.shape == (m.S, m.S)
    dense_det = np.array([m.T3[s, pi_det[s]] for s in range(m.S)])
    np.testing.assert_allclose(P.toarray(), dense_det, atol=1e-15)

    pi = random_stochastic_policy(m.rng, m.S, m.A)
    P = policy_matrix(m.csr, pi)
    assert sp.issparse(P) and P.shape == (m.S, m.S)
    dense = sum(pi[:, a, None] * m.T3[:, a, :] for a in range(m.A))
    np.testing.assert_allclose(P.toarray(), dense, atol=1e-14)
    np.testing.assert_allclose(P.toarray().sum(axis=1), 1.0, atol=1e-12)

    # A one-hot stochastic policy is the same as the deterministic one.
    onehot = np.eye(m.A)[pi_det]
    np.testing.assert_allclose(policy_matrix(m.csr, onehot).toarray(), dense_det, atol=1e-15)


# --------------------------------------------------------------------------- state_visitation


@FAST
@given(tiny_mdps(), st.integers(0, 6), st.booleans())
def test_state_visitation_matches_matrix_powers(m: Tiny, steps: int, stochastic: bool):
    if stochastic:
        pi = random_stochastic_policy(m.rng, m.S, m.A)
    else:
        pi = m.rng.integers(m.A, size=m.S)
    pi_dense = pi if stochastic else np.eye(m.A)[pi]
    P_pi = np.einsum("sa,sat->st", pi_dense, m.T3)
    d0 = m.rng.dirichlet(np.ones(m.S))
    out = state_visitation(m.csr, pi, d0, steps)
    assert out.shape == (steps + 1, m.S)
    for t in range(steps + 1):
        np.testing.assert_allclose(out[t], d0 @ np.linalg.matrix_power(P_pi, t), atol=1e-12)
    np.testing.assert_allclose(out.sum(axis=1), 1.0, atol=1e-12)
    assert np.all(out >= -1e-15)


def test_state_visitation_hand_made_cycle():
    # Deterministic 3-cycle under action 1; action 0 stays.
    S, A = 3, 2
    T3 = np.zeros((S, A, S))
    for s in range(S):
        T3[s, 0, s] = 1.0
        T3[s, 1, (s + 1) % S] = 1.0
    out = state_visitation(sp.csr_array(T3.reshape(S * A, S)), np.ones(S, int), np.eye(S)[0], 4)
    np.testing.assert_array_equal(out, np.eye(S)[[0, 1, 2, 0, 1]])


# --------------------------------------------------------------------------- validation


def test_validate_transitions_accepts_and_returns_csr():
    T = np.array([[0.5, 0.5], [1.0, 0.0], [0.0, 1.0], [0.25, 0.75]])
    for form in (T, sp.csr_matrix(T), sp.coo_array(T), sp.csr_array(T)):
        P = validate_transitions(form, 2)
        assert isinstance(P, sp.csr_array)
        np.testing.assert_array_equal(P.toarray(), T)


@pytest.mark.parametrize(
    ("T", "A", "match"),
    [
        (np.full((5, 2), 0.5), 2, r"shape \(S\*A, S\) = \(4, 2\), got \(5, 2\)"),
        (np.full((4, 2), 0.5), 3, r"shape \(S\*A, S\) = \(6, 2\)"),
        (np.full((2, 4), 0.25), 2, r"got \(2, 4\)"),
        (np.array([[1.5, -0.5], [1.0, 0.0]]), 1, "negative"),
        (np.array([[1.0, 0.0], [0.5, 0.4]]), 1, r"T\(s=1, a=0, ·\) sums to 0.9, not 1"),
        (np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.7, 0.7]]), 2, r"s=1, a=1.*1\.4"),
        (np.array([[1.0, 0.0], [0.0, 0.0]]), 1, r"s=1, a=0.*sums to 0,"),
        (np.array([[np.nan, 1.0], [0.0, 1.0]]), 1, "non-finite"),
        (np.array([[np.inf, 1.0], [0.0, 1.0]]), 1, "non-finite"),
        (np.array([1.0]), 1, "shape"),
    ],
)
def test_validate_transitions_rejects(T, A, match):
    with pytest.raises(ValueError, match=match):
        validate_transitions(T, A)


@FAST
@given(tiny_mdps(), st.integers(0, 100), st.sampled_from([0.0, 0.5, 0.999, 1.001, 2.0]))
def test_validate_transitions_names_first_bad_row(m: Tiny, pick: int, scale: float):
    s, a = divmod(pick % (m.S * m.A), m.A)
    T3 = m.T3.copy()
    T3[s, a] *= scale
    with pytest.raises(ValueError, match=rf"T\(s={s}, a={a}, ·\) sums to"):
        validate_transitions(sp.csr_array(T3.reshape(m.S * m.A, m.S)), m.A)


def test_tabular_mdp_normalises_inputs():
    T = np.array([[0.5, 0.5], [1.0, 0.0], [0.0, 1.0], [0.25, 0.75]])
    mdp = TabularMDP(T, [[1, 2], [3, 4]], 0.0)
    assert isinstance(mdp.transitions, sp.csr_array)
    assert mdp.rewards.dtype == float
    assert (mdp.n_states, mdp.n_actions) == (2, 2)
    np.testing.assert_allclose(mdp.expected_next(np.array([1.0, 3.0])), [[2.0, 1.0], [3.0, 2.5]])


@pytest.mark.parametrize(
    ("T", "R", "gamma", "match"),
    [
        (np.eye(2), np.zeros(2), 0.5, r"rewards must be \(S, A\)"),
        (np.eye(2), np.zeros((1, 2, 1)), 0.5, r"rewards must be \(S, A\)"),
        (np.eye(2), np.zeros((3, 1)), 0.5, "transitions have 2 states, rewards 3"),
        (np.eye(2), np.zeros((2, 2)), 0.5, "shape"),
        (np.array([[0.5, 0.6], [0.0, 1.0]]), np.zeros((2, 1)), 0.5, "s=0, a=0"),
        (np.array([[1.2, -0.2], [0.0, 1.0]]), np.zeros((2, 1)), 0.5, "negative"),
        (np.eye(2), np.zeros((2, 1)), 1.0, "discount"),
        (np.eye(2), np.zeros((2, 1)), -0.1, "discount"),
        (np.eye(2), np.zeros((2, 1)), 1.5, "discount"),
        (np.eye(2), np.zeros((2, 1)), float("nan"), "discount"),
    ],
)
def test_tabular_mdp_rejects(T, R, gamma, match):
    with pytest.raises(ValueError, match=match):
        TabularMDP(T, R, gamma)


def test_tabular_mdp_and_value_iteration_refuse_what_no_sweep_can_use():
    """A NaN or infinite reward ran all 10 000 sweeps into NaNs (with RuntimeWarnings), a
    string discount failed as a comparison, ``tol=0`` or ``-1`` could never be met,
    ``max_iter=-3`` reported -3 iterations, and an (S+1,) start failed inside numpy."""
    T = np.eye(2)
    for R, needle in [([[np.nan], [0.0]], r"R\(s=0, a=0\) = nan"), ([[0.0], [np.inf]], "s=1")]:
        with pytest.raises(ValueError, match=f"rewards contain non-finite values: .*{needle}"):
            TabularMDP(T, R, 0.5)
    with pytest.raises(ValueError, match=r"discount must be in \[0, 1\), got '0.5'"):
        TabularMDP(T, np.zeros((2, 1)), "0.5")
    mdp = TabularMDP(T, np.zeros((2, 1)), 0.5)
    for kwargs, needle in [
        ({"tol": 0.0}, "`tol` must be a number > 0"),
        ({"tol": -1.0}, "`tol` must be a number > 0"),
        ({"max_iter": -3}, "`max_iter` must be an integer >= 0"),
        ({"max_iter": 2.5}, "`max_iter` must be an integer >= 0"),
        ({"initial_values": np.zeros(3)}, r"`initial_values` must be 2 finite numbers.*\(3,\)"),
        ({"initial_values": [np.nan, 0.0]}, "`initial_values` must be 2 finite numbers"),
    ]:
        with pytest.raises(ValueError, match=needle):
            vi(mdp, **kwargs)
    assert vi(mdp, initial_values=[1, 2], max_iter=0).iterations == 0
