"""Scenarios as data: map, patrollers (starts, true feature probabilities, reward weights), the
interaction game and its played equilibrium, L's start and goal, detection and observability.

A scenario loads from a TOML file or a shipped name (see ``data/scenarios``); every problem is a
:class:`ScenarioError` whose one-line message names the file and the field.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from mirl.mdp import TabularMDP, value_iteration
from mirl.world import schema
from mirl.world._resources import read_shipped_or_file, shipped_names
from mirl.world.domain import DEFAULT_FEATURE_MAP, FeatureMap, PatrolDomain
from mirl.world.faults import HEALTHY_PROBABILITIES, DamageDefinition, read_faults
from mirl.world.game import Equilibrium, InteractionGame
from mirl.world.maps import GridMap
from mirl.world.motion import ERROR_MODELS, transition_matrix
from mirl.world.rewards import RewardSpec, read_reward_spec, read_weights
from mirl.world.scenario_sections import (
    PLAYED,
    TRUE_WEIGHTS,
    RobotSpec,
    read_feature_map,
    read_game,
    read_map,
    read_pairs,
    read_robots,
)
from mirl.world.world_sections import WORLD_SECTIONS

__all__ = [
    "RobotSpec",
    "Scenario",
    "ScenarioError",
    "load_scenario",
    "as_scenario",
    "shipped_scenarios",
    "HEALTHY_PROBABILITIES",
    "TRUE_WEIGHTS",
]


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message names the file and the field."""


@dataclass(frozen=True, eq=False)
class Scenario:
    """A scenario: the map, the patrollers, their game, and L's task and view.

    Load one with :func:`load_scenario`; the fields are the TOML file's (docs/design.md,
    "Scenarios"), checked when it loads.

    Parameters
    ----------
    name : str
        The scenario's name; it heads reports and run headers.
    map : GridMap
        The map.
    robots : tuple of RobotSpec
        The patrollers: starts, true transition-feature probabilities, true reward weights.
    feature_map : FeatureMap, default DEFAULT_FEATURE_MAP
        The transition features ξ of every (state, action).
    reward_spec : RewardSpec, default RewardSpec()
        The reward features φ (the paper's four by default).
    game : InteractionGame, default InteractionGame()
        The game played when two patrollers meet (the paper's by default).
    played : (str, str), default ("stop", "go")
        The pure equilibrium met robots play, row player first.
    pair_played : mapping of (int, int) to (str, str), default {}
        Per pair (i < j, i the game's row player) the equilibrium it plays, if not ``played``.
    observer_start : (int, int), optional
        L's start cell; the map's mark by default.
    goal : (int, int), optional
        L's goal cell; the map's first goal by default.
    detect_distance : int, default 6
        Cells a patroller sees straight ahead.
    observability : float, default 0.14
        The fraction of the hallway L sees (the paper's L at its door).
    discount : float, default 0.95
        The patrollers' discount γ.
    error_model : {"uniform", "stop"}, default "uniform"
        Where a failed step goes (:func:`~mirl.world.motion.transition_matrix_from_success`).
    source : str, default "<memory>"
        The file it came from, for messages.
    sections : mapping of str to mapping, default {}
        The worlds' own tables (``[physics]``) as written, by name; each world reads its own.
    faults : DamageDefinition, default DamageDefinition()
        What "damaged" means for its robots' parts.

    Raises
    ------
    ScenarioError
        An unknown error model.
    UnknownNameError
        A world section the format does not know.
    """

    name: str
    map: GridMap
    robots: tuple[RobotSpec, ...]
    feature_map: FeatureMap = DEFAULT_FEATURE_MAP
    reward_spec: RewardSpec = field(default_factory=RewardSpec)
    game: InteractionGame = field(default_factory=InteractionGame)
    played: tuple[str, str] = PLAYED
    # per pair (i < j, i the game's row player) the equilibrium it plays, if not ``played``
    pair_played: Mapping[tuple[int, int], tuple[str, str]] = field(default_factory=dict)
    observer_start: tuple[int, int] | None = None
    goal: tuple[int, int] | None = None
    # the defaults of a scenario file's top-level keys, read here by _from_dict
    detect_distance: int = 6  # cells
    observability: float = 0.14  # the paper's L at its door
    discount: float = 0.95
    error_model: str = "uniform"
    source: str = "<memory>"
    # the worlds' own tables ([physics]) as written, by name; each world reads its own
    sections: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    faults: DamageDefinition = field(default_factory=DamageDefinition)  # what "damaged" means

    def __post_init__(self) -> None:
        if self.observer_start is None:
            object.__setattr__(self, "observer_start", self.map.observer_start)
        if self.goal is None:
            object.__setattr__(self, "goal", self.map.goals[0])
        # the map's own L and G marks are defaults: the scenario's map carries its start and
        # goal, so that L's view, plans, reports and drawings all read the same ones
        start, goal = self.observer_start, self.goal
        object.__setattr__(self, "map", self.map.with_observer(start, goal))  # type: ignore[arg-type]
        if self.error_model not in ERROR_MODELS:
            raise ScenarioError(
                f"{self.source}: error_model: '{self.error_model}' is not one of {ERROR_MODELS}"
            )
        for name in self.sections:
            WORLD_SECTIONS.lookup(name)  # a world section the format does not know: refused

    @property
    def robot_names(self) -> tuple[str, ...]:
        """The patrollers' names, in order."""
        return tuple(r.name for r in self.robots)

    def robot_index(self, name: str) -> int:
        """The index of the patroller called ``name``.

        Parameters
        ----------
        name : str
            One of :attr:`robot_names`.

        Returns
        -------
        int
            Its index in :attr:`robots`.

        Raises
        ------
        ValueError
            An unknown name (the message lists the scenario's).
        """
        try:
            return self.robot_names.index(name)
        except ValueError:
            known = ", ".join(self.robot_names)
            raise ValueError(f"unknown robot '{name}' (scenario has {known})") from None

    @cached_property
    def domain(self) -> PatrolDomain:
        """The patrol domain of the scenario's map, ξ and φ."""
        return PatrolDomain(self.map, self.feature_map, self.reward_spec)

    @cached_property
    def played_equilibrium(self) -> Equilibrium:
        """The equilibrium ``played`` names, as probabilities."""
        return self.game.pure(*self.played)

    def pair_equilibrium(self, i: int, j: int) -> Equilibrium:
        """The equilibrium robots i < j play when they meet (i is the game's row player).

        Parameters
        ----------
        i : int
            The first robot's index.
        j : int
            The second's, above ``i``.

        Returns
        -------
        Equilibrium
            Their pair's own, or :attr:`played_equilibrium`.
        """
        if (i, j) in self.pair_played:
            return self.game.pure(*self.pair_played[(i, j)])
        return self.played_equilibrium

    @property
    def pairs(self) -> tuple[tuple[int, int], ...]:
        """Every pair (i, j) of patrollers with i < j, in order."""
        n = len(self.robots)
        return tuple((i, j) for i in range(n) for j in range(i + 1, n))

    def true_transitions(self, robot: int) -> sp.csr_array:
        """A patroller's true transition function (Eq. 5 under its true feature probabilities).

        Parameters
        ----------
        robot : int
            The patroller's index.

        Returns
        -------
        scipy.sparse.csr_array of shape (S*A, S)
            Its true T.
        """
        return self._true_models[robot][0]

    def true_policy(self, robot: int) -> np.ndarray:
        """Greedy optimal policy of ``robot`` under its true T and true reward.

        Parameters
        ----------
        robot : int
            The patroller's index.

        Returns
        -------
        ndarray of int, shape (S,)
            An action per state.
        """
        return self._true_models[robot][1].policy

    def true_q(self, robot: int) -> np.ndarray:
        """A patroller's optimal Q-values under its true T and true reward.

        Parameters
        ----------
        robot : int
            The patroller's index.

        Returns
        -------
        ndarray of shape (S, A)
            Q(s, a).
        """
        return self._true_models[robot][1].q_values

    @cached_property
    def _true_models(self):
        out = []
        for r in self.robots:
            T = transition_matrix(self.domain, r.feature_probabilities, self.error_model)
            res = value_iteration(TabularMDP(T, self.domain.rewards(r.weights), self.discount))
            out.append((T, res))
        return out

    def patrol_route(self, robot: int, max_steps: int | None = None) -> np.ndarray:
        """The cells ``robot`` visits from its start by its true policy when every action succeeds.

        Parameters
        ----------
        robot : int
            The patroller's index.
        max_steps : int, optional
            At most this many steps; S (four per patroller cell) by default.

        Returns
        -------
        ndarray of int, shape (k, 2)
            (row, col) of the cells, until a state repeats (its patrol loop) or ``max_steps`` have
            passed.
        """
        dom = self.domain
        state = int(dom.state_index(*self.robots[robot].start))
        policy, intended = self.true_policy(robot), dom.intended
        limit = dom.n_states if max_steps is None else max_steps
        seen, states = {state}, [state]
        for _ in range(limit):
            state = int(intended[state, policy[state]])
            states.append(state)
            if state in seen:
                break
            seen.add(state)
        return dom.states[np.asarray(states), :2]

    def with_damage(self, robot: str, feature: str, probability: float) -> Scenario:
        """A copy with one true feature probability overridden (``--damage I:right_wheel=0.7``).

        Parameters
        ----------
        robot : str
            The patroller's name.
        feature : str
            A transition feature.
        probability : float
            Its new success probability, in [0, 1].

        Returns
        -------
        Scenario
            The copy.

        Raises
        ------
        ValueError
            An unknown robot or feature, or a probability outside [0, 1].
        """
        i = self.robot_index(robot)
        if feature not in self.feature_map.features:
            known = ", ".join(self.feature_map.features)
            raise ValueError(f"unknown transition feature '{feature}' (known: {known})")
        if not 0.0 <= probability <= 1.0:
            raise ValueError(f"probability for {robot}:{feature} must be in [0, 1]")
        robots = list(self.robots)
        probs = dict(robots[i].feature_probabilities)
        probs[feature] = float(probability)
        robots[i] = replace(robots[i], feature_probabilities=probs)
        return replace(self, robots=tuple(robots))

    def modelled_with(
        self,
        feature_map: FeatureMap,
        faults: DamageDefinition | None = None,
        error_model: str | None = None,
    ) -> Scenario:
        """The same robots with their motion modelled by another ξ.

        The true transitions follow ``feature_map``; the true policies (and Q-values) stay this
        scenario's, because the robots behave as they do whatever model of their motion an observer
        takes.

        Parameters
        ----------
        feature_map : FeatureMap
            The ξ the true transitions follow.
        faults : DamageDefinition, optional
            Read their damage this way; this scenario's by default.
        error_model : {"uniform", "stop"}, optional
            Where a failed step goes; this scenario's by default.

        Returns
        -------
        Scenario
            The remodelled copy.
        """
        model = replace(
            self,
            feature_map=feature_map,
            faults=self.faults if faults is None else faults,
            error_model=self.error_model if error_model is None else error_model,
        )
        behaviour = self._true_models
        T = [
            transition_matrix(model.domain, r.feature_probabilities, model.error_model)
            for r in self.robots
        ]
        # fills the cached property: the policies are this scenario's, not re-solved under ξ
        model.__dict__["_true_models"] = [(t, b[1]) for t, b in zip(T, behaviour, strict=True)]
        return model

    def section(self, name: str) -> Mapping[str, Any]:
        """The world section ``name`` as written in the scenario.

        Parameters
        ----------
        name : str
            A table of :data:`~mirl.world.world_sections.WORLD_SECTIONS`.

        Returns
        -------
        mapping
            The table; empty when the file has none.

        Raises
        ------
        UnknownNameError
            A section the scenario format does not know.
        """
        WORLD_SECTIONS.lookup(name)
        return self.sections.get(name, {})

    def with_section(self, name: str, table: Mapping[str, Any]) -> Scenario:
        """A copy whose world section ``name`` is ``table``.

        Parameters
        ----------
        name : str
            A table of :data:`~mirl.world.world_sections.WORLD_SECTIONS`.
        table : mapping
            Its new contents (the world checks them when it reads them).

        Returns
        -------
        Scenario
            The copy.

        Raises
        ------
        UnknownNameError
            A section the scenario format does not know.
        """
        WORLD_SECTIONS.lookup(name)
        return replace(self, sections={**self.sections, name: table})

    def with_options(self, **changes: Any) -> Scenario:
        """A copy with some fields replaced (``dataclasses.replace``).

        Parameters
        ----------
        **changes
            Field names and their new values.

        Returns
        -------
        Scenario
            The copy, checked as a new scenario is.
        """
        return replace(self, **changes)


# ---- loading ---------------------------------------------------------------------------------
def shipped_scenarios() -> list[str]:
    """The names of the scenarios shipped with mirl.

    Returns
    -------
    list of str
        Names :func:`load_scenario` accepts as they are.
    """
    return shipped_names("scenarios", ".toml")


def as_scenario(scenario: Scenario | str | Path) -> Scenario:
    """``scenario`` itself, or the scenario a shipped name or a path names.

    Parameters
    ----------
    scenario : Scenario, str or Path
        A scenario, a shipped scenario's name, or a TOML file's path.

    Returns
    -------
    Scenario
        The scenario.

    Raises
    ------
    TypeError
        Anything else.
    ScenarioError
        A name or file that does not load.
    """
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, str | Path):
        return load_scenario(scenario)
    raise TypeError(f"scenario must be a Scenario, a shipped name or a path, got {type(scenario)}")


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a shipped scenario by name or a scenario TOML file.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped scenario's name (:func:`shipped_scenarios`) or a file's path; a relative map
        path in the file is read relative to the file.

    Returns
    -------
    Scenario
        The scenario, every field checked.

    Raises
    ------
    ScenarioError
        Any problem, in one line naming the file and the field.
    """
    text, source, path = read_shipped_or_file(
        name_or_path, "scenarios", ".toml", ScenarioError, "scenario"
    )
    try:
        return _from_text(text, source, base=None if path is None else path.parent)
    except ScenarioError as exc:
        if path is None or path.suffix.lower() not in MAP_SUFFIXES:
            raise
        # a map given where a scenario goes fails as TOML or as a scenario without its fields,
        # neither of which says what the file is
        raise ScenarioError(
            f"{exc}; {path.name} looks like a map, not a scenario: a scenario is a .toml file "
            f'that names its map (map = "{path.name}")'
        ) from None


MAP_SUFFIXES = (".txt", ".yaml", ".yml", ".pgm")
"""Suffixes of map files (text maps and ROS map_server maps), which a scenario file is not."""


def _from_text(text: str, source: str, base: Path | None) -> Scenario:
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
        raise ScenarioError(f"{source}: invalid TOML ({msg})") from None
    try:
        return _from_dict(data, source, base)
    except ScenarioError:
        raise
    except (ValueError, TypeError, KeyError) as exc:
        msg = str(exc.args[0]) if exc.args else exc.__class__.__name__
        raise ScenarioError(f"{source}: {msg.splitlines()[0] if msg else msg}") from None


_FIELD_DEFAULTS = {f.name: f.default for f in fields(Scenario)}

_TOP_KEYS = (
    "name",
    "map",
    "discount",
    "error_model",
    "observability",
    "detect_distance",
    "observer",
    "reward",
    "transition_features",
    "game",
    "robots",
    "frame",
    "faults",
)


def _observer(data: Any, gridmap: GridMap) -> tuple[tuple[int, int], tuple[int, int]]:
    """L's start and goal: free cells of the map, not the same cell."""
    observer = schema.table(data, "observer", ("start", "goal"))
    spots = {}
    for key, default in (("start", gridmap.observer_start), ("goal", gridmap.goals[0])):
        if key not in observer and not gridmap.marked:
            raise schema.FieldError(
                "observer", f"missing field '{key}' (the map {gridmap.name} does not mark L's)"
            )
        spot = (
            schema.cell(observer[key], f"observer.{key}", gridmap.shape, frame=gridmap.frame)
            if key in observer
            else default
        )
        if not gridmap.free[spot]:
            raise schema.FieldError(
                f"observer.{key}", f"{list(spot)} is not a free cell of the map"
            )
        spots[key] = (int(spot[0]), int(spot[1]))
    if spots["start"] == spots["goal"]:
        raise schema.FieldError("observer.goal", f"{list(spots['goal'])} is L's start cell")
    # L drives between side-adjacent free cells (its room's and the hallways'): a goal in
    # another connected piece of the map is one no plan reaches
    pieces = gridmap.free_pieces()
    if pieces[spots["start"]] != pieces[spots["goal"]]:
        raise schema.FieldError(
            "observer.goal",
            f"{list(spots['goal'])} cannot be reached from L's start {list(spots['start'])}: "
            "no path of free cells joins them",
        )
    return spots["start"], spots["goal"]


def _given(data: dict, key: str) -> Any:
    """The file's ``key``, or the default the :class:`Scenario` field of that name declares."""
    return data[key] if key in data else _FIELD_DEFAULTS[key]


def _from_dict(data: dict, source: str, base: Path | None) -> Scenario:
    """Every section read and validated in file order (:mod:`mirl.world.scenario_sections`);
    a world's own section is kept as written, a table, for that world to read."""
    schema.table(data, "", (*_TOP_KEYS, *WORLD_SECTIONS.names))
    gridmap = read_map(data, base)
    shape = gridmap.shape
    sections = {
        name: schema.table(data[name], name, data[name] if isinstance(data[name], dict) else ())
        for name in WORLD_SECTIONS
        if name in data
    }
    feature_map = DEFAULT_FEATURE_MAP
    if "transition_features" in data:
        feature_map = read_feature_map(data["transition_features"], gridmap)
    reward = schema.table(data.get("reward", {}), "reward", ("features", "weights",
                          "upper_hallway", "lower_hallway", "turn_around"))  # fmt: skip
    reward_spec, legacy = read_reward_spec(reward, shape, gridmap)
    domain = PatrolDomain(gridmap, feature_map, reward_spec)
    for k, f in enumerate(reward_spec.features):
        for cell in f.cells or ():
            if domain.state_index(*cell, 0) < 0:
                where = f"reward.{f.name}" if legacy else f"reward.features[{k}].cells"
                raise schema.FieldError(where, f"{list(cell)} is not a hallway cell")
    base_w = read_weights(
        reward.get("weights", {}),
        "reward.weights",
        reward_spec.names,
        TRUE_WEIGHTS if legacy else {},
    )
    robots = read_robots(data.get("robots"), domain, reward_spec, base_w)
    game, played, pairs = read_game(data.get("game", {}))
    try:
        game.pure(*played)
    except ValueError as exc:
        raise schema.FieldError("game.played", str(exc)) from None
    start, goal = _observer(data.get("observer", {}), gridmap)
    name = schema.string(data["name"], "name") if "name" in data else Path(source).stem
    if not name.strip() or "\n" in name or "\r" in name:  # it heads reports and run headers
        raise schema.FieldError(
            "name", f"{name!r} is not a usable scenario name (empty or multi-line)"
        )
    return Scenario(
        name=name,
        map=gridmap,
        robots=robots,
        feature_map=feature_map,
        reward_spec=reward_spec,
        game=game,
        played=played,
        pair_played=read_pairs(pairs, tuple(r.name for r in robots), game),
        observer_start=start,
        goal=goal,
        detect_distance=schema.integer(
            _given(data, "detect_distance"), "detect_distance", low=0, high=max(shape)
        ),  # fmt: skip
        observability=schema.number(
            _given(data, "observability"), "observability", low=0.0, high=1.0
        ),  # fmt: skip
        discount=schema.number(
            _given(data, "discount"), "discount", low=0.0, high=1.0, high_open=True
        ),  # fmt: skip
        error_model=schema.string(_given(data, "error_model"), "error_model", ERROR_MODELS),
        source=source,
        sections=sections,
        faults=read_faults(data.get("faults", {}), feature_map.features),
    )
