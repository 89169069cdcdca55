"""How a run and a sweep go: :class:`RunProtocol` (what
:func:`~mirl.experiments.episode.run_episode` does between its scenario and its outcome),
:class:`SweepOptions` (how
:func:`~mirl.experiments.sweep.run_experiment` runs a grid) and the table of go rules, each
option declared once with its default, the values it takes and its flag
(:mod:`mirl._validation`).

The defaults are those of ``mirl run`` and ``mirl experiment``, so the Python API and the command
line give the same run for the same seed. The experiments' conditions run the paper's protocol
(:meth:`RunProtocol.paper`: a fixed observation time, the value rule, learning once) unless a
sweep asks for another. The module imports nothing heavy, so the command line builds its flags
from it at start-up.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from importlib import import_module
from typing import Any

from mirl._registry import Registry, Strategy, check_entry_point
from mirl._validation import (
    SEED,
    Boolean,
    Interval,
    OneOf,
    Options,
    Satisfies,
    option,
    same_option,
)
from mirl.learning.methods import Method, unread_option
from mirl.learning.options import LearnOptions
from mirl.world.actions import STEP_SECONDS
from mirl.worlds import DEFAULT_WORLD, WORLDS

__all__ = [
    "RunProtocol",
    "SweepOptions",
    "GoRule",
    "GO_RULES",
    "PAPER_GO_RULE",
    "MAX_OBS_STEPS",
    "MAX_WAIT_STEPS",
    "MIN_TRAVEL",
    "TRAVEL_PER_PATH_STEP",
]

# sizes that cannot work are refused with the limit in the message: L's filter and learning are
# O(steps), and 10 000 steps are 5.5 h of robot time; L re-plans every 10 steps while it waits
MAX_OBS_STEPS = 10_000
MAX_WAIT_STEPS = 10_000
MAX_RUNS = 100_000  # runs per condition of a sweep
MAX_WORKERS = 1024
# L's planning horizon after its last go time, unless given (``travel_steps``): this many times
# its shortest path to the goal, and at least MIN_TRAVEL steps (room for failed moves and for
# waiting out a patroller on the way)
TRAVEL_PER_PATH_STEP = 3
MIN_TRAVEL = 20


@dataclass(frozen=True)
class GoRule(Strategy):
    """One row of the table of go rules; ``load()`` gives its strategy class, a
    :class:`~mirl.experiments.go_rules.GoRuleStrategy`.

    Parameters
    ----------
    name : str
        What ``--go-rule`` and ``RunProtocol.go_rule`` take.
    description : str
        What the rule does (``--go-rule``'s help).
    entry_point : str
        Its strategy's class, ``"module:Class"`` (in :mod:`mirl.experiments.go_rules`),
        imported when a run uses it.
    """


GO_RULES: Registry[GoRule] = Registry(
    "go rule",
    (
        GoRule(
            "adaptive",
            "go when the chance of going now beats the value of waiting until the deadline, "
            "and state P(success) averaged over a posterior of L's models",
            "mirl.experiments.go_rules:AdaptiveRule",
        ),
        GoRule(
            "adaptive-posterior",
            "the adaptive rule, going only if the go-now chance scaled by the posterior-averaged "
            "P(success) over the point models' still beats the value of waiting",
            "mirl.experiments.go_rules:PosteriorAdaptiveRule",
        ),
        GoRule(
            "value",
            "the published rule (the best plan value in the window, if positive)",
            "mirl.experiments.go_rules:ValueRule",
        ),
    ),
    check=lambda rule: check_entry_point(rule.entry_point, f"go rule '{rule.name}': entry point"),
)
"""How L decides to go, by name (docs/design.md, "The go rule")."""

PAPER_GO_RULE = "value"
"""The paper's go rule."""



def _hazards() -> Any:
    """The planner's hazard models (:data:`mirl.planning.go.HAZARDS`), read when a protocol
    names one that is not the default: the planner imports numpy."""
    return import_module("mirl.planning.go").HAZARDS


class RunProtocol(Options):
    """How one run goes, from observing to going (:func:`~mirl.experiments.episode.run_episode`).

    The defaults are ``mirl run``'s. The paper's protocol is :meth:`paper`. Measured with the
    true models (``oracle``) on boyd2 at 0.14, 50 seeds, while the waiting time was 300 steps
    (success / detected / timeout): ``detection_penalty=0.5`` — go only when the predicted
    success beats half the predicted detection — 0.44 / 0.38 / 0.18, against 0.32 / 0.08 / 0.60
    at 1.0 (too cautious: mostly timeouts) and 0.36 / 0.64 / 0.00 at 0.25; the joint filter 0.44
    vs 0.38 with independent marginals; negative evidence 0.44 vs 0.32 without; the first-order
    hazard 0.44 vs 0.28 with independent per-step detection. ``max_wait`` 450 instead of 300
    (100 seeds): oracle 0.47 / 0.46 / 0.07 instead of 0.41 / 0.35 / 0.24 (200 seeds).

    Parameters
    ----------
    obs_steps : int in [1, 10000], default 300
        Steps L observes before it first learns (t = 0 … obs_steps − 1), 2 s each.
    watch_until_seen : int in [1, 10000] or None, default 40
        After ``obs_steps``, L keeps watching until it has seen every patroller on this many
        steps, or ``max_obs_steps`` have passed; None: exactly ``obs_steps`` (the experiments).
    max_obs_steps : int in [1, 10000], default 1800
        The end of watching: 60 min of robot time (on boyd2 at 0.14, seed 19's J first enters
        L's view at t = 1555).
    max_wait : int in [0, 10000], default 450
        Steps L may wait after observing before the run times out (with 300 observed, 25 min in
        all: the paper's limit for its physical runs).
    go_rule : {"adaptive", "value"}, default "adaptive"
        How L decides to go (:data:`GO_RULES`): ``"adaptive"`` goes when the chance of going now
        beats the value of waiting (one fresh chance per ``opportunity_steps`` steps left after
        the window) and states the exact P(success) it goes with; ``"value"`` is the published
        rule (``detection_penalty`` applies to it alone).
    relearn : bool, default True
        A method that learns re-learns while L waits whenever its record holds
        ``relearn_growth`` times the observed steps of its last learning.
    relearn_growth : float > 1, default 1.5
        That factor (docs/design.md, "Learning while waiting").
    window : int >= 0, default 60
        Go times scored by a planning round: now and the next ``window`` steps.
    replan_every : int >= 1, default 10
        Steps between planning rounds while no go time is set (a round also comes whenever a
        patroller leaves L's view).
    travel_steps : int >= 1, optional
        The planning horizon after the last go time; by default 3 × L's shortest path, at least
        20 steps.
    opportunity_steps : int >= 1, default 10
        The adaptive rule counts one fresh chance to go per this many steps left after the
        window: one per planning round (docs/design.md, "The go rule").
    commit : bool, default False
        Keep the first go time; by default a newer plan may move or cancel it (on boyd2 the two
        gave identical outcomes over 50 seeds: the best go time is almost always "now").
    hazard : {"markov", "independent"}, default "markov"
        The planner's detection hazard (:data:`mirl.planning.go.HAZARDS`).
    goal_reward : float > 0, default 1.0
        The planner's reward for reaching the goal.
    detection_penalty : float >= 0, default 0.5
        The value rule's cost of being seen: it goes when the predicted success beats this share
        of the predicted detection.
    joint : bool, optional
        Filter the patrollers jointly (True) or as independent marginals (False); by default the
        filter's own choice for the team's size (:class:`~mirl.planning.belief.BeliefFilter`).
    negative_evidence : bool, default True
        Not seeing a patroller in L's view is evidence that it is elsewhere.

    Raises
    ------
    mirl._validation.OptionError
        A value out of its range, an unknown option, ``watch_until_seen`` above
        ``max_obs_steps``.
    """

    obs_steps: int = option(
        Interval(int, 1, MAX_OBS_STEPS), default=300,
        doc=f"steps L observes before it first learns, {STEP_SECONDS:g} s each",
        flag="--obs-steps", metavar="N",
    )  # fmt: skip
    watch_until_seen: int | None = option(
        Interval(int, 1, MAX_OBS_STEPS), None, default=40,
        doc="after obs_steps L keeps watching until it has seen every patroller on K steps, "
        "for at most max_obs_steps in all",
        flag="--watch-until-seen", metavar="K",
    )  # fmt: skip
    max_obs_steps: int = option(
        Interval(int, 1, MAX_OBS_STEPS), default=1800,
        doc="the end of watching, in steps",
    )  # fmt: skip
    max_wait: int = option(
        Interval(int, 0, MAX_WAIT_STEPS), default=450,
        doc="steps L may wait after observing (450: 25 min in all with 300 observed)",
        flag="--max-wait", metavar="N",
    )  # fmt: skip
    go_rule: str = option(
        OneOf(GO_RULES), default="adaptive",
        doc="; ".join(f"{r.name}: {r.description}" for r in GO_RULES.values()),
        flag="--go-rule",
    )  # fmt: skip
    relearn: bool = option(
        Boolean(), default=True,
        doc="re-learn while waiting, whenever the record has grown relearn_growth times",
        flag="--learn-once",
    )  # fmt: skip
    relearn_growth: float = option(
        Interval(float, 1.0, None, open_low=True), default=1.5,
        doc="the growth of L's record that calls a re-learn",
    )  # fmt: skip
    window: int = option(Interval(int, 0, None), default=60, doc="go times a round scores")
    replan_every: int = option(
        Interval(int, 1, None), default=10, doc="steps between planning rounds while waiting"
    )
    travel_steps: int | None = option(
        Interval(int, 1, None), None, default=None,
        doc="planning horizon after the last go time (None: 3 x the shortest path, at least 20)",
    )  # fmt: skip
    opportunity_steps: int = option(
        Interval(int, 1, None), default=10,
        doc="the adaptive rule's steps per fresh chance to go after the window",
    )  # fmt: skip
    commit: bool = option(Boolean(), default=False, doc="keep the first go time")
    hazard: str = option(
        OneOf(_hazards), default="markov",
        doc="the planner's detection hazard (mirl.planning.go.HAZARDS)",
    )  # fmt: skip
    goal_reward: float = option(
        Interval(float, 0.0, None, open_low=True), default=1.0,
        doc="the planner's reward for reaching the goal",
    )  # fmt: skip
    detection_penalty: float = option(
        Interval(float, 0.0, None), default=0.5, doc="the value rule's cost of being seen"
    )
    joint: bool | None = option(
        Boolean(), None, default=None,
        doc="filter the patrollers jointly (None: the filter's choice for the team's size)",
    )  # fmt: skip
    negative_evidence: bool = option(
        Boolean(), default=True, doc="not seeing a patroller in L's view is evidence"
    )

    def _check(self) -> None:
        if self.watch_until_seen is not None and self.watch_until_seen > self.max_obs_steps:
            raise self.refuse(
                "watch_until_seen",
                f"must be at most max_obs_steps, the end of watching ({self.max_obs_steps} "
                f"steps), got {self.watch_until_seen}",
            )

    def check_method(self, method: Method | str, given: Iterable[str]) -> None:
        """Refuse an option the user set for a method it changes nothing for, as
        :meth:`~mirl.learning.options.LearnOptions.check_method` does (the table:
        :data:`~mirl.learning.methods.PART_OPTIONS`): ``go_rule`` for a method that does not
        plan (random), ``relearn`` for one that learns nothing (random, oracle).

        Only the options ``given`` are checked, never the others' values: a sweep runs every
        method under one protocol (the paper's value rule and learning once, for the random
        baseline too), so only the command line, which knows the flags typed, refuses.

        Parameters
        ----------
        method : Method or str
            The method's row or name.
        given : iterable of str
            The options the user set.

        Raises
        ------
        OptionError
            Naming the option, the methods it applies to and why it does not apply to this one.
        """
        unread = unread_option(method, given)
        if unread is not None:
            raise self.refuse(*unread)

    @classmethod
    def paper(cls, **changes: Any) -> RunProtocol:
        """The paper's protocol, which the experiments' conditions run: exactly ``obs_steps``
        observed, the value rule, learning once.

        Parameters
        ----------
        **changes : object
            Other options, by name.

        Returns
        -------
        RunProtocol
            The protocol.
        """
        fields: dict[str, Any] = {
            "watch_until_seen": None,
            "go_rule": PAPER_GO_RULE,
            "relearn": False,
        }
        return cls(**(fields | changes))

    @property
    def fixed_time(self) -> bool:
        """Whether L observes exactly ``obs_steps`` (no watching until seen)."""
        return self.watch_until_seen is None

    def travel(self, path_length: int) -> int:
        """The planning horizon after the last go time.

        Parameters
        ----------
        path_length : int
            Steps of L's shortest path to its goal.

        Returns
        -------
        int
            ``travel_steps``, or 3 × the path, at least 20.
        """
        if self.travel_steps is not None:
            return int(self.travel_steps)
        return max(MIN_TRAVEL, TRAVEL_PER_PATH_STEP * int(path_length))


def _is_address(text: str) -> bool:
    """``[scheme://]HOST:PORT`` with a port in 1 … 65535."""
    m = re.fullmatch(r"(?:[a-z][a-z0-9+.-]*://)?(\[[0-9a-fA-F:]+\]|[^:/\s\[\]]+):(\d{1,5})", text)
    return m is not None and 0 < int(m.group(2)) < 65536


class SweepOptions(Options):
    """How :func:`~mirl.experiments.sweep.run_experiment` runs an experiment's grid; the
    defaults are ``mirl experiment``'s.

    .. versionchanged:: 0.2.0
       The defaults are the command line's: every CPU, and mirl's protocol (the adaptive rule,
       re-learning while waiting) on the runs of L.

    Parameters
    ----------
    runs : int in [1, 100000], optional
        Runs per condition; by default the experiment's (200 for the paper's).
    workers : int in [1, 1024], optional
        Local worker processes; by default one per CPU (refused with ``dask_scheduler``).
    resume : bool, default False
        Skip the runs the results directory holds, retry its failed ones; without it a directory
        that holds runs is refused.
    dask_scheduler : str, optional
        ``[scheme://]HOST:PORT`` of a Dask cluster to run on.
    base_seed : int in [0, 2^63 - 1], default 0
        The base of the run seeds: run i of every condition uses the seed of (base_seed, i).
    progress : bool, default True
        A progress bar on a terminal, else progress lines.
    progress_every : int in [1, 100000], optional
        When stderr is not a terminal, a progress line every this many runs; by default about
        every 5 % of the sweep (refused without ``progress``).
    world : str, default "grid"
        The world every condition runs in (:data:`~mirl.worlds.WORLDS`).
    go_rule, relearn : str, bool
        How L decides and whether it re-learns, on every condition
        (:class:`RunProtocol`'s; ``go_rule="value", relearn=False`` keeps the conditions' own,
        the paper's protocol).
    em_init : str, optional
        DBN-EM's initial T on the dbn-em conditions (:class:`~mirl.learning.options.LearnOptions`).
    """

    runs: int | None = option(
        Interval(int, 1, MAX_RUNS), None, default=None,
        doc="runs per condition (None: the experiment's default, 200 for the paper's)",
        flag="--runs", metavar="N",
    )  # fmt: skip
    workers: int | None = option(
        Interval(int, 1, MAX_WORKERS), None, default=None,
        doc="local processes (None: one per CPU)", flag="--workers", metavar="K",
    )  # fmt: skip
    resume: bool = option(
        Boolean(), default=False, doc="skip the runs DIR already holds", flag="--resume"
    )
    dask_scheduler: str | None = option(
        Satisfies(_is_address, "an address HOST:PORT (e.g. tcp://127.0.0.1:8786)"), None,
        default=None, doc="run on this Dask cluster", flag="--dask-scheduler", metavar="ADDRESS",
    )  # fmt: skip
    base_seed: int = option(
        SEED, default=0, doc="base seed of the run seeds", flag="--seed", metavar="K"
    )
    progress: bool = option(
        Boolean(), default=True, doc="a progress bar or progress lines", flag="--quiet"
    )
    progress_every: int | None = option(
        Interval(int, 1, MAX_RUNS), None, default=None,
        doc="when output is not a terminal, a progress line every N runs (None: ~every 5%)",
        flag="--progress-every", metavar="N",
    )  # fmt: skip
    world: str = option(
        OneOf(WORLDS, kind="world"), default=DEFAULT_WORLD,
        doc="the world of every run", flag="--world",
    )  # fmt: skip
    go_rule: str = same_option(RunProtocol, "go_rule")
    relearn: bool = same_option(RunProtocol, "relearn")
    em_init: str | None = same_option(LearnOptions, "em_init")

    def _check(self) -> None:
        # an option another one makes unread is refused, as the command line refuses flags
        # that would be ignored: the cluster runs on all its threads, and quiet prints nothing
        if self.dask_scheduler is not None and self.workers is not None:
            raise self.refuse(
                "workers",
                "sets local processes, and `dask_scheduler` runs on every thread of the "
                "cluster instead: give one of them",
            )
        if not self.progress and self.progress_every is not None:
            raise self.refuse(
                "progress_every", "spaces the progress lines, which `progress` turns off: "
                "give one of them",
            )  # fmt: skip

    @property
    def n_workers(self) -> int:
        """The local worker processes."""
        import os

        return self.workers if self.workers is not None else os.cpu_count() or 1
