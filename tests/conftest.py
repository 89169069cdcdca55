"""The suite's order: its longest runs first.

``python -m pytest -n auto`` hands tests to its workers in collection order, and the matrix of
valid runs (``tests/suites/test_valid_runs.py``, about half the suite's CPU; an office run takes
20–45 s) is collected last, so one worker ran the office's runs alone while the other sat idle.
Collected first, they start at once, and ``--dist worksteal`` (``pyproject.toml``) moves the
short tests queued behind them to the worker that is free.
"""

from __future__ import annotations

import pytest

LONGEST_FIRST = ("tests/suites/test_valid_runs.py",)
"""Test files whose tests run first, in this order."""


def _rank(item: pytest.Item) -> tuple[int, int]:
    path = item.nodeid.split("::", 1)[0]
    if path not in LONGEST_FIRST:
        return (len(LONGEST_FIRST), 0)
    # the office's four patrollers and 3 804 states make its runs the longest of a file
    return (LONGEST_FIRST.index(path), 0 if "-office-" in item.nodeid else 1)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items.sort(key=_rank)  # stable: the rest keep their order
