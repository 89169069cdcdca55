"""Reading the sections of a scenario TOML (see :mod:`mirl.world.scenario`) with the typed readers
of :mod:`mirl.world.schema`: each function takes the parsed table and returns plain values; every
problem is a :class:`~mirl.world.schema.FieldError` naming the field's path.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mirl.world import schema
from mirl.world.catalog import is_ros_map, load_map
from mirl.world.domain import FeatureMap, PatrolDomain
from mirl.world.faults import HEALTHY_PROBABILITIES
from mirl.world.game import GAME_ACTIONS, InteractionGame
from mirl.world.maps import GridMap, MapError, MapFrame
from mirl.world.rewards import RewardSpec, read_weights

__all__ = [
    "PLAYED",
    "TRUE_WEIGHTS",
    "RobotSpec",
    "read_map",
    "read_feature_map",
    "read_robots",
    "read_game",
    "read_pairs",
]

PLAYED = ("stop", "go")  # the equilibrium met robots play by default: the paper's (row stops)
TRUE_WEIGHTS = {"moved": 1.0, "upper_hallway": 0.05, "lower_hallway": 0.05, "turn_around": 0.3}
MAX_ROBOTS = 26  # a team, not a crowd: every pair is checked for meetings each step
OBSERVER_NAME = "L"
"""The observer's name: L's rows in a pose CSV, its agent in :class:`~mirl.envs.TeamEnv`; no
patroller may take it."""
UNNAMED_ROBOTS = "IJKMNOPQ"
"""The names of patrollers a scenario leaves unnamed, in order (the paper's I and J on, skipping
:data:`OBSERVER_NAME`); ``R8``, ``R9`` … after them."""
FieldError = schema.FieldError


@dataclass(frozen=True)
class RobotSpec:
    """A patroller as the scenario gives it.

    Parameters
    ----------
    name : str
        Its name.
    start : (int, int, int)
        Its start state (row, col, heading).
    feature_probabilities : mapping of str to float
        Its true success probability of every transition feature.
    weights : ndarray of shape (K,)
        Its true reward weights, over the domain's reward feature names.
    """

    name: str
    start: tuple[int, int, int]  # row, col, heading
    feature_probabilities: Mapping[str, float]
    weights: np.ndarray  # over the domain's reward feature names


def read_map(data: dict, base: Path | None) -> GridMap:
    """The scenario's map, placed in the metric frame of the optional ``[frame]`` table.

    The table holds ``cell_size`` (metres) and, for a text map, ``origin = [x, y]`` (the map-frame
    position of the centre of cell (0, 0)). A ROS map is discretised at ``cell_size`` and keeps the
    origin of its YAML.

    Parameters
    ----------
    data : dict
        The whole scenario as read from TOML.
    base : Path, optional
        The scenario file's folder; a relative map path is read relative to it.

    Returns
    -------
    GridMap
        The map.

    Raises
    ------
    FieldError
        A missing or unloadable map, or a bad frame, naming the field.
    """
    if "map" not in data:
        raise FieldError("map", "missing field")
    map_ref = schema.string(data["map"], "map")
    candidate = Path(map_ref)
    if base is not None and not candidate.is_absolute() and (base / candidate).exists():
        candidate = base / candidate
    source = map_ref if not candidate.is_file() else candidate
    frame = schema.table(data.get("frame", {}), "frame", ("cell_size", "origin"))
    cell_size = None
    if "cell_size" in frame:
        cell_size = schema.number(frame["cell_size"], "frame.cell_size")
    ros = is_ros_map(source)
    try:
        gridmap = load_map(source, cell_size=cell_size if ros else None)
    except (MapError, OSError, ValueError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else "cannot load"
        where = "frame.cell_size" if cell_size is not None and "`cell_size`" in message else "map"
        # the scenario's field, not the parameter (which the CLI would turn into a flag)
        raise FieldError(where, message.replace("`cell_size`", "cell_size")) from None
    if ros:
        if "origin" in frame:
            raise FieldError(
                "frame.origin", "a ROS map's frame is its YAML's 'origin'; give only cell_size"
            )
        return gridmap
    if not frame:
        return gridmap
    origin = schema.array(
        frame.get("origin", [gridmap.frame.origin_x, gridmap.frame.origin_y]),
        "frame.origin",
        length=2,
    )
    x, y = (schema.number(v, f"frame.origin[{i}]") for i, v in enumerate(origin))
    try:
        placed = MapFrame(gridmap.frame.cell_size if cell_size is None else cell_size, x, y)
    except MapError as exc:
        raise FieldError("frame", str(exc)) from None
    return replace(gridmap, frame=placed)


def read_feature_map(data: Any, gridmap: GridMap) -> FeatureMap:
    """The ``[transition_features]`` table (ξ as data, :class:`~mirl.world.domain.FeatureMap`).

    An override's cells must be hallway cells (elsewhere no patroller acts, so it would be
    silently without effect).

    Parameters
    ----------
    data : object
        The table as read from TOML.
    gridmap : GridMap
        The scenario's map.

    Returns
    -------
    FeatureMap
        ξ.

    Raises
    ------
    FieldError
        A problem, naming the field.
    """
    feature_map = FeatureMap.from_dict(data, shape=gridmap.shape, frame=gridmap.frame)
    for i, override in enumerate(feature_map.overrides):
        for k, (r, c) in enumerate(override.cells or ()):
            if not gridmap.patroller[r, c]:
                where = f"transition_features.override[{i}].cells[{k}]"
                raise FieldError(where, f"[{r}, {c}] is not a hallway cell")
    return feature_map


def _probabilities(value: Any, where: str, features: tuple[str, ...]) -> dict[str, float]:
    value = schema.table(value, where, features)
    out = dict(HEALTHY_PROBABILITIES) if set(features) >= set(HEALTHY_PROBABILITIES) else {}
    out = {k: v for k, v in out.items() if k in features}
    for k, v in value.items():
        out[k] = schema.number(v, f"{where}.{k}", low=0.0, high=1.0)
    missing = [f for f in features if f not in out]
    if missing:
        raise FieldError(where, f"no probability for feature '{missing[0]}'")
    return out


def read_robots(
    data: Any,
    domain: PatrolDomain,
    reward: RewardSpec,
    base_weights: Mapping[str, float],
) -> tuple[RobotSpec, ...]:
    """``[[robots]]``: names, hallway starts, true feature probabilities and reward weights.

    Parameters
    ----------
    data : object
        The list as read from TOML (2 to 26 robots).
    domain : PatrolDomain
        The domain their starts must be states of.
    reward : RewardSpec
        The reward features their weights are over.
    base_weights : mapping of str to float
        The ``[reward] weights`` table, which each robot's own ``weights`` update.

    Returns
    -------
    tuple of RobotSpec
        The patrollers, in file order.

    Raises
    ------
    FieldError
        A problem, naming the field.
    """
    items = schema.array(data, "robots", min_length=2)
    if len(items) > MAX_ROBOTS:
        raise FieldError("robots", f"at most {MAX_ROBOTS} patrollers, got {len(items)}")
    names = reward.names
    robots: list[RobotSpec] = []
    for i, rd in enumerate(items):
        where = f"robots[{i}]"
        rd = schema.table(rd, where, ("name", "start", "feature_probabilities", "weights"))
        if "name" in rd:
            name = schema.name(rd["name"], f"{where}.name", "robot")
        else:
            name = UNNAMED_ROBOTS[i : i + 1] or f"R{i}"
        if "start" not in rd:
            raise FieldError(where, "missing field 'start'")
        start = schema.cell(
            rd["start"], f"{where}.start", domain.map.shape, n=3, frame=domain.map.frame
        )
        if domain.state_index(*start) < 0:
            raise FieldError(f"{where}.start", f"{list(start)} is not a hallway cell")
        same = [k for k, r in enumerate(robots) if r.start == start]
        if same:  # two robots cannot stand in one state (in physics they would overlap)
            raise FieldError(f"{where}.start", f"{list(start)} is robots[{same[0]}]'s start too")
        probs = _probabilities(
            rd.get("feature_probabilities", {}),
            f"{where}.feature_probabilities",
            domain.feature_map.features,
        )
        w = read_weights(rd.get("weights", {}), f"{where}.weights", names, base_weights)
        missing = [k for k in names if k not in w]
        if missing:
            raise FieldError(  # the weight may belong in either table: name both
                f"{where}.weights",
                f"no weight for reward feature '{missing[0]}' (neither reward.weights nor "
                f"{where}.weights gives one)",
            )
        if name in [r.name for r in robots]:
            raise FieldError(f"{where}.name", f"duplicate robot name '{name}'")
        if name == OBSERVER_NAME:
            raise FieldError(
                f"{where}.name", f"'{name}' is the observer's name; a patroller needs another"
            )
        robots.append(RobotSpec(name, start, probs, np.array([w[k] for k in names])))
    return tuple(robots)


def _payoffs(value: Any, where: str) -> np.ndarray:
    rows = schema.array(value, where, length=3)
    return np.array(
        [
            [
                schema.number(x, f"{where}[{i}][{j}]")
                for j, x in enumerate(schema.array(r, f"{where}[{i}]", length=3))
            ]
            for i, r in enumerate(rows)
        ]
    )


def _played(value: Any, where: str) -> tuple[str, str]:
    items = schema.array(value, where, length=2)
    a, b = (schema.string(v, f"{where}[{i}]", GAME_ACTIONS) for i, v in enumerate(items))
    return a, b


def read_game(data: Any) -> tuple[InteractionGame, tuple[str, str], list]:
    """``[game]``: payoffs, the played equilibrium and the raw per-pair list (``pairs``).

    Parameters
    ----------
    data : object
        The table as read from TOML.

    Returns
    -------
    game : InteractionGame
        The game.
    played : (str, str)
        The equilibrium met robots play.
    pairs : list
        The ``pairs`` entries as written, for :func:`read_pairs`.

    Raises
    ------
    FieldError
        A problem, naming the field.
    """
    game = schema.table(data, "game", ("row_payoffs", "col_payoffs", "played", "pairs"))
    kwargs = {
        k: _payoffs(game[k], f"game.{k}") for k in ("row_payoffs", "col_payoffs") if k in game
    }
    played = _played(game["played"], "game.played") if "played" in game else PLAYED
    return InteractionGame(**kwargs), played, schema.array(game.get("pairs", []), "game.pairs")


def read_pairs(
    items: list, names: tuple[str, ...], game: InteractionGame
) -> dict[tuple[int, int], tuple[str, str]]:
    """``[[game.pairs]]``: ``robots = [A, B]`` and ``played = [a, b]`` (A plays a).

    Parameters
    ----------
    items : list
        The entries as written.
    names : tuple of str
        The robots' names.
    game : InteractionGame
        The game whose equilibria they must be.

    Returns
    -------
    dict of (int, int) to (str, str)
        Each pair's equilibrium, stored with the lower robot index as the game's row player.

    Raises
    ------
    FieldError
        An unknown robot, a robot paired with itself, a pair given twice, or a profile that is
        not an equilibrium.
    """
    out: dict[tuple[int, int], tuple[str, str]] = {}
    for k, item in enumerate(items):
        where = f"game.pairs[{k}]"
        item = schema.table(item, where, ("robots", "played"), ("robots", "played"))
        pair = schema.array(item["robots"], f"{where}.robots", length=2)
        idx = []
        for i, n in enumerate(pair):
            schema.string(n, f"{where}.robots[{i}]", names)
            idx.append(names.index(n))
        if idx[0] == idx[1]:
            raise FieldError(f"{where}.robots", "a robot does not meet itself")
        played = _played(item["played"], f"{where}.played")
        if idx[0] > idx[1]:
            idx, played = idx[::-1], (played[1], played[0])
        try:
            game.pure(*played)
        except ValueError as exc:
            raise FieldError(f"{where}.played", str(exc)) from None
        key = (idx[0], idx[1])
        if key in out:
            raise FieldError(f"{where}.robots", "this pair is given twice")
        out[key] = played
    return out
