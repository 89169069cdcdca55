"""What "damaged" means: a part whose success probability lies below its healthy level by more
than a margin (docs/design.md, "Fault verdicts").

A scenario may set both in its optional ``[faults]`` table::

    [faults]
    healthy = { left_wheel = 0.95, right_wheel = 0.95, navigation = 0.97, floor = 0.99 }
    margin = 0.15

Without it, the healthy levels are those a scenario's robots get by default
(:data:`~mirl.world.scenario_sections.HEALTHY_PROBABILITIES`; 0.95 for a feature those do not
name) and the margin is 0.15: a wheel is damaged below 0.80. The grid world's damaged wheel
(0.70) lies below that, a healthy one (0.95) well above it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mirl.world import schema
from mirl.world.scenario_sections import HEALTHY_PROBABILITIES

__all__ = ["DamageDefinition", "DEFAULT_MARGIN", "DEFAULT_HEALTHY", "read_faults"]

DEFAULT_MARGIN = 0.15
"""How far below its healthy level a part's success probability must be to count as damaged."""
DEFAULT_HEALTHY = 0.95
"""The healthy level of a feature :data:`HEALTHY_PROBABILITIES` does not name."""


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
    """

    healthy: Mapping[str, float] = field(default_factory=lambda: dict(HEALTHY_PROBABILITIES))
    margin: float = DEFAULT_MARGIN

    def __post_init__(self) -> None:
        if not 0.0 < self.margin < 1.0:
            raise ValueError(f"`margin` must be in (0, 1), got {self.margin}")
        for name, level in self.healthy.items():
            if not 0.0 < level <= 1.0:
                raise ValueError(f"`healthy` level of '{name}' must be in (0, 1], got {level}")

    def threshold(self, feature: str) -> float:
        """The success probability below which ``feature`` counts as damaged."""
        return self.healthy.get(feature, DEFAULT_HEALTHY) - self.margin

    def damaged(self, feature: str, probability: float) -> bool:
        """Whether a part with success ``probability`` is damaged."""
        return probability < self.threshold(feature)

    def damaged_parts(self, probabilities: Mapping[str, float]) -> tuple[str, ...]:
        """The damaged features of a robot with these success probabilities, in their order."""
        return tuple(f for f, p in probabilities.items() if self.damaged(f, p))


def read_faults(data: Any, features: tuple[str, ...]) -> DamageDefinition:
    """The ``[faults]`` table (``healthy`` levels per feature, ``margin``), checked."""
    faults = schema.table(data, "faults", ("healthy", "margin"))
    default = DamageDefinition()
    healthy = {f: default.healthy.get(f, DEFAULT_HEALTHY) for f in features}
    for name, value in schema.table(faults.get("healthy", {}), "faults.healthy", features).items():
        healthy[name] = schema.number(value, f"faults.healthy.{name}", low=0.0, high=1.0)
    margin = schema.number(faults.get("margin", DEFAULT_MARGIN), "faults.margin", low=0.0, high=1.0)
    try:
        return DamageDefinition(healthy, margin)
    except ValueError as exc:
        raise schema.FieldError("faults", str(exc)) from None
