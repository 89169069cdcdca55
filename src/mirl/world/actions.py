"""The four actions every robot of the domain takes, by name and by index, and the number of
headings a state can have. Everything that acts on states (the domain, reward features, the
simulators, L's planner) reads them from here."""

from __future__ import annotations

__all__ = ["ACTIONS", "FORWARD", "TURN_LEFT", "TURN_RIGHT", "STOP", "N_HEADINGS", "STEP_SECONDS"]

ACTIONS: tuple[str, ...] = ("forward", "turn_left", "turn_right", "stop")
FORWARD, TURN_LEFT, TURN_RIGHT, STOP = range(4)
N_HEADINGS = 4  # east, north, west, south
STEP_SECONDS = 2.0
"""Robot time an action takes, one step of the record: the paper's 2 s."""
