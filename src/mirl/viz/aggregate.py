"""Stored runs grouped by condition (rates, means, standard errors), and the paper's numbers and
method names they are compared with."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mirl.experiments.conditions import Condition
from mirl.learning.methods import METHODS

__all__ = ["PAPER", "method_name"]


Row = dict[str, Any]  # one stored run, as read from the store

PAPER_NAMES = {name: m.paper_name for name, m in METHODS.items()}

# What the paper reports (Bogert & Doshi, Sec. 4), as text beside each of our results.
PAPER = {
    "fig3": "Accuracy of mIRL*/T+Int rises with observability and with observing time; Known R/T "
    "is an upper bound. Accuracy correlates almost linearly with success, which reaches up to "
    "**0.60** for mIRL*/T+Int. 200 simulated runs per point.",
    "fig4a": "mIRL*/T+Int succeeds more often than mIRL*+Int with an arbitrary fixed success "
    "probability and equally often at p = 0.9; the gap is larger between Known R/T and Known R. "
    "DBN-EM is below Random and **100%** timed out under occlusion (about 90% without); the "
    "timed-out rate of every other method is **under 4%**.",
    "fig4b": "J's learned feature probabilities are all below I's; J's left wheel is "
    "significantly below its right wheel (two-tailed t-test, **p ≪ 0.001**), whose probability "
    "matches a working wheel; the damage also lowers J's navigation.",
    "fig4c": "With no damaged wheel the learned probabilities of I and J coincide, with small "
    "errors, close to those of Known R/T.",
    "table1": "10 physical runs per cell at about 14% observability.",
    "verdicts": "Not in the paper, which reports J's left wheel below its right "
    "(two-tailed t-test over runs, **p ≪ 0.001**) but no verdict of a single run.",
}
TABLE1_PAPER = {
    ("mirl-t", "boyd2"): 0.60,
    ("mirl-t", "boyd2-healthy"): 0.50,
    ("mirl", "boyd2"): 0.50,
    ("mirl", "boyd2-healthy"): 0.40,
    ("random", "boyd2"): 0.40,
    ("random", "boyd2-healthy"): 0.20,
}
FIG4A_PAPER = {
    "oracle": "not in the paper (true T and R: the real ceiling)",
    "known-r-t": "upper bound, above Known R",
    "mirl-t": "≥ every fixed-p mIRL*+Int; up to 0.60",
    "known-r": "below Known R/T",
    "mirl": "below mIRL*/T+Int, equal at p = 0.9",
    "dbn-em": "below Random; timed out 100% (d < 1), ~90% (d = 1)",
    "random": "above DBN-EM",
}


def method_name(c: Condition) -> str:
    """A condition's method as the paper names it, with its fixed p or EM initialisation.

    Parameters
    ----------
    c : Condition
        The condition.

    Returns
    -------
    str
        E.g. ``mIRL*+Int (p=0.9)``.
    """
    name = PAPER_NAMES.get(c.method, c.method)
    name = name if c.p is None else f"{name} (p={c.p:g})"
    return name if c.em_init is None else f"{name} ({c.em_init} init)"


# ---------------------------------------------------------------------------------------------
# Aggregation


@dataclass
class Group:
    """The finished (non-error) runs of one condition."""

    condition: Condition
    rows: list[Row]

    @property
    def n(self) -> int:
        return len(self.rows)

    def rate(self, outcome: str) -> float:
        return sum(r["outcome"] == outcome for r in self.rows) / self.n if self.n else float("nan")

    def rate_se(self, outcome: str) -> float:
        p = self.rate(outcome)
        return float(np.sqrt(p * (1 - p) / self.n)) if self.n else float("nan")

    def values(self, column: str) -> np.ndarray:
        v = [r.get(column) for r in self.rows]
        return np.array([float(x) for x in v if x is not None and x == x], dtype=float)

    def mean_std(self, column: str) -> tuple[float, float]:
        v = self.values(column)
        if not len(v):
            return float("nan"), float("nan")
        return float(v.mean()), float(v.std(ddof=1)) if len(v) > 1 else 0.0


def groups(rows: Sequence[Row]) -> list[Group]:
    """Non-error runs grouped by condition, in first-seen order."""
    out: dict[str, Group] = {}
    for r in rows:
        if r["outcome"] == "error":
            continue
        key = r["condition_key"]
        if key not in out:
            out[key] = Group(Condition.from_key(key), [])
        out[key].rows.append(r)
    return list(out.values())
