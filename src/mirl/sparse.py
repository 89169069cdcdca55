"""Sparse kernels shared by the solvers and filters: products with a CSR (or CSC) matrix given by
its arrays, and CSR maps that reproduce a sum in a known order.

Every product here calls scipy's compiled kernels (``scipy.sparse._sparsetools``, the loops
behind ``A @ x``) directly. They are private to scipy, and used anyway for speed: a filter or a
value-iteration sweep makes thousands of small products, and scipy's per-call dispatch (format
checks, allocating and upcasting the result) was measured to cost more than such a product
itself. Called directly they add the same products in the same order as ``A @ x``, so the
results are bit for bit those of the public operator (``tests/learning/test_fast_paths.py``).
This is the only module that imports them.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import _sparsetools

__all__ = [
    "csr_matmul",
    "csr_block_matvec",
    "csc_block_matvec",
    "csr_scale_columns",
    "linear_map",
]


def csr_matmul(A: sp.csr_array, X: np.ndarray) -> np.ndarray:
    """``A @ X`` for a CSR matrix and a dense vector or (n, k) matrix, by the same kernel as ``@``.

    Bit for bit the same as ``A @ X``, without scipy's per-call dispatch.

    Parameters
    ----------
    A : scipy.sparse.csr_array of shape (M, N)
        The sparse matrix.
    X : ndarray of shape (N,) or (N, k)
        The dense vector or matrix.

    Returns
    -------
    ndarray of shape (M,) or (M, k)
        The product, of the two inputs' result type.
    """
    M, N = A.shape
    if X.ndim == 1:
        out = np.zeros(M, dtype=np.result_type(A.dtype, X.dtype))
        _sparsetools.csr_matvec(M, N, A.indptr, A.indices, A.data, X, out)
        return out
    out = np.zeros((M, X.shape[1]), dtype=np.result_type(A.dtype, X.dtype))
    _sparsetools.csr_matvecs(
        M, N, X.shape[1], A.indptr, A.indices, A.data, np.ascontiguousarray(X).ravel(), out.ravel()
    )
    return out


def csr_block_matvec(n_row, n_col, width, indptr, indices, data, x, y) -> None:
    """y += A·x for a CSR array A given by its arrays, x and y row-major blocks passed flat.

    scipy's block kernel, or for one column its one-vector kernel, which keeps each row's sum in
    a register — 2.3× faster on the office's P_πᵀ (11 against 25 µs). Both add the same products in
    the same order into y, so they agree bit for bit.

    Parameters
    ----------
    n_row : int
        M, the rows of A.
    n_col : int
        N, the columns of A.
    width : int
        The columns k of the blocks x (N, k) and y (M, k).
    indptr : ndarray of shape (M+1,)
        A's row pointers.
    indices : ndarray
        A's column indices, of ``indptr``'s dtype.
    data : ndarray
        A's entries.
    x : ndarray of shape (N*k,)
        The block multiplied, flat and C-contiguous.
    y : ndarray of shape (M*k,)
        The block added into, in place.
    """
    if width == 1:
        _sparsetools.csr_matvec(n_row, n_col, indptr, indices, data, x, y)
    else:
        _sparsetools.csr_matvecs(n_row, n_col, width, indptr, indices, data, x, y)


def csc_block_matvec(n_row, n_col, width, indptr, indices, data, x, y) -> None:
    """:func:`csr_block_matvec` for a CSC array (e.g. a CSR one read transposed).

    One column takes scipy's one-vector kernel, 1.55× faster there (14 against 22 µs), bit for bit
    equal.

    Parameters
    ----------
    n_row : int
        M, the rows of A.
    n_col : int
        N, the columns of A.
    width : int
        The columns k of the blocks x (N, k) and y (M, k).
    indptr : ndarray of shape (N+1,)
        A's column pointers.
    indices : ndarray
        A's row indices, of ``indptr``'s dtype.
    data : ndarray
        A's entries.
    x : ndarray of shape (N*k,)
        The block multiplied, flat and C-contiguous.
    y : ndarray of shape (M*k,)
        The block added into, in place.
    """
    if width == 1:
        _sparsetools.csc_matvec(n_row, n_col, indptr, indices, data, x, y)
    else:
        _sparsetools.csc_matvecs(n_row, n_col, width, indptr, indices, data, x, y)


def csr_scale_columns(n_row, n_col, indptr, indices, data, x) -> None:
    """In place, ``data *= x[indices]``: a CSR array's entries scaled by their column's factor.

    Gathered and multiplied in one pass.

    Parameters
    ----------
    n_row : int
        M, the rows of the array.
    n_col : int
        N, its columns.
    indptr : ndarray of shape (M+1,)
        Its row pointers.
    indices : ndarray
        Its column indices.
    data : ndarray
        Its entries, scaled in place.
    x : ndarray of shape (N,)
        One factor per column.
    """
    _sparsetools.csr_scale_columns(n_row, n_col, indptr, indices, data, x)


def linear_map(
    keys, within, columns, data, dtype
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """A CSR map summing ``data[n]·x[columns[n]]`` into the output entry ``keys[n]``.

    Its rows are the distinct keys (ascending, returned first), each row's terms ordered by
    ``within``. The mat-vec kernel adds a row's terms in that order from 0, so the map reproduces
    any sum whose order is known (e.g. that of a sparse-sparse product, term by term).

    Parameters
    ----------
    keys : ndarray of int, shape (n,)
        The output entry each term adds into.
    within : ndarray of shape (n,)
        The order of the terms within an output entry.
    columns : ndarray of int, shape (n,)
        The input entry each term multiplies.
    data : ndarray of shape (n,)
        The terms' coefficients.
    dtype : numpy dtype
        The integer type of the map's indptr and indices.

    Returns
    -------
    keys : ndarray
        The distinct output entries, ascending: row r of the map sums into ``keys[r]``.
    arrays : tuple
        The map's (indptr, indices, data), of ``dtype`` indices.
    """
    order = np.lexsort((within, keys))
    keys = keys[order]
    uniq, start = np.unique(keys, return_index=True)
    indptr = np.append(start, len(keys)).astype(dtype)
    return uniq, (indptr, columns[order].astype(dtype), np.ascontiguousarray(data[order]))
