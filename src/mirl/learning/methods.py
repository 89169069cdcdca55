"""The table of methods: every way L can come by models of the patrollers, in one place.

Each row says what a method is called on the command line and in the paper, where each part of
its models comes from, and so which options apply to it. :func:`mirl.learning.learn.learn`
builds a method's models from its row; the command line takes its choices, help and flag rules
from it; the run records and reports take the paper's names from it. Adding a method is a row
here plus, if it needs a source of models no row uses yet, that source in
:mod:`mirl.learning.learn`.

The module imports nothing heavy, so the command line can build its parser from it cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["Method", "METHODS", "get_method", "LEARNING_METHODS"]

RewardSource = Literal["learned", "true", "none"]
TransitionSource = Literal["features", "fixed-p", "em", "true", "none"]


@dataclass(frozen=True)
class Method:
    """One row of the table.

    Parameters
    ----------
    name : str
        The name :func:`~mirl.learning.learn.learn`, ``run_episode`` and ``--method`` take.
    paper_name : str
        The method's name in the paper's figures.
    description : str
        What it does, in a sentence (reports and ``--help``).
    reward : {"learned", "true", "none"}
        Where the patrollers' rewards and their interaction equilibrium come from: occluded
        max-ent IRL and the weighing of equilibria, the scenario's truth, or nowhere.
    transitions : {"features", "fixed-p", "em", "true", "none"}
        Where each patroller's transition model comes from: mIRL*/T's feature probabilities,
        one success probability ``p`` for every action, tabular EM over a two-slice DBN, the
        truth, or nowhere.
    relabels : bool
        Whether the observed steps are relabelled with the learned policies until the labels
        settle (mIRL*/T+Int's rounds).
    plans : bool
        Whether L plans its go time on the learned models; the random baseline does not.
    """

    name: str
    paper_name: str
    description: str
    reward: RewardSource
    transitions: TransitionSource
    relabels: bool = False
    plans: bool = True

    @property
    def uses_p(self) -> bool:
        """Whether the fixed success probability ``p`` applies."""
        return self.transitions == "fixed-p"

    @property
    def uses_em_init(self) -> bool:
        """Whether DBN-EM's initial transition model (``em_init``) applies."""
        return self.transitions == "em"

    @property
    def learns(self) -> bool:
        """Whether the method needs L's observations (the oracle and random do not)."""
        return self.transitions not in ("true", "none")

    @property
    def has_feature_probabilities(self) -> bool:
        """Whether its models carry per-feature success probabilities."""
        return self.transitions in ("features", "true")


_ROWS = (
    Method(
        "mirl-t", "mIRL*/T+Int",
        "learns each patroller's transition-feature probabilities (mIRL*/T), its reward by IRL "
        "under occlusion and their interaction, relabelling observed steps until they settle",
        reward="learned", transitions="features", relabels=True,
    ),
    Method(
        "mirl", "mIRL*+Int",
        "learns rewards and interaction; every action succeeds with a fixed p",
        reward="learned", transitions="fixed-p",
    ),
    Method(
        "known-r-t", "Known R/T",
        "true rewards and interaction, learned transitions (upper bound)",
        reward="true", transitions="features",
    ),
    Method(
        "known-r", "Known R",
        "true rewards and interaction, fixed success p",
        reward="true", transitions="fixed-p",
    ),
    Method(
        "dbn-em", "DBN-EM",
        "transitions learned by EM over a two-slice DBN, learned rewards",
        reward="learned", transitions="em",
    ),
    Method(
        "random", "Random",
        "waits, then goes at a random time along a shortest path",
        reward="none", transitions="none", plans=False,
    ),
    Method(
        "oracle", "Oracle",
        "the true models (a ceiling; not in the paper)",
        reward="true", transitions="true",
    ),
)  # fmt: skip

METHODS: dict[str, Method] = {m.name: m for m in _ROWS}
"""Every method by name, in the order of the paper's figures (the oracle last)."""

LEARNING_METHODS: tuple[str, ...] = tuple(n for n, m in METHODS.items() if m.plans)
"""The methods :func:`~mirl.learning.learn.learn` accepts: those with models to build."""


def get_method(name: str, known: tuple[str, ...] = tuple(METHODS)) -> Method:
    """The row of method ``name``; a ValueError naming the known ones otherwise.

    Parameters
    ----------
    name : str
        A method's name.
    known : tuple of str, default all methods
        The names acceptable where the method is asked for.
    """
    if name not in known:
        raise ValueError(f"unknown method '{name}' (known: {', '.join(known)})")
    return METHODS[name]
