"""Eq. 5: a robot's transition function T(s, a, ·) from its transition-feature probabilities.

This is the world's model of motion (the grid simulator runs it, the scenario solves the true
policies with it, and the learner fits its parameters), so it lives with the world.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from mirl.world.domain import PatrolDomain

__all__ = ["ERROR_MODELS", "transition_matrix", "transition_matrix_from_success"]

ERROR_MODELS = ("uniform", "stop")


def transition_matrix(
    domain: PatrolDomain,
    feature_probabilities: Mapping[str, float],
    error_model: str = "uniform",
) -> sp.csr_array:
    """T(s, a, ·) from transition-feature probabilities (Eq. 2 and Eq. 5), shape (S·A, S).

    Parameters
    ----------
    domain : PatrolDomain
        The domain: its states, intended outcomes ψ and features ξ.
    feature_probabilities : mapping of str to float
        A probability in [0, 1] for every transition feature.
    error_model : {"uniform", "stop"}, default "uniform"
        Where a failed step goes (see :func:`transition_matrix_from_success`).

    Returns
    -------
    scipy.sparse.csr_array of shape (S*A, S)
        T, every row summing to 1.

    Raises
    ------
    ValueError
        An unknown or missing feature, a probability outside [0, 1], or an unknown error model.
    """
    success = domain.success_probabilities(feature_probabilities)
    return transition_matrix_from_success(domain, success, error_model)


def transition_matrix_from_success(
    domain: PatrolDomain, success: np.ndarray | float, error_model: str = "uniform"
) -> sp.csr_array:
    """T(s, a, ·) as a CSR matrix of shape (S·A, S) from success probabilities T(s, a, ψ(s, a)).

    ``uniform``: the failure mass 1 − Π p_τ is split equally over the intended states of the
    other |A| − 1 actions (Eq. 5). ``stop``: it all goes to the current state (the robot stops
    and relocalises). Several actions may share an intended state (a forward into a wall stays
    put, like stop); their masses are summed, so every row sums to 1.

    Parameters
    ----------
    domain : PatrolDomain
        The domain: its states and intended outcomes ψ.
    success : ndarray of shape (S, A), or float
        The probability that (s, a) reaches ψ(s, a); one number for the fixed-p baselines.
    error_model : {"uniform", "stop"}, default "uniform"
        Where the failure mass goes.

    Returns
    -------
    scipy.sparse.csr_array of shape (S*A, S)
        T, every row summing to 1.

    Raises
    ------
    ValueError
        An unknown error model, or a probability outside [0, 1].
    """
    if error_model not in ERROR_MODELS:
        raise ValueError(f"unknown error model '{error_model}' (known: {', '.join(ERROR_MODELS)})")
    success = np.broadcast_to(np.asarray(success, dtype=float), (domain.n_states, domain.n_actions))
    if np.any(~np.isfinite(success)) or np.any((success < 0) | (success > 1)):
        raise ValueError("success probabilities must be in [0, 1]")
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
