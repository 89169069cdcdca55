"""How L learns: :class:`LearnOptions`, the options :func:`mirl.learning.learn.learn` takes beyond
the observations, the scenario and the method, each declared once with its default, the values
it takes and its flag (:mod:`mirl._validation`).

The names the options choose among live here too — the IRL's objectives and optimisers, DBN-EM's
initial transition models — so that the command line reads them without importing the modules
that implement them (numpy and scipy). The module imports nothing heavy.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

from mirl._registry import Registry, Strategy, check_entry_point, resolve
from mirl._validation import Instance, Interval, OneOf, Options, option, unknown_name
from mirl.learning.methods import METHODS, Method, unread_option

__all__ = [
    "LearnOptions",
    "IRL_OBJECTIVES",
    "Objective",
    "IRL_OPTIMIZERS",
    "Optimizer",
    "EM_INITS",
    "LABELLINGS",
    "Labelling",
    "DEFAULT_P",
]

@dataclass(frozen=True)
class Objective:
    """What the IRL fits: the terms its loss adds up.

    Parameters
    ----------
    name : str
        What ``objective`` takes.
    description : str
        What it is.
    counts : bool, default False
        Whether the loss has the squared difference of feature counts on the observed steps.
    likelihood : bool, default False
        Whether it has the negative log-likelihood of the observed labelled actions.
    sequence : bool, default False
        Whether it has the negative log-likelihood of everything L saw, occlusion included.
    """

    name: str
    description: str
    counts: bool = False
    likelihood: bool = False
    sequence: bool = False


def _adds_a_term(row: Objective) -> None:
    if not (row.counts or row.likelihood or row.sequence):
        raise ValueError(f"objective '{row.name}' adds no term to the loss")


IRL_OBJECTIVES: Registry[Objective] = Registry(
    "objective",
    (
        Objective("counts", "the paper's: squared difference of feature counts on observed "
                  "steps", counts=True),
        Objective("likelihood", "log-likelihood of the observed labelled actions",
                  likelihood=True),
        Objective("both", "counts and likelihood added", counts=True, likelihood=True),
        Objective("sequence", "log-likelihood of everything L saw of the robot, occlusion "
                  "included", sequence=True),
    ),
    check=_adds_a_term,
)  # fmt: skip
"""What :class:`~mirl.learning.irl.OccludedMaxEntIRL` fits (its module docstring)."""


@dataclass(frozen=True)
class Optimizer:
    """An optimiser of the IRL.

    Parameters
    ----------
    name : str
        What ``optimizer`` takes.
    description : str
        What it is.
    restarts : int
        The starts it makes unless told (``n_restarts``).
    """

    name: str
    description: str
    restarts: int


IRL_OPTIMIZERS: Registry[Optimizer] = Registry("optimizer", (
    Optimizer("nelder-mead", "derivative-free Nelder-Mead from seeded restarts (the paper's)", 3),
    # its restarts were measured to land on the same optimum
    Optimizer("lbfgs", "L-BFGS-B with the exact gradient", 1),
))  # fmt: skip
"""How the IRL fits, by name."""

EM_INITS = Registry.of_choices("EM initialisation", {
    "intended": "uniform over the intended outcomes ψ(s, a') of every action (the default)",
    "uniform": "uniform over all states",
})  # fmt: skip
"""DBN-EM's initial transition models (:func:`~mirl.learning.dbn_em.initial_transitions`)."""

IRL_ESTIMATOR = "mirl.learning.irl:OccludedMaxEntIRL"
"""The estimator ``irl_options`` configure, by entry point (``LearnOptions`` checks them)."""


@dataclass(frozen=True)
class Labelling(Strategy):
    """How ``mirl learn-transitions`` labels the observed steps with actions; ``load()`` gives
    ``labels(scenario, series_list)``.

    Parameters
    ----------
    name : str
        What ``--labels`` takes.
    description : str
        What it does (``--labels``'s help).
    entry_point : str
        Its function, ``"module:function"``.
    reads_truth : bool, default False
        Whether it reads the scenario's true policies, which its true feature probabilities
        (``--damage``'s) shape; ``--damage`` is refused with a labelling that does not.
    """

    reads_truth: bool = False


LABELLINGS: Registry[Labelling] = Registry(
    "labelling",
    (
        Labelling(
            "true-policy",
            "the scenario's true policies and played equilibrium label the steps (Known R/T)",
            "mirl.learning.transitions:true_policy_labels",
            reads_truth=True,
        ),
        Labelling(
            "perception",
            "each step is labelled with the action whose intended outcome L saw",
            "mirl.learning.transitions:perceived_labels",
        ),
    ),
    check=lambda row: check_entry_point(row.entry_point, f"labelling '{row.name}': entry point"),
)
"""How ``mirl learn-transitions`` labels the observed steps with actions; a row's entry point is
``labels(scenario, series_list)``, per robot its (horizon,) labels, -1 where unlabelled."""

DEFAULT_P = 0.9
"""The success probability of every action for the methods with a fixed T, when ``p`` is None."""


class LearnOptions(Options):
    """How :func:`~mirl.learning.learn.learn` learns; every field is optional.

    Parameters
    ----------
    p : float in [0, 1], optional
        Success probability of every action, for the methods with a fixed T (``mirl``,
        ``known-r``; refused for the others). None: 0.9 (:data:`DEFAULT_P`).
    max_iterations : int in [1, 100], default 5
        Rounds of relabelling at most (``mirl-t`` only, the method that relabels; refused, set
        away from its default, for the others).
    label_tol : float in [0, 1], default 0.01
        The relabelling has converged when a round changes at most this share of the labelled
        steps (those T is learned from); on long records a few labels can flip back and forth
        for rounds, each a full refit (docs/design.md, "A looser stopping rule"). ``mirl-t``
        only, as ``max_iterations``.
    objective : {"sequence", "counts", "likelihood", "both"}, default "sequence"
        The IRL's objective (:class:`~mirl.learning.irl.OccludedMaxEntIRL`); the paper's is
        ``"counts"``. The defaults were picked by measured behaviour accuracy and speed (the
        :mod:`mirl.learning.irl` docstring). The IRL's options (this, ``optimizer``,
        ``n_restarts``, ``irl_options``) apply to the methods that learn the reward (``mirl-t``,
        ``mirl``, ``dbn-em``); set for the others, they are refused.
    optimizer : {"lbfgs", "nelder-mead"}, default "lbfgs"
        The IRL's optimiser; the paper's is ``"nelder-mead"``.
    n_restarts : int >= 1, optional
        The IRL's starts: by default 1 for L-BFGS (its restarts were measured to land on the
        same optimum) and 3 for Nelder–Mead.
    irl_options : mapping, optional
        Further keyword arguments of the estimator (e.g. ``anchor``, ``l2``,
        ``max_evaluations``), checked by it.
    em_init : {"intended", "uniform"}, optional
        DBN-EM's initial T (``dbn-em`` only; refused for the others). None: ``"intended"``.

    Raises
    ------
    mirl._validation.OptionError
        A value out of its range, or an unknown option (the message names it).
    """

    p: float | None = option(
        Interval(float, 0.0, 1.0), None, default=None,
        doc="fixed success probability of every action, for "
        + " and ".join(m.name for m in METHODS.values() if m.uses_p),
        flag="--p", metavar="P",
    )  # fmt: skip
    max_iterations: int = option(
        Interval(int, 1, 100), default=5,
        doc="relabelling rounds of mirl-t at most", flag="--max-iterations", metavar="N",
    )  # fmt: skip
    label_tol: float = option(
        Interval(float, 0.0, 1.0), default=0.01,
        doc="mirl-t's relabelling has converged when a round changes at most this share of the "
        "labelled steps (0: none)",
        flag="--label-tol", metavar="F",
    )  # fmt: skip
    objective: str = option(
        OneOf(IRL_OBJECTIVES), default="sequence",
        doc="IRL objective (paper: counts)", flag="--objective",
    )  # fmt: skip
    optimizer: str = option(
        OneOf(IRL_OPTIMIZERS), default="lbfgs",
        doc="IRL optimiser (paper: nelder-mead)", flag="--optimizer",
    )  # fmt: skip
    n_restarts: int | None = option(
        Interval(int, 1, None), None, default=None,
        doc="the IRL's starts (None: 1 for lbfgs, 3 for nelder-mead)",
    )  # fmt: skip
    irl_options: Mapping[str, Any] | None = option(
        Instance(Mapping, "a mapping of the estimator's options"), None, default=None,
        doc="further keyword arguments of the IRL estimator",
    )  # fmt: skip
    em_init: str | None = option(
        OneOf(EM_INITS), None, default=None,
        doc="DBN-EM's initial transitions: uniform over the intended states of all actions, or "
        "over all states",
        flag="--em-init",
    )  # fmt: skip

    def _check(self) -> None:
        if self.irl_options is not None:  # a read-only copy: the options stay as they were made
            object.__setattr__(self, "irl_options", MappingProxyType(dict(self.irl_options)))
            self._check_irl_options()

    def _check_irl_options(self) -> None:
        """Refuse what the estimator would refuse only once learning had started (an unknown
        keyword, a bad value, ``random_state`` twice), and a setting these options make
        themselves, which the mapping would silently override (``objective``)."""
        assert self.irl_options is not None
        own = ("objective", "optimizer", "n_restarts")
        key = next((k for k in own if k in self.irl_options), None)
        if key is not None:
            raise self.refuse(
                "irl_options",
                f"may not set '{key}', an option of {type(self).__name__} itself (give "
                f"{key}=... beside irl_options)",
            )
        if "random_state" in self.irl_options:
            raise self.refuse(
                "irl_options",
                "may not set 'random_state': learn()'s own random_state seeds the IRL of every "
                "robot and round",
            )
        # the estimator by its entry point, loaded only when options are given (scipy), as the
        # tables here load what carries their rows out: irl.py reads this module's vocabularies
        OccludedMaxEntIRL = resolve(IRL_ESTIMATOR)
        try:
            OccludedMaxEntIRL(**self.irl_options)
        except TypeError:  # an unexpected keyword
            known = [n for n in OccludedMaxEntIRL().get_params() if n not in (*own, "random_state")]
            name = next(k for k in self.irl_options if k not in known)
            raise self.refuse(
                "irl_options", unknown_name("estimator option", name, known)
            ) from None
        except ValueError as exc:
            problem = f"holds a setting the estimator refuses: {exc}"
            raise self.refuse("irl_options", problem) from None

    @property
    def in_effect_default(self) -> bool:
        """Whether these options learn as the defaults do (an option given at its default
        value, such as ``p=0.9``, counts as the default)."""
        given = replace(
            self,
            p=None if self.fixed_p == DEFAULT_P else self.p,
            em_init=None if self.initial_transitions == EM_INITS.names[0] else self.em_init,
            n_restarts=(
                None if self.restarts == IRL_OPTIMIZERS[self.optimizer].restarts
                else self.n_restarts
            ),
            irl_options=self.irl_options or None,
        )  # fmt: skip
        return given == type(self)()

    @property
    def fixed_p(self) -> float:
        """The success probability a method with a fixed T uses."""
        return DEFAULT_P if self.p is None else float(self.p)

    @property
    def initial_transitions(self) -> str:
        """DBN-EM's initial T."""
        return EM_INITS.names[0] if self.em_init is None else self.em_init

    @property
    def restarts(self) -> int:
        """The IRL's starts."""
        if self.n_restarts is not None:
            return int(self.n_restarts)
        return IRL_OPTIMIZERS[self.optimizer].restarts

    def check_method(self, method: Method | str, given: Iterable[str] | None = None) -> None:
        """Refuse an option set for a method it changes nothing for: an option that one source
        of models alone reads (:attr:`~mirl.learning.methods.ModelSource.options`: ``p`` for a
        fixed T, ``em_init`` for DBN-EM, the IRL's ``objective``, ``optimizer``, ``n_restarts``
        and ``irl_options`` for a learned reward), or one part of a method alone
        (:data:`~mirl.learning.methods.PART_OPTIONS`: ``max_iterations`` and ``label_tol`` for the
        relabelling rounds), given for a method without it. A setting is never silently
        ignored.

        Parameters
        ----------
        method : Method or str
            The method's row or name.
        given : iterable of str, optional
            The options the caller set (the command line: the flags given); by default those
            that differ from their declared defaults (``changed()``).

        Raises
        ------
        OptionError
            Naming the option, the methods it applies to and why it does not apply to this one.
        """
        unread = unread_option(method, self.changed() if given is None else given)
        if unread is not None:
            raise self.refuse(*unread)
