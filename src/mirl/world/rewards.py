"""Reward features φ as data: a scenario names any number of features, each of a *kind*, and gives
every patroller its own true weights over them (so two robots can patrol different routes).

Kinds are the rows of :data:`KINDS`: the fields a scenario gives a feature of that kind and
what it rewards, in one place (``cells`` is a region: a list whose entries are cells ``[r, c]``
or inclusive rectangles ``{from = [r, c], to = [r, c]}``, or one such rectangle; on a map, a cell
may also be a point ``{x, y}`` in metres, and a rectangle covers the hallway cells inside it):

============================ ==================================================================
``moved``                    a forward that changes cell
``region``                   standing on one of ``cells`` (any action)
``turn_around``              a turn (left or right) on one of ``cells`` (default: the map's dead
                             ends, where a patrol must turn)
``heading_in_region``        standing on one of ``cells`` facing one of ``headings`` (names
                             ``east``/``north``/``west``/``south`` or 0-3), any action
============================ ==================================================================

The paper's four features (``moved``, ``upper_hallway``, ``lower_hallway``, ``turn_around``)
are :func:`hallway_features`, which the older ``[reward]`` keys of a scenario still produce.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mirl._registry import Registry
from mirl.world import schema
from mirl.world.actions import FORWARD, HEADING_NAMES, TURN_LEFT, TURN_RIGHT
from mirl.world.maps import GridMap, dead_ends

__all__ = [
    "KINDS",
    "FeatureKind",
    "RewardFeature",
    "RewardSpec",
    "hallway_features",
    "read_region",
    "read_reward_spec",
    "read_weights",
]

FIELDS = ("cells", "headings")  # what a feature may have besides its name and kind
LEGACY_KEYS = ("upper_hallway", "lower_hallway", "turn_around")
Cells = tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class RewardFeature:
    """One reward feature.

    Parameters
    ----------
    name : str
        Its name, the key of its weight.
    kind : str
        One of :data:`KINDS` (module doc).
    cells : tuple of (int, int), optional
        Its region; None for the kind's default.
    headings : tuple of int, default ()
        For ``heading_in_region``, the headings it rewards (0 east, 1 north, 2 west, 3 south).
    """

    name: str
    kind: str
    cells: Cells | None = None
    headings: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"reward feature '{self.name}': {KINDS.unknown(self.kind)}")


class StateSpace(Protocol):
    """What a kind needs of the domain to value its feature
    (:class:`~mirl.world.domain.PatrolDomain` is one)."""

    @property
    def n_states(self) -> int: ...

    @property
    def n_actions(self) -> int: ...

    @property
    def states(self) -> np.ndarray:
        """(S, 3): row, col, heading."""
        ...

    @property
    def intended(self) -> np.ndarray:
        """(S, A): ψ, the intended next state."""
        ...

    @property
    def map(self) -> GridMap: ...

    def state_cell(self, states: Any) -> np.ndarray: ...

    def cell_mask(self, cells: Sequence[tuple[int, int]]) -> np.ndarray: ...


@dataclass(frozen=True)
class FeatureKind:
    """One kind of reward feature.

    Parameters
    ----------
    name : str
        The ``kind`` a scenario writes.
    takes : tuple of str
        The fields a feature of this kind may have besides ``name`` and ``kind``.
    needs : tuple of str
        Those it must have.
    values : callable
        ``values(domain, feature)`` -> (S, A) array: the feature's value at every state and
        action of ``domain`` (a :class:`StateSpace`).
    """

    name: str
    takes: tuple[str, ...]
    needs: tuple[str, ...]
    values: Callable[[StateSpace, RewardFeature], np.ndarray]


def _moved(domain: StateSpace, feature: RewardFeature) -> np.ndarray:
    out = np.zeros((domain.n_states, domain.n_actions))
    cell_of = domain.state_cell(np.arange(domain.n_states))
    out[:, FORWARD] = domain.state_cell(domain.intended[:, FORWARD]) != cell_of
    return out


def _turn_around(domain: StateSpace, feature: RewardFeature) -> np.ndarray:
    out = np.zeros((domain.n_states, domain.n_actions))
    cells = dead_ends(domain.map) if feature.cells is None else feature.cells
    ends = domain.cell_mask(cells)
    out[:, TURN_LEFT] = ends
    out[:, TURN_RIGHT] = ends
    return out


def _region(domain: StateSpace, feature: RewardFeature) -> np.ndarray:
    mask = domain.cell_mask(feature.cells or ())
    return np.repeat(mask[:, None].astype(float), domain.n_actions, axis=1)


def _heading_in_region(domain: StateSpace, feature: RewardFeature) -> np.ndarray:
    mask = domain.cell_mask(feature.cells or ()) & np.isin(domain.states[:, 2], feature.headings)
    return np.repeat(mask[:, None].astype(float), domain.n_actions, axis=1)


def _check_kind(kind: FeatureKind) -> None:
    """A kind needs only fields it takes, of those a scenario's feature may have."""
    if not set(kind.needs) <= set(kind.takes) <= set(FIELDS):
        raise ValueError(
            f"reward-feature kind '{kind.name}': takes {kind.takes} and needs {kind.needs}; "
            f"it may take only {FIELDS} and need only what it takes"
        )


KINDS: Registry[FeatureKind] = Registry("reward-feature kind", (
    FeatureKind("moved", (), (), _moved),
    FeatureKind("region", ("cells",), ("cells",), _region),
    FeatureKind("turn_around", ("cells",), (), _turn_around),
    FeatureKind("heading_in_region", ("cells", "headings"), ("cells", "headings"),
                _heading_in_region),
), check=_check_kind)  # fmt: skip
"""Every kind of reward feature by name."""


def hallway_features(
    upper: Cells = (), lower: Cells = (), turn_around: Cells | None = None
) -> tuple[RewardFeature, ...]:
    """The paper's four reward features (docs/design.md, "Reward features").

    Parameters
    ----------
    upper : tuple of (int, int), default ()
        The cells of ``upper_hallway``.
    lower : tuple of (int, int), default ()
        The cells of ``lower_hallway``.
    turn_around : tuple of (int, int), optional
        The cells of ``turn_around``; the map's dead ends if None.

    Returns
    -------
    tuple of RewardFeature
        ``moved``, ``upper_hallway``, ``lower_hallway`` and ``turn_around``.
    """
    return (
        RewardFeature("moved", "moved"),
        RewardFeature("upper_hallway", "region", tuple(upper)),
        RewardFeature("lower_hallway", "region", tuple(lower)),
        RewardFeature("turn_around", "turn_around", turn_around),
    )


@dataclass(frozen=True)
class RewardSpec:
    """The reward features of a domain, in weight order.

    Parameters
    ----------
    features : tuple of RewardFeature, default the paper's four
        The features (:func:`hallway_features` with no regions by default).
    """

    features: tuple[RewardFeature, ...] = hallway_features()

    def __post_init__(self) -> None:
        names = [f.name for f in self.features]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate reward feature name in {names}")
        if not names:
            raise ValueError("a reward needs at least one feature")

    @property
    def names(self) -> tuple[str, ...]:
        """The features' names, in weight order."""
        return tuple(f.name for f in self.features)

    def feature(self, name: str) -> RewardFeature:
        """The feature called ``name``.

        Parameters
        ----------
        name : str
            One of :attr:`names`.

        Returns
        -------
        RewardFeature
            The feature.

        Raises
        ------
        ValueError
            No feature has that name.
        """
        return self.features[self.names.index(name)]

    def turn_around_cells(self, gridmap: GridMap) -> Cells:
        """The cells where a turn is rewarded.

        Parameters
        ----------
        gridmap : GridMap
            The map, whose dead ends are the default.

        Returns
        -------
        tuple of (int, int)
            The cells of the first ``turn_around`` feature that names its own, else the map's dead
            ends (where that kind rewards a turn by default).
        """
        for f in self.features:
            if f.kind == "turn_around" and f.cells is not None:
                return f.cells
        return dead_ends(gridmap)


def read_region(
    value: Any, path: str, shape: tuple[int, int], gridmap: GridMap | None = None
) -> Cells:
    """A region (module doc) as a tuple of cells, rectangles expanded row by row.

    Parameters
    ----------
    value : object
        The region as read from TOML: a list of cells and rectangles, or one rectangle or point.
    path : str
        Its field path, for messages.
    shape : (int, int)
        The map's (rows, cols); every cell must lie on it.
    gridmap : GridMap, optional
        With the map, positions may be in metres of its frame, a rectangle's corners must be
        hallway cells, and it covers the hallway cells inside it.

    Returns
    -------
    tuple of (int, int)
        The cells.

    Raises
    ------
    FieldError
        A malformed entry, an empty list or a cell off the map, naming its field path.
    """
    frame = None if gridmap is None else gridmap.frame
    if isinstance(value, dict) and set(value) - {"x", "y"}:
        return _rectangle(value, path, shape, gridmap)
    if isinstance(value, dict):  # one point in metres
        return (schema.cell(value, path, shape, frame=frame),)
    out: list[tuple[int, int]] = []
    # an empty region's feature is 0 in every state: its weight could never be learned
    for i, item in enumerate(schema.array(value, path, min_length=1)):
        if isinstance(item, dict) and set(item) - {"x", "y"}:
            out.extend(_rectangle(item, f"{path}[{i}]", shape, gridmap))
        else:
            out.append(schema.cell(item, f"{path}[{i}]", shape, frame=frame))
    return tuple(out)


def _rectangle(value: dict, path: str, shape: tuple[int, int], gridmap: GridMap | None) -> Cells:
    value = schema.table(value, path, ("from", "to"), required=("from", "to"))
    frame = None if gridmap is None else gridmap.frame
    corners = []
    for key in ("from", "to"):
        corner = schema.cell(value[key], f"{path}.{key}", shape, frame=frame)
        if gridmap is not None and not gridmap.patroller[corner]:
            raise schema.FieldError(f"{path}.{key}", f"{list(corner)} is not a hallway cell")
        corners.append(corner)
    (r0, c0), (r1, c1) = corners
    cells = (
        (r, c)
        for r in range(min(r0, r1), max(r0, r1) + 1)
        for c in range(min(c0, c1), max(c0, c1) + 1)
    )
    if gridmap is None:
        return tuple(cells)
    return tuple(cell for cell in cells if gridmap.patroller[cell])


def _headings(value: Any, path: str) -> tuple[int, ...]:
    out = []
    for i, h in enumerate(schema.array(value, path, min_length=1)):
        if isinstance(h, str):
            out.append(HEADING_NAMES.index(schema.string(h, f"{path}[{i}]", HEADING_NAMES)))
        else:
            out.append(schema.integer(h, f"{path}[{i}]", low=0, high=3))
    return tuple(sorted(set(out)))


def _feature(
    value: Any, path: str, shape: tuple[int, int], gridmap: GridMap | None
) -> RewardFeature:
    value = schema.table(value, path, ("name", "kind", *FIELDS), ("name", "kind"))
    name = schema.name(value["name"], f"{path}.name", "reward feature")
    kind = schema.string(value["kind"], f"{path}.kind", tuple(KINDS))
    for key in FIELDS:
        if key in value and key not in KINDS[kind].takes:
            raise schema.FieldError(f"{path}.{key}", f"a '{kind}' feature takes no {key}")
    for key in KINDS[kind].needs:
        if key not in value:
            raise schema.FieldError(path, f"a '{kind}' feature needs {key}")
    cells = None
    if "cells" in value:
        cells = read_region(value["cells"], f"{path}.cells", shape, gridmap)
    headings: tuple[int, ...] = ()
    if "headings" in value:
        headings = _headings(value["headings"], f"{path}.headings")
    return RewardFeature(name, kind, cells, headings)


def read_reward_spec(
    reward: dict, shape: tuple[int, int], gridmap: GridMap | None = None
) -> tuple[RewardSpec, bool]:
    """The ``[reward]`` table's features.

    Parameters
    ----------
    reward : dict
        The ``[reward]`` table as read from TOML.
    shape : (int, int)
        The map's (rows, cols).
    gridmap : GridMap, optional
        The map, for regions in metres and rectangles (:func:`read_region`).

    Returns
    -------
    spec : RewardSpec
        The features.
    legacy : bool
        Whether they came in the older fixed form (``upper_hallway`` / ``lower_hallway`` /
        ``turn_around`` keys).

    Raises
    ------
    FieldError
        A problem, naming its field path.
    """
    reward = schema.table(reward, "reward", ("features", "weights", *LEGACY_KEYS))
    legacy = [k for k in LEGACY_KEYS if k in reward]
    if "features" in reward:
        if legacy:
            raise schema.FieldError(
                f"reward.{legacy[0]}", "give either reward.features or the fixed hallway keys"
            )
        items = schema.array(reward["features"], "reward.features", min_length=1)
        feats = tuple(
            _feature(f, f"reward.features[{i}]", shape, gridmap) for i, f in enumerate(items)
        )
        names = [f.name for f in feats]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise schema.FieldError(f"reward.features[{i}].name", f"'{name}' is used twice")
        return RewardSpec(feats), False
    regions = {
        k: read_region(reward[k], f"reward.{k}", shape, gridmap) if k in reward else None
        for k in LEGACY_KEYS
    }
    return RewardSpec(
        hallway_features(
            regions["upper_hallway"] or (), regions["lower_hallway"] or (), regions["turn_around"]
        )
    ), True


MAX_WEIGHT = 1e6  # a reward weight's magnitude; values stay far from overflow at any discount


def read_weights(
    value: Any, path: str, names: tuple[str, ...], base: Mapping[str, float]
) -> dict[str, float]:
    """``base`` updated by the table ``value`` of feature = weight (finite numbers).

    Parameters
    ----------
    value : object
        The table as read from TOML.
    path : str
        Its field path, for messages.
    names : tuple of str
        The reward features' names; no other key is accepted.
    base : mapping of str to float
        The weights the table updates.

    Returns
    -------
    dict of str to float
        The updated weights.

    Raises
    ------
    FieldError
        An unknown feature, a value that is not a number, or one above the largest weight.
    """
    value = schema.table(value, path, names)
    out = dict(base)
    for k, v in value.items():
        out[k] = schema.number(v, f"{path}.{k}")
        if abs(out[k]) > MAX_WEIGHT:  # 1e308 overflowed the value functions into NaN
            raise schema.FieldError(f"{path}.{k}", f"|{out[k]:g}| is above {MAX_WEIGHT:g}")
    return out
