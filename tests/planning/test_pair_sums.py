"""The pair filter's sparse sums are the dense products they replace, bit for bit (a
faster re-planning must not move a single plan value)."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.results import oracle_models
from mirl.planning.belief import BeliefFilter
from mirl.planning.observer import observer_model
from mirl.planning.pair_sums import PairSightings
from mirl.sparse import csr_matmul
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def boyd2_filter():
    sc = load_scenario("boyd2")
    return sc, BeliefFilter(sc.domain, oracle_models(sc))


def _beliefs(S: int, n: int, seed: int) -> np.ndarray:
    """Joint beliefs with the spread of real ones: a few large entries, many tiny ones."""
    b = np.random.default_rng(seed).random((n, S * S)) ** 8
    return b / b.sum(axis=1, keepdims=True)


def test_propagation_is_the_dense_products_bit_for_bit(boyd2_filter):
    _, bf = boyd2_filter
    S = bf.n_states
    assert 0 < bf.form.meet.sum() < S * S / 10  # few meeting states: the sparse sum pays off
    for b in _beliefs(S, 20, 0):
        B = b.reshape(S, S)
        met = B * bf.form.meet  # the former computation, dense
        ref = csr_matmul(bf.form.step_T[1], csr_matmul(bf.form.step_T[0], B - met).T).T
        ref = ref + csr_matmul(bf.form.mixed_T[1], csr_matmul(bf.form.mixed_T[0], met).T).T
        out = bf.propagate(b)
        assert np.array_equal(out, ref.ravel())
        assert out.sum() == pytest.approx(1.0)


def test_pair_sightings_sum_in_the_products_order(boyd2_filter):
    sc, bf = boyd2_filter
    D = observer_model(sc).detection.toarray()
    S, C = D.shape
    sightings = PairSightings(D)
    for b in _beliefs(S, 5, 1):
        B = b.reshape(S, S)
        seq = np.zeros(C)  # Σ over s_I (ascending) of Σ over s_J (ascending), as (B @ D)·D
        for c in range(C):
            who = np.flatnonzero(D[:, c])
            for si in who:
                inner = 0.0
                for sj in who:
                    inner += B[si, sj]
                seq[c] += inner
        both = sightings.both(b)
        assert np.array_equal(both, seq)
        np.testing.assert_allclose(both, ((B @ D) * D).sum(axis=0), rtol=1e-12, atol=1e-300)
        assert both.max() > 0
