"""``transition_matrix`` (Eq. 5) against a dense brute-force implementation with explicit loops.

The reference builds T[s, a, s'] from a hand-written ψ (loop over cells and headings) and the
ξ table of docs/design.md, adding mass action by action, so coinciding intended states (a forward
into a wall lands where stop does) are summed exactly as Eq. 5 says.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.world.catalog import load_map
from mirl.world.domain import ACTIONS, FeatureMap, FeatureOverride, PatrolDomain
from mirl.world.motion import transition_matrix
from tests.references.motion_model import DELTA, FEATURES, SPEC_XI

CARPET_CELLS = {(3, 1), (4, 1), (0, 5), (16, 8)}


def ref_psi(free, state, action):
    r, c, h = state
    if action == "forward":
        dr, dc = DELTA[h]
        nr, nc = r + dr, c + dc
        if 0 <= nr < free.shape[0] and 0 <= nc < free.shape[1] and free[nr, nc]:
            return (nr, nc, h)
        return state
    if action == "turn_left":
        return (r, c, (h + 1) % 4)
    if action == "turn_right":
        return (r, c, (h - 1) % 4)
    return state


def dense_eq5(free, probabilities, error_model, carpet=False):
    """T as an (S, A, S) dense array, state order row-major cells × headings."""
    states = [
        (r, c, h)
        for r in range(free.shape[0])
        for c in range(free.shape[1])
        if free[r, c]
        for h in range(4)
    ]
    index = {s: i for i, s in enumerate(states)}
    S, A = len(states), len(ACTIONS)
    T = np.zeros((S, A, S))
    for i, s in enumerate(states):
        for a, name in enumerate(ACTIONS):
            subset = set(SPEC_XI[name])
            if carpet and s[:2] in CARPET_CELLS:
                subset.add("carpet")
            p = math.prod(probabilities[f] for f in subset)
            T[i, a, index[ref_psi(free, s, name)]] += p
            if error_model == "uniform":
                for b, other in enumerate(ACTIONS):
                    if b != a:
                        T[i, a, index[ref_psi(free, s, other)]] += (1 - p) / (A - 1)
            else:
                T[i, a, i] += 1 - p
    return T


@pytest.fixture(scope="module")
def boyd2():
    return PatrolDomain(load_map("boyd2"))


@pytest.fixture(scope="module")
def boyd2_carpet():
    fm = FeatureMap(
        features=(*FEATURES, "carpet"),
        action_subsets={a: tuple(sorted(v)) for a, v in SPEC_XI.items()},
        overrides=(FeatureOverride(cells=tuple(sorted(CARPET_CELLS)), add=("carpet",)),),
    )
    return PatrolDomain(load_map("boyd2"), fm)


def as_dense(T: sp.csr_array, S: int) -> np.ndarray:
    assert T.shape == (S * 4, S)
    return T.toarray().reshape(S, 4, S)


probability = st.one_of(st.sampled_from([0.0, 1.0, 0.5]), st.floats(0.0, 1.0, allow_nan=False))
feature_probs = st.fixed_dictionaries({f: probability for f in FEATURES})


@settings(max_examples=25, deadline=None)
@given(feature_probs, st.sampled_from(["uniform", "stop"]))
def test_matches_dense_eq5(boyd2, probs, error_model):
    free = boyd2.map.patroller
    ref = dense_eq5(free, probs, error_model)
    got = as_dense(transition_matrix(boyd2, probs, error_model), boyd2.n_states)
    np.testing.assert_allclose(got, ref, atol=1e-12)
    np.testing.assert_allclose(got.sum(axis=2), 1.0, atol=1e-12)
    assert got.min() >= 0.0


@settings(max_examples=15, deadline=None)
@given(feature_probs, probability, st.sampled_from(["uniform", "stop"]))
def test_matches_dense_eq5_with_state_dependent_xi(boyd2_carpet, probs, carpet, error_model):
    probs = {**probs, "carpet": carpet}
    ref = dense_eq5(boyd2_carpet.map.patroller, probs, error_model, carpet=True)
    got = as_dense(transition_matrix(boyd2_carpet, probs, error_model), boyd2_carpet.n_states)
    np.testing.assert_allclose(got, ref, atol=1e-12)
    np.testing.assert_allclose(got.sum(axis=2), 1.0, atol=1e-12)


def test_shared_intended_states_are_summed(boyd2):
    """A forward into a wall stays put, like stop: their masses add up in that row."""
    probs = {"left_wheel": 0.7, "right_wheel": 0.95, "navigation": 0.97, "floor": 0.99}
    T = as_dense(transition_matrix(boyd2, probs, "uniform"), boyd2.n_states)
    p_fwd = 0.7 * 0.95 * 0.97 * 0.99
    p_stop = 0.99
    blocked = [s for s in range(boyd2.n_states) if boyd2.intended[s, 0] == s]
    assert len(blocked) > 0
    for s in blocked:
        # forward: success stays, plus stop's share of the failure
        assert T[s, 0, s] == pytest.approx(p_fwd + (1 - p_fwd) / 3)
        # stop: success stays, plus forward's share of the failure
        assert T[s, 3, s] == pytest.approx(p_stop + (1 - p_stop) / 3)
        assert np.count_nonzero(T[s, 0]) == 3  # s, s+left, s+right
        assert T[s].sum() == pytest.approx(4.0)
    # a free forward: four distinct targets
    free = next(s for s in range(boyd2.n_states) if boyd2.intended[s, 0] != s)
    assert np.count_nonzero(T[free, 0]) == 4
    assert T[free, 0, boyd2.intended[free, 0]] == pytest.approx(p_fwd)


@pytest.mark.parametrize("error_model", ["uniform", "stop"])
def test_certain_features_give_deterministic_psi(boyd2, error_model):
    probs = dict.fromkeys(FEATURES, 1.0)
    T = transition_matrix(boyd2, probs, error_model)
    S = boyd2.n_states
    expected = np.zeros((S * 4, S))
    free = boyd2.map.patroller
    states = [tuple(map(int, s)) for s in boyd2.states]
    index = {s: i for i, s in enumerate(states)}
    for i, s in enumerate(states):
        for a, name in enumerate(ACTIONS):
            expected[i * 4 + a, index[ref_psi(free, s, name)]] = 1.0
    np.testing.assert_array_equal(T.toarray(), expected)
    assert T.nnz == S * 4  # no explicit zeros stored


def test_stop_model_puts_failure_on_current_state(boyd2):
    probs = dict.fromkeys(FEATURES, 0.5)
    T = as_dense(transition_matrix(boyd2, probs, "stop"), boyd2.n_states)
    s = int(boyd2.state_index(5, 1, 3))
    assert T[s, 0, s] == pytest.approx(1 - 0.5**4)
    assert T[s, 0, int(boyd2.state_index(6, 1, 3))] == pytest.approx(0.5**4)
    assert T[s, 3, s] == pytest.approx(1.0)  # stop: success or failure, it stays


def test_unknown_error_model(boyd2):
    with pytest.raises(ValueError, match="teleport"):
        transition_matrix(boyd2, dict.fromkeys(FEATURES, 0.9), "teleport")
