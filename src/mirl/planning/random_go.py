"""The random baseline of SPEC §5: L ignores what it saw, waits the observation phase, draws a go
time uniformly in [0, window] and follows a shortest path to its goal."""

from __future__ import annotations

import numpy as np

__all__ = ["random_go"]


def random_go(rng: np.random.Generator, window: int) -> int:
    """The random baseline's go time: uniform over 0 … window steps after observing."""
    return int(rng.integers(0, window + 1))
