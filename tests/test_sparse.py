"""The sparse kernels: each gives bit for bit what scipy's public operators give (the same
products added in the same order), on random sparse matrices of every shape hypothesis finds."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from mirl.sparse import (
    csc_block_matvec,
    csr_block_matvec,
    csr_matmul,
    csr_scale_columns,
    linear_map,
)

shapes = st.tuples(st.integers(1, 12), st.integers(1, 12), st.integers(1, 4), st.integers(0, 999))


def _random(shape, seed, density=0.3):
    rng = np.random.default_rng(seed)
    A = sp.random_array(shape, density=density, rng=rng, format="csr")
    return sp.csr_array(A), rng


@settings(max_examples=60, deadline=None)
@given(shapes)
def test_csr_matmul_is_the_operator_bit_for_bit(shape):
    M, N, k, seed = shape
    A, rng = _random((M, N), seed)
    x, X = rng.standard_normal(N), rng.standard_normal((N, k))
    assert np.array_equal(csr_matmul(A, x), A @ x)
    assert np.array_equal(csr_matmul(A, X), A @ X)
    assert np.array_equal(csr_matmul(A, np.asfortranarray(X)), A @ X)  # any memory order


@settings(max_examples=60, deadline=None)
@given(shapes)
def test_block_matvecs_add_the_product_into_y(shape):
    """Into zeros, the product bit for bit (one column takes the one-vector kernel, several the
    block kernel: the same sums); into anything else, added to it."""
    M, N, k, seed = shape
    A, rng = _random((M, N), seed)
    X, Y0 = rng.standard_normal((N, k)), rng.standard_normal((M, k))
    y = np.zeros((M, k))
    csr_block_matvec(M, N, k, A.indptr, A.indices, A.data, X.ravel(), y.ravel())
    assert np.array_equal(y, A @ X)
    y = Y0.copy()
    csr_block_matvec(M, N, k, A.indptr, A.indices, A.data, X.ravel(), y.ravel())
    np.testing.assert_allclose(y, Y0 + A @ X, rtol=1e-12, atol=1e-12)
    # the same arrays read as CSC are the transpose
    z = np.zeros((N, k))
    csc_block_matvec(N, M, k, A.indptr, A.indices, A.data, Y0.ravel(), z.ravel())
    assert np.array_equal(z, sp.csc_array(A.T) @ Y0)


@settings(max_examples=60, deadline=None)
@given(shapes)
def test_scaling_columns_is_multiplying_by_a_diagonal(shape):
    M, N, _, seed = shape
    A, rng = _random((M, N), seed)
    x = rng.standard_normal(N)
    data = A.data.copy()
    csr_scale_columns(M, N, A.indptr, A.indices, data, x)
    scaled = sp.csr_array((data, A.indices, A.indptr), shape=A.shape)
    assert np.array_equal(scaled.toarray(), (A @ sp.diags_array(x)).toarray())


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.integers(1, 6), st.integers(1, 8), st.integers(0, 999))
def test_a_linear_map_sums_its_terms_in_the_order_given(n, n_keys, n_cols, seed):
    rng = np.random.default_rng(seed)
    keys = rng.integers(0, n_keys, n)
    within = rng.permutation(n)
    columns = rng.integers(0, n_cols, n)
    data = rng.standard_normal(n)
    x = rng.standard_normal(n_cols)
    uniq, (indptr, indices, coef) = linear_map(keys, within, columns, data, np.int32)
    assert np.array_equal(uniq, np.unique(keys))
    assert indptr.dtype == indices.dtype == np.int32
    y = np.zeros(len(uniq))
    csr_block_matvec(len(uniq), n_cols, 1, indptr, indices, coef, x, y)
    for r, key in enumerate(uniq):
        expected = 0.0
        for term in sorted(np.flatnonzero(keys == key), key=lambda t: within[t]):
            expected += data[term] * x[columns[term]]  # left to right, from 0
        assert y[r] == expected
