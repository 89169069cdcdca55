"""The paper's evaluation as data: conditions, experiment grids (docs/design.md, "The paper's
experiments as data") and run functions.

How the grids are executed and stored is :mod:`mirl.experiments.sweep`.

An experiment is a grid of :class:`Condition` s × run indices 0…runs−1. Run ``i`` of *every*
condition uses the seed derived from (base seed, i) only — common random numbers: all methods,
observabilities and observation times face the same patrol realisations, so their differences
are not noise from different patrols. A run's result depends only on (condition, seed), never on
the number of workers or the order in which runs finish.

"""

from __future__ import annotations

import hashlib
import json
import os
import time
import zlib
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

from mirl._registry import Registry
from mirl.experiments.atlas import atlas_design, atlas_run
from mirl.experiments.options import PAPER_GO_RULE, RunProtocol
from mirl.learning.methods import METHODS
from mirl.learning.verdicts import also_field
from mirl.worlds import DEFAULT_WORLD, WORLDS

__all__ = [
    "Condition",
    "Experiment",
    "EXPERIMENTS",
    "experiment_names",
    "get_experiment",
    "in_world",
    "run_seed",
    "code_version",
    "episode_run",
    "selftest_run",
    "StoreError",
    "OUTCOMES",
]

DEFAULT_OBS_STEPS: int = RunProtocol.default("obs_steps")
GO_RULE_PUBLISHED = PAPER_GO_RULE
GO_RULE_DEFAULT: str = RunProtocol.default("go_rule")  # mirl's, the API's and the command line's
DEFAULT_RUNS = 200  # per point, as in the paper's simulations
DOOR_VIEW = 0.14  # the paper's L at its door on boyd2 (its scenario's observability)
FULL_VIEW = 1.0  # L sees every patroller cell
OUTCOMES = ("success", "detected", "timeout", "learned")  # learned: a run with no L to go (atlas)


@dataclass(frozen=True)
class Condition:
    """One point of an experiment grid; its :attr:`key` names its runs in the store.

    Parameters
    ----------
    method : str
        The method (a row of :data:`~mirl.learning.methods.METHODS`).
    scenario : str, default "boyd2"
        The shipped scenario's name.
    observability : float, default 0.14
        The share of the hallway L sees from its room.
    obs_steps : int, default 300
        Steps L observes before it may go (``RunProtocol``'s default).
    p : float, optional
        The fixed success probability of the fixed-T methods (``mirl``, ``known-r``); None for
        methods that learn or know T.
    world : str, default "grid"
        The world (a row of :data:`~mirl.worlds.WORLDS`).
    em_init : str, optional
        DBN-EM's initial T; None: the default (``"intended"``).
    go_rule : str, optional
        How L decides to go; None is the paper's rule (``"value"``).
    relearn : bool, default False
        Whether L re-learns while it waits (False: the paper's protocol).
    damage : str, optional
        ``"ROBOT:FEATURE"``: one part of the scenario damaged, to the world's
        :attr:`~mirl.worlds.registry.WorldSpec.experiment_damage`; None: as the scenario has
        it.
    """

    method: str
    scenario: str = "boyd2"
    observability: float = DOOR_VIEW
    obs_steps: int = DEFAULT_OBS_STEPS
    p: float | None = None
    world: str = DEFAULT_WORLD  # a name in mirl.worlds.WORLDS
    em_init: str | None = None  # DBN-EM's initial T; None: the default ("intended")
    # how L decides to go and whether it re-learns while it waits; None and False are the
    # paper's protocol (``with_protocol`` gives mirl's, the command line's default), so that
    # databases written before these fields existed keep their keys and meaning
    go_rule: str | None = None
    relearn: bool = False
    damage: str | None = None  # "ROBOT:FEATURE" damaged in the world's way; None: as scenario

    @property
    def key(self) -> str:
        """Stable identity: JSON of the sorted fields (part of the database's primary key);
        ``world`` only when it is not the grid and ``em_init``, ``go_rule``, ``relearn`` and
        ``damage`` only when set, so databases written before they existed keep their keys."""
        defaults = {
            "em_init": None, "go_rule": None, "relearn": False, "world": DEFAULT_WORLD,
            "damage": None,
        }  # fmt: skip
        fields = {
            k: v
            for k, v in asdict(self).items()
            if not (k in defaults and v == defaults[k] and type(v) is type(defaults[k]))
        }
        return json.dumps(fields, sort_keys=True, separators=(",", ":"))

    @classmethod
    def from_key(cls, key: str) -> Condition:
        """The condition a :attr:`key` names.

        Parameters
        ----------
        key : str
            A condition's key, as stored.

        Returns
        -------
        Condition
            The condition.
        """
        return cls(**json.loads(key))

    @property
    def label(self) -> str:
        """The condition in words, for reports and messages (its method, p, initialisation,
        protocol and damage where they are not the defaults)."""
        label = self.method if self.p is None else f"{self.method} (p={self.p:g})"
        if self.em_init is not None:
            label = f"{label} ({self.em_init} init)"
        label = f"{label}{self.protocol_label}"
        return label if self.damage is None else f"{label}, {self.damage} damaged"

    @property
    def protocol_label(self) -> str:
        """How L decided, for labels: nothing for mirl's default protocol and for the paper's
        (the conditions' own; a report says which one its runs used), else its parts."""
        rule = self.go_rule or GO_RULE_PUBLISHED
        named = (rule, self.relearn) in ((GO_RULE_DEFAULT, True), (GO_RULE_PUBLISHED, False))
        return "" if named else f" ({self.protocol})"

    @property
    def protocol(self) -> str:
        """The protocol's name in words, for reports."""
        rule = self.go_rule or GO_RULE_PUBLISHED
        if (rule, self.relearn) == (GO_RULE_PUBLISHED, False):
            return "the paper's protocol (value rule, learning once)"
        if (rule, self.relearn) == (GO_RULE_DEFAULT, True):
            return "mirl's protocol (adaptive rule, re-learning while waiting)"
        return f"{rule} rule, {'re-learning while waiting' if self.relearn else 'learning once'}"

    def scenario_object(self):
        """The condition's scenario, with its ``damage`` applied in its world.

        Returns
        -------
        Scenario
            The scenario (loaded once per process).
        """
        scenario = _scenario(self.scenario)
        if self.damage is None:
            return scenario
        robot, feature = self.damage.split(":")
        world = WORLDS[self.world]
        return world.load().apply_damage(scenario, robot, feature, world.experiment_damage)


def in_world(experiment: Experiment, world: str) -> Experiment:
    """The same grid of conditions run in another world (``mirl experiment --world``).

    Parameters
    ----------
    experiment : Experiment
        An experiment whose conditions run in the grid world.
    world : str
        The world's name.

    Returns
    -------
    Experiment
        The experiment with every condition in ``world`` (itself for the grid).

    Raises
    ------
    StoreError
        If the world is unknown, the experiment runs in several worlds already, or its runs
        are not episodes.
    """
    if world == DEFAULT_WORLD:
        return experiment
    if world not in WORLDS:
        raise StoreError(f"unknown world '{world}' (known: {', '.join(WORLDS)})")
    if any(c.world != DEFAULT_WORLD for c in experiment.conditions):
        raise StoreError(f"experiment '{experiment.name}' runs in every world already")
    if experiment.run_function is not episode_run:
        raise StoreError(f"experiment '{experiment.name}' has no physical version")
    conds = tuple(replace(c, world=world) for c in experiment.conditions)
    desc = experiment.description.replace("on the grid simulator", f"in the {world} world")
    return replace(experiment, conditions=conds, description=f"{desc} ({world} world)")


RunFunction = Callable[[Condition, int], Mapping[str, Any]]
"""``fn(condition, seed) -> result``: a picklable top-level callable. The result maps
``outcome`` (success/detected/timeout) and optionally ``go_time``, ``behavior_accuracy``,
``feature_probabilities`` ({robot: {feature: p}}), ``timings`` ({phase: seconds}); any other
JSON-serialisable entries are kept as metrics."""


@dataclass(frozen=True)
class Experiment:
    """An experiment: a grid of conditions, each run ``runs`` times by its run function.

    Parameters
    ----------
    name : str
        Its name (``mirl experiment NAME``).
    description : str
        One line, for ``--help`` and the report.
    conditions : tuple of Condition
        The grid, in the order the report shows it.
    run_function : callable
        ``fn(condition, seed) -> mapping`` (:data:`RunFunction`), top-level so it pickles.
    default_runs : int, default 200
        Runs per condition unless ``--runs`` says otherwise.
    hidden : bool, default False
        A built-in smoke experiment, runnable by name but not listed in help.
    """

    name: str
    description: str
    conditions: tuple[Condition, ...]
    run_function: RunFunction
    default_runs: int = DEFAULT_RUNS
    hidden: bool = False  # built-in smoke experiments, not listed in help


@lru_cache(maxsize=1)
def code_version() -> str:
    """The library version plus a hash of the package's source and shipped data, so rows that
    different code computed are told apart even between releases (work in progress, a
    resumed sweep after an edit)."""
    from mirl._version import package_version

    root = Path(__file__).parents[1]  # the whole mirl package, not just this stage
    h = hashlib.sha256()
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.suffix in {".py", ".txt", ".toml"}:
            h.update(p.relative_to(root).as_posix().encode())
            h.update(p.read_bytes())
    return f"{package_version()}+src.{h.hexdigest()[:10]}"


def run_seed(base_seed: int, run: int) -> int:
    """Seed of run ``run`` of every condition: a function of (base seed, run) only.

    Parameters
    ----------
    base_seed : int
        The sweep's base seed.
    run : int
        The run's index.

    Returns
    -------
    int
        The seed (common random numbers: every condition's run ``run`` gets it).
    """
    import numpy as np  # here: the command line reads this module's table at start-up

    return int(np.random.SeedSequence([base_seed, run]).generate_state(1)[0])


# ---------------------------------------------------------------------------------------------
# Run functions


@lru_cache(maxsize=8)
def _scenario(name: str):
    # loading a scenario solves the true patrollers' MDPs; do it once per worker process
    from mirl.world.scenario import load_scenario

    return load_scenario(name)


def episode_run(condition: Condition, seed: int) -> dict[str, Any]:
    """The real run: one episode of :func:`mirl.experiments.episode.run_episode` under the
    condition's protocol, flattened to a result mapping.

    Parameters
    ----------
    condition : Condition
        The condition.
    seed : int
        The run's seed.

    Returns
    -------
    dict
        ``outcome``, ``go_time``, ``behavior_accuracy``, ``feature_probabilities``,
        ``timings`` and the run's further numbers (per-robot accuracy and sightings, the plan's
        value, the world's counts, and for methods that learn feature probabilities each
        robot's verdict, its confidence, the truth and whether it was right).
    """
    from mirl.experiments.episode import run_episode

    learning = {"p": condition.p, "em_init": condition.em_init}
    scenario = condition.scenario_object()
    result = run_episode(
        scenario,
        condition.method,
        seed=seed,
        observability=condition.observability,
        # the paper's protocol: a fixed observation time, and the condition's rule
        protocol=RunProtocol.paper(
            obs_steps=condition.obs_steps,
            go_rule=condition.go_rule or GO_RULE_PUBLISHED,
            relearn=condition.relearn,
        ),
        learn_options={k: v for k, v in learning.items() if v is not None},
        world=condition.world,
    )
    out = _flatten_run_result(result)
    if METHODS[condition.method].has_feature_probabilities and result.learned is not None:
        truth = WORLDS[condition.world].load().damaged_parts(scenario)
        out.update(_verdict_metrics(result.learned, truth))
    return out


def _verdict_metrics(learned: Any, truth: Mapping[str, tuple[str, ...]]) -> dict[str, Any]:
    """Per robot the verdict, the parts it says are damaged besides (``also.<robot>``, where
    there are any), its confidence, ``unseen.<robot>`` = 1 where L never saw it move (no
    verdict), the truly damaged parts and whether the verdict is right; and the feature
    intervals (``ci.<robot>.<feature>``: [lo, hi])."""
    out: dict[str, Any] = {}
    for r in learned.robots:
        v = r.verdict
        if v is None:
            continue
        out[f"verdict.{r.name}"] = ",".join(v.named)
        if v.also:
            out[f"also.{r.name}"] = also_field(v)
        out[f"confidence.{r.name}"] = float(v.confidence)
        if not v.seen_moving:  # no verdict: the confidence is the prior's
            out[f"unseen.{r.name}"] = 1
        out[f"truth.{r.name}"] = ",".join(truth[r.name])
        out[f"right.{r.name}"] = int(v.is_right(truth[r.name]))
        out.update({f"ci.{r.name}.{f}": list(iv) for f, iv in r.feature_intervals.items()})
    return out


def _flatten_run_result(result: Any) -> dict[str, Any]:
    out: dict[str, Any] = {
        "outcome": result.outcome,
        "go_time": _maybe_float(getattr(result, "go_time", None)),
        "behavior_accuracy": _maybe_float(getattr(result, "behavior_accuracy", None)),
        "feature_probabilities": {
            str(r): {str(f): float(p) for f, p in fp.items()}
            for r, fp in (getattr(result, "feature_probabilities", None) or {}).items()
        },
        "timings": {str(k): float(v) for k, v in (getattr(result, "timings", None) or {}).items()},
    }
    for robot, acc in (getattr(result, "behavior_accuracy_per_robot", None) or {}).items():
        out[f"behavior_accuracy_{robot}"] = _maybe_float(acc)
    # why a run went as it did: how much L saw and how confident its plan was
    for robot, n in (getattr(result, "seen_steps", None) or {}).items():
        out[f"seen_steps_{robot}"] = int(n)
    out["plan_value"] = _maybe_float(getattr(result, "plan_value", None))
    out["predicted_success"] = _maybe_float(getattr(result, "predicted_success", None))
    interval = getattr(result, "predicted_success_interval", None)
    if interval is not None:  # the spread of the stated chance over the model draws
        out["predicted_success_lo"], out["predicted_success_hi"] = map(float, interval)
        out["predicted_success_point"] = _maybe_float(result.predicted_success_point)
        averaged = getattr(result, "predicted_success_averaged", None)
        if averaged is not None:  # before the method's held-out calibration
            out["predicted_success_averaged"] = float(averaged)
            raw = result.predicted_success_interval_averaged
            out["predicted_success_averaged_lo"], out["predicted_success_averaged_hi"] = map(
                float, raw
            )
    relearns = getattr(result, "relearns", None)
    if relearns is not None:
        out["relearns"] = len(relearns)
    out["plan_attempts"] = len(getattr(result, "attempts", ()) or ())
    extras = getattr(result, "extras", None)
    if extras is not None:  # the world's own counts (the physics world's contact events)
        out.update({k: v for k, v in extras.to_dict().items() if isinstance(v, int | float)})
    return out


def _maybe_float(v: Any) -> float | None:
    return None if v is None else float(v)


def selftest_run(condition: Condition, seed: int) -> dict[str, Any]:
    """A cheap deterministic stand-in for an episode (the ``selftest`` experiment): the result
    is a pure function of (condition, seed); ``MIRL_SELFTEST_SLEEP`` seconds of sleep make it
    slow enough to be interrupted in tests.

    Parameters
    ----------
    condition : Condition
        The condition (its key and observability shape the result).
    seed : int
        The run's seed.

    Returns
    -------
    dict
        A result mapping as :func:`episode_run`'s, made up from the seed.
    """
    time.sleep(float(os.environ.get("MIRL_SELFTEST_SLEEP", "0")))
    import numpy as np

    rng = np.random.default_rng([seed, zlib.crc32(condition.key.encode())])
    acc = float(np.clip(0.4 + 0.5 * condition.observability + 0.1 * rng.standard_normal(), 0, 1))
    u = rng.random()
    outcome = "success" if u < acc * 0.6 else ("timeout" if u > 0.97 else "detected")
    return {
        "outcome": outcome,
        "go_time": None if outcome == "timeout" else float(rng.integers(0, 50)),
        "behavior_accuracy": acc,
        "behavior_accuracy_I": acc,
        "behavior_accuracy_J": acc,
        "feature_probabilities": {
            "I": {"left_wheel": 0.95 - 0.02 * rng.random(), "right_wheel": 0.95},
            "J": {"left_wheel": 0.70 + 0.05 * rng.random(), "right_wheel": 0.95},
        },
        "timings": {"learn": 0.001},
    }


# ---------------------------------------------------------------------------------------------
# Grids (docs/design.md, "The paper's experiments as data")

OBSERVABILITIES = (DOOR_VIEW, 0.3, 0.5, 0.75, FULL_VIEW)
OBS_STEPS = (150, 300, 450, 900)
FIXED_PS = (0.7, 0.8, 0.9, 0.95)


def _fig3() -> tuple[Condition, ...]:
    return tuple(
        Condition(m, "boyd2", d, n)
        for m in ("mirl-t", "known-r-t")
        for n in OBS_STEPS
        for d in OBSERVABILITIES
    )


def _fig4a() -> tuple[Condition, ...]:
    conds: list[Condition] = []
    for d in (DOOR_VIEW, FULL_VIEW):
        conds += [Condition(m, "boyd2", d) for m in ("oracle", "known-r-t", "mirl-t")]
        conds.append(Condition("known-r", "boyd2", d, p=0.9))
        conds += [Condition("mirl", "boyd2", d, p=p) for p in FIXED_PS]
        conds += [Condition(m, "boyd2", d) for m in ("dbn-em", "random")]
    return tuple(conds)


def _features(scenario: str) -> tuple[Condition, ...]:
    return tuple(
        Condition(m, scenario, d) for d in (DOOR_VIEW, FULL_VIEW) for m in ("mirl-t", "known-r-t")
    )


def _verdicts() -> tuple[Condition, ...]:
    """The calibration of the fault verdicts: both worlds, L's door and full view, no damage
    and a damaged wheel on each robot and side (docs/design.md, "Fault verdicts")."""
    damages = (None, "I:left_wheel", "I:right_wheel", "J:left_wheel", "J:right_wheel")
    return tuple(
        Condition("mirl-t", "boyd2-healthy", d, world=w, damage=x)
        for w in WORLDS
        for d in (DOOR_VIEW, FULL_VIEW)
        for x in damages
    )


def _table1() -> tuple[Condition, ...]:
    return tuple(
        Condition(m, s, DOOR_VIEW, p=p)
        for s in ("boyd2", "boyd2-healthy")
        for m, p in (("mirl-t", None), ("mirl", 0.9), ("random", None))
    )


def _selftest() -> tuple[Condition, ...]:
    return tuple(Condition(m, "boyd2", d, 10) for m in ("a", "b") for d in (DOOR_VIEW, FULL_VIEW))


def _check_experiment(exp: Experiment) -> None:
    """An experiment runs as its table row says: at least one run per condition by default,
    conditions of known methods and worlds, no condition twice (its key names its rows in
    the store). The fake run of ``selftest`` takes any method name."""
    where = f"experiment '{exp.name}'"
    if exp.default_runs < 1:
        raise ValueError(f"{where}: default_runs must be at least 1, got {exp.default_runs}")
    keys = [c.key for c in exp.conditions]
    if not keys or len(set(keys)) != len(keys):
        raise ValueError(f"{where}: needs conditions, each once")
    for c in exp.conditions:
        if c.world not in WORLDS:
            raise ValueError(f"{where}: condition {c.label}: unknown world '{c.world}'")
        if exp.run_function is episode_run and c.method not in METHODS:
            raise ValueError(f"{where}: condition {c.label}: {METHODS.unknown(c.method)}")


EXPERIMENTS: Registry[Experiment] = Registry(
    "experiment",
    (
        Experiment(
            "fig3",
            "behaviour accuracy and success vs observability × observation time",
            _fig3(),
            episode_run,
        ),
        Experiment("fig4a", "success and timed-out rates of every method", _fig4a(), episode_run),
        Experiment(
            "fig4b",
            "learned feature probabilities, J's left wheel damaged",
            _features("boyd2"),
            episode_run,
        ),
        Experiment(
            "fig4c",
            "learned feature probabilities, healthy patrollers",
            _features("boyd2-healthy"),
            episode_run,
        ),
        Experiment(
            "table1", "the physical-runs table on the grid simulator at 14%", _table1(), episode_run
        ),
        Experiment(
            "verdicts",
            "calibration of the fault verdicts in both worlds: no damage and each wheel damaged",
            _verdicts(),
            episode_run,
            default_runs=10,
        ),
        Experiment(
            "atlas",
            "calibration atlas of the fault verdicts: worlds, data paths, faults, views, lengths",
            tuple(Condition(**p) for p in atlas_design()),
            atlas_run,
            default_runs=1,
        ),
        Experiment(
            "selftest",
            "built-in smoke test with a fake run",
            _selftest(),
            selftest_run,
            default_runs=6,
            hidden=True,
        ),
    ),
    check=_check_experiment,
)
"""Every experiment by name, in the order of the paper's figures (docs/design.md, "The paper's
experiments as data")."""


def experiment_names(include_hidden: bool = False) -> list[str]:
    """The experiments' names, in the table's order.

    Parameters
    ----------
    include_hidden : bool, default False
        Whether to list the hidden smoke experiments too.

    Returns
    -------
    list of str
        The names.
    """
    return [n for n, e in EXPERIMENTS.items() if include_hidden or not e.hidden]


def get_experiment(name: str) -> Experiment:
    """The experiment ``name``; a :class:`StoreError` naming the nearest and the listed ones
    otherwise (hidden experiments run when named, and are not offered).

    Parameters
    ----------
    name : str
        The experiment's name.

    Returns
    -------
    Experiment
        Its row of :data:`EXPERIMENTS`.

    Raises
    ------
    StoreError
        If no experiment has that name.
    """
    if name not in EXPERIMENTS:
        raise StoreError(str(EXPERIMENTS.unknown(name, known=experiment_names())))
    return EXPERIMENTS[name]


class StoreError(ValueError):
    """A problem with an experiment's request or its results directory (one-line message)."""


def with_em_init(exp: Experiment, init: str | None) -> Experiment:
    """``exp`` with DBN-EM's initialisation set on its dbn-em conditions (None: unchanged)."""
    if init is None:
        return exp
    if not any(METHODS[c.method].uses_em_init for c in exp.conditions):
        raise StoreError(f"`em_init`: experiment {exp.name} has no dbn-em runs to initialise")
    conditions = tuple(
        replace(c, em_init=init) if METHODS[c.method].uses_em_init else c for c in exp.conditions
    )
    return replace(exp, conditions=conditions)


def with_protocol(exp: Experiment, go_rule: str, relearn: bool) -> Experiment:
    """``exp`` with every condition deciding by ``go_rule`` and, with ``relearn``, re-learning
    while L waits (the command line's default: ``"adaptive"``, True); ``go_rule="value",
    relearn=False`` is the paper's protocol, the one the experiments' conditions are listed
    under."""
    rule = None if go_rule == GO_RULE_PUBLISHED else go_rule
    if rule is None and not relearn:
        return exp
    if exp.run_function is not episode_run:
        if (go_rule, relearn) == (GO_RULE_DEFAULT, True):
            return exp  # nothing of L decides or learns: the default asks for nothing
        raise StoreError(f"`go_rule`: experiment {exp.name} has no runs of L to decide")
    conditions = tuple(replace(c, go_rule=rule, relearn=relearn) for c in exp.conditions)
    return replace(exp, conditions=conditions)
