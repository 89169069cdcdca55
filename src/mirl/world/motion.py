"""Eq. 5: a robot's transition function T(s, a, ·) from its transition-feature probabilities,
and the variants of motion an observer may take a robot to have.

This is the world's model of motion (the grid simulator runs it, the scenario solves the true
policies with it, and the learner fits its parameters), so it lives with the world. Two
questions stay open for a robot L watches, and the learner weighs both against its record
(:mod:`mirl.learning.motion_models`): where a failed step ends (:data:`ERROR_MODELS`: Eq. 5's
``uniform``, or ``stop``, where it started) and whether a turn needs a wheel
(:func:`turns_without_wheels`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from mirl.world.domain import FeatureMap, PatrolDomain
from mirl.world.faults import WHEELS

__all__ = [
    "ERROR_MODELS",
    "PIVOTS",
    "transition_matrix",
    "transition_matrix_from_success",
    "turns_without_wheels",
]

ERROR_MODELS = ("uniform", "stop")
"""Where the failure mass 1 − Π p_τ of a step goes: ``uniform`` (Eq. 5) to the intended states
of the other actions, ``stop`` to the state the robot started in."""

PIVOTS = ("turn_left", "turn_right")
"""The actions that turn a robot in place."""


def turns_without_wheels(feature_map: FeatureMap) -> FeatureMap:
    """ξ with the wheels taken out of the turns (overrides kept).

    A robot whose weak motor still pivots it in time: a turn tests no wheel, and a weak wheel
    shows only in forward steps, which need both. The paper's ξ has a damaged wheel fail the turns
    it drives; a physical robot's turn needs far less of a motor than a forward step (measured in
    the physical world: :func:`mirl.physics.config.physical_feature_map`), so charging the turns
    to a wheel would pin the wheel that drives the patrol's many left turns near 1 and blame the
    other one for every forward failure. The learner weighs both ξ against a robot's record
    (docs/design.md, "Fault verdicts").

    Parameters
    ----------
    feature_map : FeatureMap
        The scenario's ξ.

    Returns
    -------
    FeatureMap
        The same features, no wheel in ``turn_left`` or ``turn_right``.
    """
    wheels = [w for w in WHEELS if w in feature_map.features]
    return feature_map.without(wheels, PIVOTS)


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
