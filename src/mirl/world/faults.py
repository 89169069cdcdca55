"""What "damaged" means: a part whose success probability lies below its healthy level by more
than a margin (docs/design.md, "Fault verdicts").

A scenario may set both in its optional ``[faults]`` table, e.g. for robots whose navigation
fails more often when healthy::

    [faults]
    healthy = { navigation = 0.9 }
    margin = 0.1

Without it, the healthy levels are :data:`HEALTHY_PROBABILITIES` (the success probabilities a
scenario's robots get by default; :data:`DEFAULT_HEALTHY` for a feature they do not name) and
the margin is :data:`DEFAULT_MARGIN`: a wheel is damaged below 0.80. The grid world's damaged
wheel (0.70) lies below that, a healthy one (0.95) well above it.

The same table says how a weak wheel shows in a robot's poses (:class:`DriftSpec`), for the
verdicts on robot data::

    [faults]
    drift = { per_gap = 0.25, spread = 0.3, tolerance = 0.02 }

Without ``per_gap`` the drift per unit of wheel gap is unknown (a half-normal prior of scale
``scale``); the physical world states its own, measured (``PhysicsConfig.drift_per_gap``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mirl.world import schema

__all__ = [
    "DamageDefinition",
    "DriftSpec",
    "DEFAULT_MARGIN",
    "DEFAULT_HEALTHY",
    "HEALTHY_PROBABILITIES",
    "WHEELS",
    "read_faults",
]

WHEELS = ("left_wheel", "right_wheel")
"""A differential drive's two wheels, as ξ names them: the features a robot's lateral drift
speaks of (a robot veers towards the weaker one) and those a motor's strength sets in the
physical world. A feature map without both has no drift term."""

HEALTHY_PROBABILITIES = {"left_wheel": 0.95, "right_wheel": 0.95, "navigation": 0.97, "floor": 0.99}
"""Each default transition feature's success probability on a healthy robot: what a scenario's
robots get for a feature they do not set, and the level damage is measured from."""

DEFAULT_MARGIN = 0.15
"""How far below its healthy level a part's success probability must be to count as damaged."""
DEFAULT_HEALTHY = 0.95
"""The healthy level of a feature :data:`HEALTHY_PROBABILITIES` does not name."""


@dataclass(frozen=True)
class DriftSpec:
    """How a weak wheel shows in a robot's lateral drift: offset ~ N(κ (p_right − p_left), se² +
    τ²), κ the drift (cells) of a unit gap between the wheels' success probabilities.

    Parameters
    ----------
    per_gap : float or None, default None
        The κ where it is known (measured for the robots and their controller): κ ~ N(per_gap,
        (spread · per_gap)²). None: κ is unknown, with a half-normal prior of scale ``scale``.
    spread : float, default 0.3
        The κ's relative standard deviation when ``per_gap`` is given.
    scale : float, default 0.5
        The scale (cells) of κ's half-normal prior when ``per_gap`` is None: a wheel-probability
        gap of 1 drifts a robot by up to about half a cell — across a one-cell hallway to the
        wall.
    tolerance : float, default 0.02
        The τ (cells): how far from the centre line a healthy robot's mean path driving alone may
        lie beyond its standard error (localisation error, the controller's own bias).

    Raises
    ------
    ValueError
        A ``per_gap``, ``spread``, ``scale`` or ``tolerance`` that is not positive.
    """

    per_gap: float | None = None
    spread: float = 0.3
    scale: float = 0.5
    tolerance: float = 0.02

    def __post_init__(self) -> None:
        if self.per_gap is not None and not self.per_gap > 0:
            raise ValueError(f"`per_gap` must be positive, got {self.per_gap}")
        for name in ("spread", "scale", "tolerance"):
            if not getattr(self, name) > 0:
                raise ValueError(f"`{name}` must be positive, got {getattr(self, name)}")


@dataclass(frozen=True)
class DamageDefinition:
    """A part is damaged when its success probability is below ``healthy[part] - margin``.

    Parameters
    ----------
    healthy : mapping of str to float
        Each feature's success probability on a healthy robot; features not listed have
        :data:`DEFAULT_HEALTHY`.
    margin : float, default :data:`DEFAULT_MARGIN`
        How far below the healthy level damage starts, in (0, 1).
    drift : DriftSpec, default DriftSpec()
        How a weak wheel shows in the robot's lateral drift (robot data with poses).

    Raises
    ------
    ValueError
        A ``margin`` outside (0, 1) or a healthy level outside (0, 1].
    """

    healthy: Mapping[str, float] = field(default_factory=lambda: dict(HEALTHY_PROBABILITIES))
    margin: float = DEFAULT_MARGIN
    drift: DriftSpec = field(default_factory=DriftSpec)

    def __post_init__(self) -> None:
        if not 0.0 < self.margin < 1.0:
            raise ValueError(f"`margin` must be in (0, 1), got {self.margin}")
        for name, level in self.healthy.items():
            if not 0.0 < level <= 1.0:
                raise ValueError(f"`healthy` level of '{name}' must be in (0, 1], got {level}")

    def healthy_level(self, feature: str) -> float:
        """A part's success probability on a healthy robot.

        Parameters
        ----------
        feature : str
            A transition feature's name (``"left_wheel"``, say).

        Returns
        -------
        float
            Its level in ``healthy``, or :data:`DEFAULT_HEALTHY` if ``healthy`` does not name it.
        """
        return self.healthy.get(feature, DEFAULT_HEALTHY)

    def threshold(self, feature: str) -> float:
        """The success probability below which ``feature`` counts as damaged.

        Parameters
        ----------
        feature : str
            A transition feature's name (``"left_wheel"``, say).

        Returns
        -------
        float
            Its healthy level (:data:`DEFAULT_HEALTHY` if ``healthy`` does not name it) less
            ``margin``.
        """
        return self.healthy_level(feature) - self.margin

    def damaged(self, feature: str, probability: float) -> bool:
        """Whether a part with success ``probability`` is damaged.

        Parameters
        ----------
        feature : str
            The part's feature name.
        probability : float
            Its success probability.

        Returns
        -------
        bool
            True when ``probability`` lies strictly below :meth:`threshold` of ``feature``.
        """
        return probability < self.threshold(feature)

    def damaged_parts(self, probabilities: Mapping[str, float]) -> tuple[str, ...]:
        """The damaged features of a robot with these success probabilities, in their order.

        Parameters
        ----------
        probabilities : mapping of str to float
            Each feature's success probability.

        Returns
        -------
        tuple of str
            The features that are :meth:`damaged`, in the mapping's order (empty if none).
        """
        return tuple(f for f, p in probabilities.items() if self.damaged(f, p))


def read_faults(data: Any, features: tuple[str, ...]) -> DamageDefinition:
    """The ``[faults]`` table (``healthy`` levels per feature, ``margin``, ``drift``), checked.

    Parameters
    ----------
    data : dict
        The parsed ``[faults]`` table of a scenario file (``{}`` when the file has none).
    features : tuple of str
        The scenario's transition features: the names ``healthy`` may set, and those the
        returned definition gives a healthy level.

    Returns
    -------
    DamageDefinition
        The healthy level of every feature in ``features`` (the table's, else
        :data:`HEALTHY_PROBABILITIES`, else :data:`DEFAULT_HEALTHY`), the margin (else
        :data:`DEFAULT_MARGIN`) and the drift specification (else ``DriftSpec()``'s defaults).

    Raises
    ------
    mirl.world.schema.FieldError
        An unknown key or feature, a value that is not a number or lies out of range (levels
        and margin in [0, 1], drift fields positive and at most 10), or a combination
        :class:`DamageDefinition` refuses; the message names the field.
    """
    faults = schema.table(data, "faults", ("healthy", "margin", "drift"))
    default = DamageDefinition()
    healthy = {f: default.healthy.get(f, DEFAULT_HEALTHY) for f in features}
    for name, value in schema.table(faults.get("healthy", {}), "faults.healthy", features).items():
        healthy[name] = schema.number(value, f"faults.healthy.{name}", low=0.0, high=1.0)
    margin = schema.number(faults.get("margin", DEFAULT_MARGIN), "faults.margin", low=0.0, high=1.0)
    drift = schema.table(faults.get("drift", {}), "faults.drift", _DRIFT_FIELDS)
    spec = {
        name: schema.number(value, f"faults.drift.{name}", low=0.0, high=10.0)
        for name, value in drift.items()
    }
    for name, value in spec.items():
        if value <= 0:
            raise schema.FieldError(f"faults.drift.{name}", f"must be positive, got {value}")
    try:
        return DamageDefinition(healthy, margin, DriftSpec(**spec))
    except ValueError as exc:
        raise schema.FieldError("faults", str(exc)) from None


_DRIFT_FIELDS = ("per_gap", "spread", "scale", "tolerance")
