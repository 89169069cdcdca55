"""The stated chance's held-out calibration: a logistic map, one per method and run protocol,
from the posterior-averaged chance L computes to the chance it states, fitted on runs whose seeds
are not the ones reported (docs/design.md, "The stated chance").

Averaging the chance over a posterior of L's models removes most of the selection effect of
going when the point models' error favours going, but not all of it, and not the same part for
every method: a method whose motion model is fixed (mIRL\\*+Int's p) or whose models are far
from the truth (DBN-EM) has a posterior that is too narrow, so its chance is too confident where
L goes; mIRL\\*/T+Int at 0.14 has one that is too wide. What is left is measured on held-out
runs and corrected by Platt scaling (Platt, 1999) with the two quantities that move it:

    stated = σ(a + b · logit(averaged) + c · width + d · view)

where ``averaged`` is the posterior-averaged chance, ``width`` the spread of the per-draw
chances (their 5–95 % interval) and ``view`` the fraction of the patrollers' states L sees. The
map is monotone in ``averaged`` (b > 0 is required of a fit), so it changes what L says, never
when it goes. A method without a fitted map states its averaged chance, and says so.

The selection left differs with the protocol: ``mirl run`` watches until it has seen every
patroller (its average understates), the experiments observe a fixed 300 steps (their average
overstates). A map holds only under the protocol it was fitted under, so the file keeps one set
per protocol, each with the options that name it (:class:`CalibratedProtocol`); a run under any
other protocol states its averaged chance. So does a run in a world the maps were not fitted in:
a map corrects the bias of the runs it saw, and a method whose motion model is fixed
(mIRL\\*+Int's p) is biased by how wrong that p is for the world's robots, which the map's
inputs do not see (carried to the physical world, mIRL\\*+Int's grid map stated 0.51 where 0.97
came true).

The coefficients are fitted by penalised maximum likelihood (:func:`fit_calibration`), a
Gaussian prior centred on the identity map (a = c = d = 0, b = 1); scikit-learn's
``LogisticRegression`` penalises towards zero, not towards the identity, so the fit is the few
lines below on :func:`scipy.optimize.minimize`. How strongly the prior holds is chosen by how
well maps fitted on some seed ranges predict another's outcomes (:func:`choose_prior_precision`,
leave one range out): a map must carry the method's bias, not one range's luck.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit, logit

__all__ = [
    "ChanceMap",
    "CalibratedProtocol",
    "CALIBRATION_FILE",
    "MIRL_RUN",
    "FIXED_OBSERVATION",
    "calibration_protocols",
    "fit_calibration",
    "PRECISIONS",
    "choose_prior_precision",
    "calibration_maps",
    "calibrate_chance",
    "maps_to_json",
]

CALIBRATION_FILE = "stated_chance_calibration.json"
"""The fitted maps, in ``mirl/data`` (written by ``benchmarks/fit_chance_calibration.py``)."""

MIRL_RUN = "mirl-run"
"""The maps fitted under ``mirl run``'s protocol (watching until every patroller was seen)."""

FIXED_OBSERVATION = "fixed-observation"
"""The maps fitted under the experiments' default protocol: exactly 300 observed steps (Fig. 4a,
Table 1)."""

_CLIP = 1e-3  # logit's argument is clipped to [_CLIP, 1 − _CLIP]: a chance of exactly 0 or 1


@dataclass(frozen=True)
class ChanceMap:
    """One method's calibration map (module docstring).

    Parameters
    ----------
    intercept : float
        The map's a.
    slope : float
        Its b, the weight of the averaged chance's logit; positive.
    width : float
        Its c, the weight of the draws' spread.
    view : float
        Its d, the weight of the fraction of states L sees.
    runs : int
        The held-out runs it was fitted on (where L went).
    fitted_on : str
        Which runs, in words (scenario, world, views, seeds).
    """

    intercept: float
    slope: float
    width: float
    view: float
    runs: int
    fitted_on: str

    def __post_init__(self) -> None:
        if not self.slope > 0:
            raise ValueError(f"a calibration map's slope must be positive, got {self.slope}")

    def __call__(self, chance, width, view) -> np.ndarray:
        """The stated chance for averaged chance(s) ``chance``.

        Parameters
        ----------
        chance : float or ndarray
            The posterior-averaged chance(s), in [0, 1].
        width : float or ndarray
            The per-draw chances' 5–95 % spread.
        view : float or ndarray
            The fraction of the patrollers' states L sees.

        Returns
        -------
        ndarray
            The calibrated chance(s), in (0, 1).
        """
        z = _logit(chance)
        return expit(self.intercept + self.slope * z + self.width * np.asarray(width)
                     + self.view * np.asarray(view))  # fmt: skip


    def unmapped_interval(
        self, stated: float, interval: tuple[float, float], averaged: float, view: float
    ) -> tuple[float, float]:
        """The interval a statement had before this map: the map's inverse at the width and
        view the statement was mapped with (its ``c · width`` read off the stated chance and its
        average, so no division by ``c``).

        Parameters
        ----------
        stated : float
            The stated (mapped) chance.
        interval : tuple of (float, float)
            The stated (mapped) interval.
        averaged : float
            The average the chance was mapped from.
        view : float
            The fraction of states L saw.

        Returns
        -------
        tuple of (float, float)
            The per-draw chances' quantiles before the map (exact up to the clipping of a chance
            to [0.001, 0.999] before its logit).
        """
        spread = float(_logit(stated) - self.intercept - self.slope * _logit(averaged)
                       - self.view * view)  # c · width  # fmt: skip
        lo, hi = expit((_logit(np.asarray(interval)) - self.intercept - spread - self.view * view)
                       / self.slope)  # fmt: skip
        return float(lo), float(hi)


def _logit(chance) -> np.ndarray:
    """logit of a chance clipped to [_CLIP, 1 − _CLIP] (a chance of exactly 0 or 1 is finite)."""
    return logit(np.clip(chance, _CLIP, 1 - _CLIP))


def _design(chance, width, view) -> np.ndarray:
    """The map's inputs, one row per run: 1, logit(chance) (clipped), width, view."""
    chance = np.asarray(chance, dtype=float)
    return np.column_stack([
        np.ones_like(chance), _logit(chance),
        np.broadcast_to(width, chance.shape), np.broadcast_to(view, chance.shape),
    ])  # fmt: skip


def fit_calibration(
    chance, width, view, success, *, prior_precision: float = 1.0, fitted_on: str = ""
) -> ChanceMap:
    """Fit a method's calibration map to held-out runs by penalised maximum likelihood.

    Parameters
    ----------
    chance : array_like of shape (n,)
        The posterior-averaged chance of each run where L went.
    width : array_like of shape (n,)
        Its per-draw chances' 5–95 % spread.
    view : array_like of shape (n,)
        The fraction of the patrollers' states L saw in that run.
    success : array_like of shape (n,) of bool
        Whether the run succeeded.
    prior_precision : float, default 1.0
        The Gaussian prior's precision on (a, b − 1, c, d): the identity map is worth this many
        runs' curvature, little against hundreds.
    fitted_on : str, default ""
        Which runs, in words.

    Returns
    -------
    ChanceMap
        The fitted map.

    Raises
    ------
    ValueError
        Fewer than 20 runs, lengths that differ, or a fit whose slope is not positive.
    """
    X = _design(chance, width, view)
    y = np.asarray(success, dtype=float)
    if len(y) != len(X):
        raise ValueError(f"{len(X)} chances but {len(y)} outcomes")
    if len(y) < 20:
        raise ValueError(f"a calibration map needs at least 20 runs, got {len(y)}")
    centre = np.array([0.0, 1.0, 0.0, 0.0])

    def loss(theta: np.ndarray) -> tuple[float, np.ndarray]:
        z = X @ theta
        gap = theta - centre
        value = np.sum(np.logaddexp(0.0, z) - y * z) + 0.5 * prior_precision * gap @ gap
        return float(value), X.T @ (expit(z) - y) + prior_precision * gap

    theta = minimize(loss, centre, jac=True, method="L-BFGS-B").x
    a, b, c, d = map(float, theta)
    return ChanceMap(a, b, c, d, runs=len(y), fitted_on=fitted_on)


PRECISIONS = (1.0, 10.0, 100.0, 1000.0, 10000.0)
"""The prior precisions :func:`choose_prior_precision` weighs: from a map the runs set almost
alone (1: the identity is worth a run's curvature) to one held near the identity
(10 000: worth far more runs than any fit has)."""


def choose_prior_precision(
    chance, width, view, success, groups, *, precisions=PRECISIONS
) -> tuple[float, dict[float, float]]:
    """How strongly a map is held near the identity, chosen by how well maps fitted on some
    seed ranges predict the outcomes of another (leave one range out).

    A map fitted on one range of a few hundred runs carries that range's luck as well as the
    method's bias; the precision at which maps carry from range to range best is the one whose
    map is the method's bias, as far as the ranges show it. The loss is the held-out log loss
    summed over the ranges left out; a tie goes to the larger precision (the map nearer the
    identity).

    Parameters
    ----------
    chance, width, view, success : array_like of shape (n,)
        As for :func:`fit_calibration`.
    groups : array_like of shape (n,)
        Each run's seed range (any hashable label); at least two distinct.
    precisions : sequence of float, default :data:`PRECISIONS`
        The candidates.

    Returns
    -------
    precision : float
        The chosen precision.
    losses : dict of float to float
        Each candidate's held-out log loss per run.

    Raises
    ------
    ValueError
        Fewer than two seed ranges, or lengths that differ.
    """
    chance = np.asarray(chance, dtype=float)
    width = np.broadcast_to(np.asarray(width, dtype=float), chance.shape)
    view = np.broadcast_to(np.asarray(view, dtype=float), chance.shape)
    y = np.asarray(success, dtype=bool)
    groups = np.asarray(groups)
    if not len(y) == len(groups) == len(chance):
        raise ValueError(f"{len(chance)} chances, {len(y)} outcomes and {len(groups)} groups")
    labels = np.unique(groups)
    if len(labels) < 2:
        raise ValueError("choosing the precision needs runs from at least two seed ranges")
    losses = {}
    for precision in precisions:
        total = 0.0
        for g in labels:
            out = groups == g
            m = fit_calibration(
                chance[~out], width[~out], view[~out], y[~out], prior_precision=precision
            )
            q = np.clip(m(chance[out], width[out], view[out]), 1e-12, 1 - 1e-12)
            total -= float(np.sum(np.where(y[out], np.log(q), np.log1p(-q))))
        losses[float(precision)] = total / len(y)
    best = min(losses.values())
    chosen = max(p for p, v in losses.items() if v <= best + 1e-12)
    return chosen, losses


@dataclass(frozen=True)
class CalibratedProtocol:
    """The maps fitted under one run protocol.

    Parameters
    ----------
    options : mapping of str to object
        The protocol's options that differ from ``mirl run``'s (``RunProtocol(**options)``;
        empty for ``mirl run``'s own).
    maps : mapping of str to ChanceMap
        One map per method fitted under it.
    how : str
        The command that fitted them.
    worlds : tuple of str
        The worlds whose runs they were fitted on; a run in another world states its average.
    scenarios : tuple of str
        The scenarios (by name) whose runs they were fitted on; a run of another scenario
        states its average: what a map corrects depends on the floor plan and the patrols
        (docs/design.md, "Where the maps apply").
    """

    options: Mapping[str, Any]
    maps: Mapping[str, ChanceMap]
    how: str
    worlds: tuple[str, ...]
    scenarios: tuple[str, ...]

    def applies(self, world: str, scenario: str) -> bool:
        """Whether these maps state the chance of a run of ``scenario`` in ``world``.

        Parameters
        ----------
        world : str
            The run's world.
        scenario : str
            The run's scenario's name.

        Returns
        -------
        bool
            True when both are among those the maps were fitted on.
        """
        return world in self.worlds and scenario in self.scenarios


@lru_cache(maxsize=1)
def calibration_protocols() -> Mapping[str, CalibratedProtocol]:
    """The shipped maps (:data:`CALIBRATION_FILE`), by the name of the protocol they were fitted
    under.

    Returns
    -------
    mapping of str to CalibratedProtocol
        :data:`MIRL_RUN` (``mirl run``'s protocol) and :data:`FIXED_OBSERVATION` (a fixed 300
        observed steps, the experiments' protocol).
    """
    text = (resources.files("mirl") / "data" / CALIBRATION_FILE).read_text(encoding="utf-8")
    return {
        name: CalibratedProtocol(
            options=entry["options"],
            maps={m: ChanceMap(**fields) for m, fields in entry["methods"].items()},
            how=entry["how"],
            worlds=tuple(entry["worlds"]),
            scenarios=tuple(entry["scenarios"]),
        )
        for name, entry in json.loads(text)["protocols"].items()
    }


def calibration_maps(protocol: str = MIRL_RUN) -> Mapping[str, ChanceMap]:
    """The shipped maps of one protocol, by method name.

    Parameters
    ----------
    protocol : str, default MIRL_RUN
        The protocol's name (:func:`calibration_protocols`).

    Returns
    -------
    mapping of str to ChanceMap
        One per method fitted; a method absent states its averaged chance.

    Raises
    ------
    ValueError
        No maps were fitted under a protocol of that name.
    """
    protocols = calibration_protocols()
    if protocol not in protocols:
        raise ValueError(
            f"no stated-chance calibration for protocol {protocol!r}; known: {sorted(protocols)}"
        )
    return protocols[protocol].maps


def calibrate_chance(
    method: str,
    chance: float,
    interval: tuple[float, float],
    view: float,
    protocol: str = MIRL_RUN,
) -> tuple[float, tuple[float, float]] | None:
    """The chance and interval ``method`` states, mapped by its calibration.

    Parameters
    ----------
    method : str
        The method that learned L's models.
    chance : float
        The posterior-averaged chance.
    interval : tuple of (float, float)
        The per-draw chances' 5–95 % quantiles (mapped with the same width and view, so the
        stated chance stays inside its interval).
    view : float
        The fraction of the patrollers' states L sees.
    protocol : str, default MIRL_RUN
        The run protocol whose maps apply (:func:`calibration_protocols`).

    Returns
    -------
    (float, (float, float)) or None
        The stated chance and interval; None when the method has no map under that protocol.
    """
    m = calibration_maps(protocol).get(method)
    if m is None:
        return None
    width = interval[1] - interval[0]
    lo, mid, hi = m(np.array([interval[0], chance, interval[1]]), width, view)
    return float(mid), (float(lo), float(hi))


def maps_to_json(protocols: Mapping[str, CalibratedProtocol]) -> str:
    """The JSON text of :data:`CALIBRATION_FILE` for ``protocols``.

    Parameters
    ----------
    protocols : mapping of str to CalibratedProtocol
        The fitted maps by protocol name.

    Returns
    -------
    str
        The file's text.
    """
    return json.dumps({"protocols": {
        name: {
            "options": dict(p.options),
            "worlds": list(p.worlds),
            "scenarios": list(p.scenarios),
            "how": p.how,
            "methods": {k: asdict(v) for k, v in sorted(p.maps.items())},
        }
        for name, p in sorted(protocols.items())
    }}, indent=2) + "\n"  # fmt: skip
