"""mIRL*/T: transition functions from transition-feature probabilities (Eq. 5), counting of
observed successes per feature subset, and the estimator that learns feature probabilities
from occluded trajectories by maximum entropy (Eq. 4, solved in :mod:`mirl.feature_solver`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from mirl.domain import PatrolDomain

__all__ = ["ERROR_MODELS", "transition_matrix"]

ERROR_MODELS = ("uniform", "stop")


def transition_matrix(
    domain: PatrolDomain,
    feature_probabilities: Mapping[str, float],
    error_model: str = "uniform",
) -> sp.csr_array:
    """T(s, a, ·) as a CSR matrix of shape (S·A, S) (Eq. 5).

    ``uniform``: the failure mass 1 − Π p_τ is split equally over the intended states of the
    other |A| − 1 actions. ``stop``: it all goes to the current state (the robot stops and
    relocalises). Several actions may share an intended state (a forward into a wall stays put,
    like stop); their masses are summed, so every row sums to 1.
    """
    if error_model not in ERROR_MODELS:
        raise ValueError(f"unknown error model '{error_model}' (known: {', '.join(ERROR_MODELS)})")
    success = domain.success_probabilities(feature_probabilities)  # (S, A)
    S, A = success.shape
    psi = domain.intended
    rows = np.arange(S * A)
    if error_model == "uniform":
        # row (s, a) puts success on ψ(s, a) and (1 - success)/(A-1) on ψ(s, a') for a' != a
        other = np.ones((A, A), dtype=bool)
        np.fill_diagonal(other, False)
        a_idx, b_idx = np.nonzero(other)  # (a, a') pairs, a' != a
        fail = ((1.0 - success) / (A - 1))[:, a_idx]  # (S, A·(A-1))
        fail_rows = (np.arange(S)[:, None] * A + a_idx[None, :]).ravel()
        fail_cols = psi[:, b_idx].ravel()
        r = np.concatenate([rows, fail_rows])
        c = np.concatenate([psi.ravel(), fail_cols])
        v = np.concatenate([success.ravel(), fail.ravel()])
    else:
        stay = np.repeat(np.arange(S), A)
        r = np.concatenate([rows, rows])
        c = np.concatenate([psi.ravel(), stay])
        v = np.concatenate([success.ravel(), 1.0 - success.ravel()])
    keep = v > 0
    # COO → CSR sums duplicate (row, col) entries: coinciding intended states add up
    return sp.csr_array(sp.coo_array((v[keep], (r[keep], c[keep])), shape=(S * A, S)).tocsr())
