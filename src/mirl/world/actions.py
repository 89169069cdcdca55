"""The four actions every robot of the domain takes, by name and by index, and the number of
headings a state can have. Everything that acts on states (the domain, reward features, the
simulators, L's planner) reads them from here."""

from __future__ import annotations

__all__ = [
    "ACTIONS",
    "FORWARD",
    "TURN_LEFT",
    "TURN_RIGHT",
    "STOP",
    "HEADING_NAMES",
    "N_HEADINGS",
    "STEP_SECONDS",
]

ACTIONS: tuple[str, ...] = ("forward", "turn_left", "turn_right", "stop")
FORWARD, TURN_LEFT, TURN_RIGHT, STOP = range(4)
HEADING_NAMES: tuple[str, ...] = ("east", "north", "west", "south")
"""Heading 0-3 in words: the map's x points east, its y north."""
N_HEADINGS = len(HEADING_NAMES)
STEP_SECONDS = 2.0
"""Robot time an action takes, one step of the record: the paper's 2 s."""
