"""Soft policy iteration (Newton's method on the soft Bellman equation) against soft value
iteration and against the equation itself, on random MDPs small enough for the dense solves
and large enough for the sparse ones."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.special import logsumexp

from mirl.learning.soft_policy import soft_policy_iteration
from mirl.mdp import TabularMDP, soft_value_iteration, value_iteration


def random_mdp(S: int, A: int, seed: int, successors: int = 3):
    """T with a few successors per (s, a), rewards in [-1, 1]."""
    rng = np.random.default_rng(seed)
    rows = np.repeat(np.arange(S * A), successors)
    cols = rng.integers(0, S, S * A * successors)
    vals = rng.random(S * A * successors) + 0.05
    T = sp.csr_array((vals, (rows, cols)), shape=(S * A, S))
    T = sp.csr_array(sp.diags_array(1.0 / np.asarray(T.sum(axis=1)).ravel()) @ T)
    return T, rng.uniform(-1, 1, (S, A))


# 40 states take the dense linear solves, 450 the sparse ones (the limit is 200)
@pytest.mark.parametrize("S, seed", [(40, 0), (40, 1), (450, 2)])
@pytest.mark.parametrize("temperature", [0.3, 1.0])
def test_it_agrees_with_soft_value_iteration(S, seed, temperature):
    T, R = random_mdp(S, 4, seed)
    V, Q, pi, iterations = soft_policy_iteration(T, R, 0.9, temperature=temperature)
    ref = soft_value_iteration(TabularMDP(T, R, 0.9), temperature=temperature, tol=1e-12)
    assert iterations < 15  # Newton: a handful of solves
    np.testing.assert_allclose(V, ref.values, atol=1e-7)
    np.testing.assert_allclose(Q, ref.q_values, atol=1e-7)
    np.testing.assert_allclose(pi, ref.policy, atol=1e-8)


def test_its_answer_solves_the_soft_bellman_equation():
    T, R = random_mdp(60, 3, 5)
    tau, gamma = 0.5, 0.95
    V, Q, pi, _ = soft_policy_iteration(T, R, gamma, temperature=tau)
    np.testing.assert_allclose(Q, R + gamma * (T @ V).reshape(60, 3), atol=1e-9)
    np.testing.assert_allclose(V, tau * logsumexp(Q / tau, axis=1), atol=1e-9)
    np.testing.assert_allclose(pi, np.exp((Q - V[:, None]) / tau), atol=1e-12)
    np.testing.assert_allclose(pi.sum(axis=1), 1.0)


def test_a_warm_start_at_the_answer_stops_at_once():
    T, R = random_mdp(30, 4, 7)
    V, *_ = soft_policy_iteration(T, R, 0.9)
    _, _, _, iterations = soft_policy_iteration(T, R, 0.9, initial_values=V)
    assert iterations == 1


def test_a_cold_temperature_approaches_the_greedy_policy():
    T, R = random_mdp(25, 4, 3)
    hard = value_iteration(TabularMDP(T, R, 0.9))
    V, _, pi, _ = soft_policy_iteration(T, R, 0.9, temperature=1e-3)
    assert (pi.argmax(axis=1) == hard.policy).all()
    np.testing.assert_allclose(V, hard.values, atol=0.05)  # τ log A above, at most
