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

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

from mirl._registry import Registry

__all__ = [
    "Method",
    "METHODS",
    "get_method",
    "LEARNING_METHODS",
    "ModelSource",
    "REWARD_SOURCES",
    "TRANSITION_SOURCES",
    "PART_OPTIONS",
    "ruled_options",
    "unread_option",
]

RewardSource = Literal["learned", "true", "none"]
TransitionSource = Literal["features", "fixed-p", "em", "true", "none"]


@dataclass(frozen=True)
class ModelSource:
    """Where one part of a method's models (its reward, or its transition model) comes from.

    Parameters
    ----------
    name : str
        The value a :class:`Method` row names it by.
    description : str
        What it is, in a few words.
    built : bool
        Whether :func:`~mirl.learning.learn.learn` builds it (from L's observations, or from
        an option such as ``p``) rather than taking it as given: the scenario's truth, or
        nothing.
    feature_probabilities : bool, default False
        Whether the models it gives carry per-feature success probabilities (a transition
        model made of ξ's features).
    options : tuple of str, default ()
        The options of :func:`~mirl.learning.learn.learn` it alone reads (``("p",)`` for a fixed
        T, the IRL's for a learned reward), refused for a method without it
        (:func:`unread_option`).
    """

    name: str
    description: str
    built: bool
    feature_probabilities: bool = False
    options: tuple[str, ...] = ()


REWARD_SOURCES: Registry[ModelSource] = Registry(
    "reward source",
    (
        ModelSource(
            "learned", "occluded max-ent IRL and the weighing of equilibria", True,
            options=("objective", "optimizer", "n_restarts", "irl_options"),
        ),
        ModelSource("true", "the scenario's true rewards and played equilibrium", False),
        ModelSource("none", "no reward: the method does not plan", False),
    ),
)  # fmt: skip
"""Where a method's rewards and equilibrium come from (a :class:`Method`'s ``reward``)."""

TRANSITION_SOURCES: Registry[ModelSource] = Registry(
    "transition source",
    (
        ModelSource("features", "mIRL*/T's transition-feature probabilities", True, True),
        ModelSource("fixed-p", "one success probability p for every action", True, options=("p",)),
        ModelSource("em", "tabular EM over a two-slice DBN", True, options=("em_init",)),
        ModelSource("true", "the scenario's true transition model", False, True),
        ModelSource("none", "no transition model: the method does not plan", False),
    ),
)
"""Where a method's transition models come from (a :class:`Method`'s ``transitions``)."""


@dataclass(frozen=True)
class Method:
    """One row of the table. A row that could not run as written is refused where the table is
    defined (:func:`check_method`).

    Parameters
    ----------
    name : str
        The name :func:`~mirl.learning.learn.learn`, ``run_episode`` and ``--method`` take.
    paper_name : str
        The method's name in the paper's figures.
    description : str
        What it does, in a sentence (reports and ``--help``).
    reward : {"learned", "true", "none"}
        Where the patrollers' rewards and their interaction equilibrium come from
        (:data:`REWARD_SOURCES`): occluded max-ent IRL and the weighing of equilibria, the
        scenario's truth, or nowhere.
    transitions : {"features", "fixed-p", "em", "true", "none"}
        Where each patroller's transition model comes from (:data:`TRANSITION_SOURCES`):
        mIRL*/T's feature probabilities, one success probability ``p`` for every action,
        tabular EM over a two-slice DBN, the truth, or nowhere.
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
        return "p" in TRANSITION_SOURCES[self.transitions].options

    @property
    def uses_em_init(self) -> bool:
        """Whether DBN-EM's initial transition model (``em_init``) applies."""
        return "em_init" in TRANSITION_SOURCES[self.transitions].options

    @property
    def learns(self) -> bool:
        """Whether :func:`~mirl.learning.learn.learn` builds its models from L's observations
        (the oracle and random need none)."""
        return TRANSITION_SOURCES[self.transitions].built

    @property
    def has_feature_probabilities(self) -> bool:
        """Whether its models carry per-feature success probabilities."""
        return TRANSITION_SOURCES[self.transitions].feature_probabilities

    @property
    def labels_by_truth(self) -> bool:
        """Whether :func:`~mirl.learning.learn.learn` labels the observed steps with the
        scenario's true policies (Known R/T): a true reward whose T is learned from labelled
        steps. Those policies are optimal under the true T, so the scenario's true feature
        probabilities (``--damage``'s) change what it learns."""
        return self.reward == "true" and self.transitions == "features"


def check_method(row: Method) -> None:
    """Refuse a row that :func:`~mirl.learning.learn.learn` and ``run_episode`` could not run as
    it reads; each rule is what they do with a row:

    * its sources are rows of :data:`REWARD_SOURCES` and :data:`TRANSITION_SOURCES`;
    * a method that plans needs a reward and a transition model, and one that does not plan
      has neither (it would build models nothing uses);
    * the relabelling rounds learn the reward by IRL and T from the features, so a method that
      relabels has ``reward="learned", transitions="features"`` (anything else would run
      without the rounds);
    * the true transition model comes with the true reward: ``learn`` then returns the
      scenario's truth whole (:func:`~mirl.learning.results.oracle_models`), and any other
      reward would never be built.

    Raises
    ------
    ValueError
        One line naming the row and the rule it breaks.
    """
    where = f"method '{row.name}'"
    for part, table, value in (
        ("reward", REWARD_SOURCES, row.reward),
        ("transitions", TRANSITION_SOURCES, row.transitions),
    ):
        if value not in table:
            raise ValueError(f"{where}: {part}: {table.unknown(value)}")
    absent = [part for part in (row.reward, row.transitions) if part == "none"]
    if row.plans and absent:
        raise ValueError(f"{where}: a method that plans needs a reward and a transition model")
    if not row.plans and len(absent) < 2:
        raise ValueError(f"{where}: a method that does not plan has no models to build")
    if row.relabels and (row.reward, row.transitions) != ("learned", "features"):
        raise ValueError(
            f"{where}: relabelling learns the reward by IRL and T from the features "
            "(reward='learned', transitions='features')"
        )
    if row.transitions == "true" and row.reward != "true":
        raise ValueError(f"{where}: the true transition model comes with the true reward")


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

METHODS: Registry[Method] = Registry("method", _ROWS, check=check_method)
"""Every method by name, in the order of the paper's figures (the oracle last)."""

LEARNING_METHODS: tuple[str, ...] = tuple(n for n, m in METHODS.items() if m.plans)
"""The methods :func:`~mirl.learning.learn.learn` accepts: those with models to build."""

PART_OPTIONS: tuple[tuple[str, tuple[str, ...], str], ...] = (
    ("relabels", ("max_iterations", "label_tol"), "it does not relabel the observed steps"),
    ("plans", ("go_rule",), "it does not plan: it goes at a random time"),
    ("learns", ("relearn",), "it learns no models: it is given them or needs none"),
)
"""The options one part of a method alone reads beyond its sources' (:attr:`ModelSource.options`):
per part, the :class:`Method` attribute that says a method has it, the options (of
:class:`~mirl.learning.options.LearnOptions` and :class:`~mirl.experiments.options.RunProtocol`)
and why a method without it changes nothing for them. The relabelling rounds alone read their
limits, a method that plans alone its go rule, one that learns alone whether it re-learns."""


def _why_not(option: str, row: Method) -> str | None:
    """Why ``row`` changes nothing for ``option`` (its source's or its part's words); None if it
    reads it, or every method does (the table rules it nowhere)."""
    for part, table in (("reward", REWARD_SOURCES), ("transitions", TRANSITION_SOURCES)):
        if any(option in s.options for s in table.values()):
            source = table[getattr(row, part)]
            return None if option in source.options else f"its {part}: {source.description}"
    for attribute, options, why in PART_OPTIONS:
        if option in options:
            return None if getattr(row, attribute) else why
    return None


def ruled_options() -> frozenset[str]:
    """The options some method does not read (:func:`unread_option` refuses them for it): its
    sources' and :data:`PART_OPTIONS`'.

    Returns
    -------
    frozenset of str
        The options' names.
    """
    sources = (*REWARD_SOURCES.values(), *TRANSITION_SOURCES.values())
    return frozenset(
        [o for s in sources for o in s.options] + [o for _, opts, _ in PART_OPTIONS for o in opts]
    )


def unread_option(method: Method | str, given: Iterable[str]) -> tuple[str, str] | None:
    """The first of the ``given`` options that ``method`` never reads, with why: the one place
    that says which options apply to which method (its sources' :attr:`ModelSource.options` and
    :data:`PART_OPTIONS`), for :meth:`~mirl.learning.options.LearnOptions.check_method` and
    :meth:`~mirl.experiments.options.RunProtocol.check_method`. A setting is never silently
    ignored.

    Parameters
    ----------
    method : Method or str
        The method's row or name.
    given : iterable of str
        The options set (by the caller, or by the user's flags).

    Returns
    -------
    tuple of (str, str) or None
        The option and the problem, ``applies to the method mirl-t only, not known-r (it does
        not relabel the observed steps)``; None when the method reads every one.
    """
    row = get_method(method) if isinstance(method, str) else method
    for name in given:
        why = _why_not(name, row)
        if why is not None:
            users = [m.name for m in METHODS.values() if _why_not(name, m) is None]
            which = f"the method{'s' * (len(users) > 1)} {_and(users)}"
            return name, f"applies to {which} only, not {row.name} ({why})"
    return None


def _and(names: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def get_method(name: str, known: tuple[str, ...] | None = None) -> Method:
    """The row of method ``name`` (``METHODS.lookup``).

    Parameters
    ----------
    name : str
        A method's name.
    known : tuple of str, optional
        The names acceptable where the method is asked for (default: every method).

    Returns
    -------
    Method
        The row.

    Raises
    ------
    UnknownNameError
        A ValueError naming the nearest and the known methods.
    """
    return METHODS.lookup(name, among=known)
