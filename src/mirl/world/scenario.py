"""Scenarios as data: map, patrollers (starts, true feature probabilities, reward weights), the
interaction game and its played equilibrium, L's start and goal, detection and observability.

A scenario loads from a TOML file or a shipped name (see ``data/scenarios``); every problem is a
:class:`ScenarioError` whose one-line message names the file and the field.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from mirl.mdp import TabularMDP, value_iteration
from mirl.world._resources import read_shipped_or_file, shipped_names
from mirl.world.catalog import load_map
from mirl.world.domain import (
    DEFAULT_FEATURE_MAP,
    REWARD_FEATURES,
    FeatureMap,
    PatrolDomain,
    RewardSpec,
)
from mirl.world.game import GAME_ACTIONS, Equilibrium, InteractionGame
from mirl.world.maps import GridMap, MapError, MapFrame
from mirl.world.motion import ERROR_MODELS, transition_matrix

__all__ = [
    "RobotSpec",
    "Scenario",
    "ScenarioError",
    "load_scenario",
    "shipped_scenarios",
    "parse_damage",
    "HEALTHY_PROBABILITIES",
]

HEALTHY_PROBABILITIES = {"left_wheel": 0.95, "right_wheel": 0.95, "navigation": 0.97, "floor": 0.99}
TRUE_WEIGHTS = {"moved": 1.0, "upper_hallway": 0.05, "lower_hallway": 0.05, "turn_around": 0.3}


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message names the file and the field."""


@dataclass(frozen=True)
class RobotSpec:
    name: str
    start: tuple[int, int, int]  # row, col, heading
    feature_probabilities: Mapping[str, float]
    weights: np.ndarray  # over REWARD_FEATURES


@dataclass(frozen=True, eq=False)
class Scenario:
    name: str
    map: GridMap
    robots: tuple[RobotSpec, ...]
    feature_map: FeatureMap = DEFAULT_FEATURE_MAP
    reward_spec: RewardSpec = field(default_factory=RewardSpec)
    game: InteractionGame = field(default_factory=InteractionGame)
    played: tuple[str, str] = ("stop", "go")
    observer_start: tuple[int, int] | None = None
    goal: tuple[int, int] | None = None
    detect_distance: int = 6
    observability: float = 0.14
    discount: float = 0.95
    error_model: str = "uniform"
    source: str = "<memory>"
    physics: Mapping[str, Any] = field(default_factory=dict)  # [physics] table (mirl.physics)

    def __post_init__(self) -> None:
        if self.observer_start is None:
            object.__setattr__(self, "observer_start", self.map.observer_start)
        if self.goal is None:
            object.__setattr__(self, "goal", self.map.goals[0])
        if self.error_model not in ERROR_MODELS:
            raise ScenarioError(
                f"{self.source}: error_model: '{self.error_model}' is not one of {ERROR_MODELS}"
            )

    @property
    def robot_names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.robots)

    def robot_index(self, name: str) -> int:
        try:
            return self.robot_names.index(name)
        except ValueError:
            known = ", ".join(self.robot_names)
            raise ValueError(f"unknown robot '{name}' (scenario has {known})") from None

    @cached_property
    def domain(self) -> PatrolDomain:
        return PatrolDomain(self.map, self.feature_map, self.reward_spec)

    @cached_property
    def played_equilibrium(self) -> Equilibrium:
        return self.game.pure(*self.played)

    def true_transitions(self, robot: int) -> sp.csr_array:
        return self._true_models[robot][0]

    def true_policy(self, robot: int) -> np.ndarray:
        """Greedy optimal policy of ``robot`` under its true T and true reward, (S,)."""
        return self._true_models[robot][1].policy

    def true_q(self, robot: int) -> np.ndarray:
        return self._true_models[robot][1].q_values

    @cached_property
    def _true_models(self):
        out = []
        for r in self.robots:
            T = transition_matrix(self.domain, r.feature_probabilities, self.error_model)
            res = value_iteration(TabularMDP(T, self.domain.rewards(r.weights), self.discount))
            out.append((T, res))
        return out

    def with_damage(self, robot: str, feature: str, probability: float) -> Scenario:
        """A copy with one true feature probability overridden (``--damage I:right_wheel=0.7``)."""
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

    def with_options(self, **changes: Any) -> Scenario:
        return replace(self, **changes)


def parse_damage(text: str) -> tuple[str, str, float]:
    """Parse ``ROBOT:FEATURE=P``."""
    try:
        robot, rest = text.split(":", 1)
        feature, value = rest.split("=", 1)
        return robot.strip(), feature.strip(), float(value)
    except ValueError:
        raise ValueError(
            f"--damage '{text}': expected ROBOT:FEATURE=P, e.g. J:left_wheel=0.7"
        ) from None


# ---- loading ---------------------------------------------------------------------------------
def shipped_scenarios() -> list[str]:
    return shipped_names("scenarios", ".toml")


def load_scenario(name_or_path: str | Path) -> Scenario:
    text, source, path = read_shipped_or_file(
        name_or_path, "scenarios", ".toml", ScenarioError, "scenario"
    )
    return _from_text(text, source, base=None if path is None else path.parent)


def _from_text(text: str, source: str, base: Path | None) -> Scenario:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: invalid TOML ({exc})") from None
    try:
        return _from_dict(data, source, base)
    except ScenarioError:
        raise
    except MapError as exc:
        raise ScenarioError(f"{source}: map: {exc}") from None
    except (ValueError, TypeError, KeyError) as exc:
        msg = exc.args[0] if exc.args else exc.__class__.__name__
        raise ScenarioError(f"{source}: {msg}") from None


def _cell(value: Any, where: str, n: int = 2) -> Any:  # tuple of n ints (n = 2 or 3)
    if (
        not isinstance(value, list | tuple)
        or len(value) != n
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    ):
        raise ValueError(f"{where}: expected a list of {n} integers, got {value!r}")
    return tuple(value)


def _region(value: Any, where: str) -> tuple[tuple[int, int], ...]:
    """A region is a list of cells, or {from=[r,c], to=[r,c]} for an inclusive rectangle."""
    if isinstance(value, dict):
        (r0, c0), (r1, c1) = (
            _cell(value.get("from"), f"{where}.from"),
            _cell(value.get("to"), f"{where}.to"),
        )
        return tuple(
            (r, c)
            for r in range(min(r0, r1), max(r0, r1) + 1)
            for c in range(min(c0, c1), max(c0, c1) + 1)
        )
    if not isinstance(value, list):
        raise ValueError(f"{where}: expected a list of cells or {{from=[r,c], to=[r,c]}}")
    return tuple(_cell(v, f"{where}[{i}]") for i, v in enumerate(value))


def _probabilities(value: Any, where: str, features: tuple[str, ...]) -> dict[str, float]:
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected a table of feature = probability")
    out = dict(HEALTHY_PROBABILITIES) if set(features) >= set(HEALTHY_PROBABILITIES) else {}
    for k, v in value.items():
        if k not in features:
            raise ValueError(
                f"{where}.{k}: unknown transition feature (known: {', '.join(features)})"
            )
        if not isinstance(v, int | float) or not 0.0 <= float(v) <= 1.0:
            raise ValueError(f"{where}.{k}: probability must be a number in [0, 1], got {v!r}")
        out[k] = float(v)
    missing = [f for f in features if f not in out]
    if missing:
        raise ValueError(f"{where}: no probability for feature '{missing[0]}'")
    return out


def _weights(value: Any, where: str) -> np.ndarray:
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected a table of reward feature = weight")
    w = dict(TRUE_WEIGHTS)
    for k, v in value.items():
        if k not in REWARD_FEATURES:
            known = ", ".join(REWARD_FEATURES)
            raise ValueError(f"{where}.{k}: unknown reward feature (known: {known})")
        if not isinstance(v, int | float):
            raise ValueError(f"{where}.{k}: weight must be a number, got {v!r}")
        w[k] = float(v)
    return np.array([w[k] for k in REWARD_FEATURES])


def _table(value: Any, where: str, keys: set[str]) -> dict:
    """A TOML table with only known keys: a misspelt key must not be silently ignored."""
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected a table, got {value!r}")
    unknown = set(value) - keys
    if unknown:
        known = ", ".join(sorted(keys))
        raise ValueError(f"{where}.{sorted(unknown)[0]}: unknown field (known: {known})")
    return value


_TOP_KEYS = {
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
    "physics",
}


def _map_from_dict(data: dict, base: Path | None) -> GridMap:
    """The scenario's map (relative paths are relative to the scenario file), placed in the
    metric frame of the optional ``[frame]`` table (``cell_size``, ``origin = [x, y]``: the
    map-frame position of the centre of cell (0, 0))."""
    if "map" not in data:
        raise ValueError("missing field 'map'")
    map_ref = str(data["map"])
    candidate = Path(map_ref)
    if base is not None and not candidate.is_absolute() and (base / candidate).exists():
        candidate = base / candidate
    gridmap = load_map(map_ref if not candidate.exists() else candidate)
    if "frame" not in data:
        return gridmap
    frame = _table(data["frame"], "frame", {"cell_size", "origin"})
    cell_size = frame.get("cell_size", gridmap.frame.cell_size)
    if isinstance(cell_size, bool) or not isinstance(cell_size, int | float):
        raise ValueError(f"frame.cell_size: expected a number of metres, got {cell_size!r}")
    origin = frame.get("origin", [gridmap.frame.origin_x, gridmap.frame.origin_y])
    if (
        not isinstance(origin, list)
        or len(origin) != 2
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in origin)
    ):
        raise ValueError(f"frame.origin: expected [x, y] in metres, got {origin!r}")
    try:
        placed = MapFrame(float(cell_size), float(origin[0]), float(origin[1]))
    except MapError as exc:
        raise ValueError(f"frame: {exc}") from None
    return replace(gridmap, frame=placed)


def _from_dict(data: dict, source: str, base: Path | None) -> Scenario:
    """Long because every section of the scenario is read and validated in file order."""
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise ValueError(f"unknown field '{sorted(unknown)[0]}'")
    gridmap = _map_from_dict(data, base)
    feature_map = DEFAULT_FEATURE_MAP
    if "transition_features" in data:
        feature_map = FeatureMap.from_dict(data["transition_features"])
    reward = _table(
        data.get("reward", {}),
        "reward",
        {"upper_hallway", "lower_hallway", "turn_around", "weights"},
    )
    reward_spec = RewardSpec(
        upper_hallway=_region(reward.get("upper_hallway", []), "reward.upper_hallway"),
        lower_hallway=_region(reward.get("lower_hallway", []), "reward.lower_hallway"),
        turn_around=(
            _region(reward["turn_around"], "reward.turn_around")
            if "turn_around" in reward
            else None
        ),
    )
    default_w = _weights(reward.get("weights", {}), "reward.weights")
    robots_data = data.get("robots")
    if not isinstance(robots_data, list) or len(robots_data) < 2:
        raise ValueError("robots: need at least two [[robots]] entries")
    robots = []
    probe = PatrolDomain(gridmap, feature_map, reward_spec)
    for label, cells in (
        ("reward.upper_hallway", reward_spec.upper_hallway),
        ("reward.lower_hallway", reward_spec.lower_hallway),
        ("reward.turn_around", reward_spec.turn_around or ()),
    ):
        for cell in cells:
            if probe.state_index(*cell, 0) < 0:
                raise ValueError(f"{label}: {cell} is not a hallway cell")
    for i, rd in enumerate(robots_data):
        where = f"robots[{i}]"
        rd = _table(rd, where, {"name", "start", "feature_probabilities", "weights"})
        name = str(rd.get("name", "IJKLMNOP"[i] if i < 8 else f"R{i}"))
        start = _cell(rd.get("start"), f"{where}.start", 3)
        if probe.state_index(*start) < 0:
            raise ValueError(f"{where}.start: {start} is not a hallway cell with heading 0-3")
        probs = _probabilities(
            rd.get("feature_probabilities", {}),
            f"{where}.feature_probabilities",
            feature_map.features,
        )
        weights = _weights(rd["weights"], f"{where}.weights") if "weights" in rd else default_w
        robots.append(RobotSpec(name, start, probs, weights))
    if len({r.name for r in robots}) != len(robots):
        raise ValueError("robots: duplicate robot name")
    game_data = _table(data.get("game", {}), "game", {"row_payoffs", "col_payoffs", "played"})
    game = InteractionGame(
        **{
            k: np.array(game_data[k], dtype=float)
            for k in ("row_payoffs", "col_payoffs")
            if k in game_data
        }
    )
    played = tuple(game_data.get("played", ("stop", "go")))
    if len(played) != 2 or any(a not in GAME_ACTIONS for a in played):
        raise ValueError(f"game.played: expected two of {GAME_ACTIONS}, got {list(played)}")
    observer = _table(data.get("observer", {}), "observer", {"start", "goal"})
    scenario = Scenario(
        name=str(data.get("name", Path(source).stem)),
        map=gridmap,
        robots=tuple(robots),
        feature_map=feature_map,
        reward_spec=reward_spec,
        game=game,
        played=played,  # type: ignore[arg-type]
        observer_start=_cell(observer["start"], "observer.start") if "start" in observer else None,
        goal=_cell(observer["goal"], "observer.goal") if "goal" in observer else None,
        detect_distance=int(data.get("detect_distance", 6)),
        observability=float(data.get("observability", 0.14)),
        discount=float(data.get("discount", 0.95)),
        error_model=str(data.get("error_model", "uniform")),
        source=source,
        physics=_table(data.get("physics", {}), "physics", set(data.get("physics", {}))),
    )
    try:
        scenario.played_equilibrium  # noqa: B018 - validate now, not mid-run
    except ValueError as exc:
        raise ValueError(f"game.played: {exc}") from None
    if not 0.0 <= scenario.observability <= 1.0:
        raise ValueError("observability: must be in [0, 1]")
    if not 0.0 <= scenario.discount < 1.0:
        raise ValueError("discount: must be in [0, 1)")
    placed: list[tuple[str, tuple[int, int] | None]] = [
        ("observer.start", scenario.observer_start),
        ("observer.goal", scenario.goal),
    ]
    for label, spot in placed:
        assert spot is not None  # filled from the map in Scenario.__post_init__
        if not gridmap.free[spot]:
            raise ValueError(f"{label}: {spot} is not a free cell of the map")
    return scenario
