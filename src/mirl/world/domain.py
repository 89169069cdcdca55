"""The patrol domain: robot states, actions, intended outcomes ψ, transition features ξ (as
data), reward features φ, detection, and the patrollers' interaction game.

A robot state is (row, col, heading) on a patroller cell; state index = 4·cell_index + heading,
with cells in row-major order. Headings: 0 east, 1 north, 2 west, 3 south.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mirl.world import schema
from mirl.world.actions import ACTIONS, FORWARD, N_HEADINGS, STOP, TURN_LEFT, TURN_RIGHT
from mirl.world.maps import HEADING_DELTAS, GridMap, dead_ends
from mirl.world.rewards import KINDS, RewardFeature, RewardSpec

__all__ = [
    "ACTIONS",
    "FORWARD",
    "TURN_LEFT",
    "TURN_RIGHT",
    "STOP",
    "N_HEADINGS",
    "dead_ends",
    "FeatureOverride",
    "FeatureMap",
    "DEFAULT_FEATURE_MAP",
    "RewardFeature",
    "RewardSpec",
    "REWARD_FEATURES",
    "PatrolDomain",
    "detection_cells",
]


@dataclass(frozen=True)
class FeatureOverride:
    """A state-dependent change to ξ, e.g. a ``carpet`` feature on some cells.

    Parameters
    ----------
    cells : tuple of (int, int), optional
        The (row, col) cells it applies on; all cells if None.
    actions : tuple of str, optional
        The actions it applies to; all if None.
    add : tuple of str, default ()
        Transition features added to ξ(s, a) there.
    remove : tuple of str, default ()
        Transition features removed from ξ(s, a) there.
    """

    cells: tuple[tuple[int, int], ...] | None = None
    actions: tuple[str, ...] | None = None
    add: tuple[str, ...] = ()
    remove: tuple[str, ...] = ()


@dataclass(frozen=True)
class FeatureMap:
    """ξ as data: the transition features and the feature subset of every (state, action).

    Parameters
    ----------
    features : tuple of str
        The transition features, in the order their probabilities are listed everywhere.
    action_subsets : mapping of str to tuple of str
        The features every action depends on, for each of :data:`~mirl.world.actions.ACTIONS`.
    overrides : tuple of FeatureOverride, default ()
        State-dependent changes, applied in order.

    Raises
    ------
    ValueError
        No feature, a duplicate feature, an action without a subset, or an unknown action or
        feature name.
    """

    features: tuple[str, ...]
    action_subsets: Mapping[str, tuple[str, ...]]
    overrides: tuple[FeatureOverride, ...] = ()

    def __post_init__(self) -> None:
        if not self.features:  # the learners' posteriors over the probabilities need one
            raise ValueError("no transition features: ξ needs at least one (features = [...])")
        if len(set(self.features)) != len(self.features):
            raise ValueError(f"duplicate transition feature in {list(self.features)}")
        known = set(self.features)
        missing = [a for a in ACTIONS if a not in self.action_subsets]
        if missing:
            raise ValueError(f"transition feature map has no subset for action '{missing[0]}'")
        for action, subset in self.action_subsets.items():
            if action not in ACTIONS:
                raise ValueError(f"unknown action '{action}' in transition feature map")
            self._check(subset, known, f"action '{action}'")
        for i, ov in enumerate(self.overrides):
            self._check(ov.add + ov.remove, known, f"override {i + 1}")
            for a in ov.actions or ():
                if a not in ACTIONS:
                    raise ValueError(f"override {i + 1}: unknown action '{a}'")

    @staticmethod
    def _check(names: Iterable[str], known: set[str], where: str) -> None:
        for name in names:
            if name not in known:
                known_list = ", ".join(sorted(known))
                raise ValueError(
                    f"{where}: unknown transition feature '{name}' (known: {known_list})"
                )

    def subset_table(self, domain: PatrolDomain) -> tuple[np.ndarray, tuple[tuple[str, ...], ...]]:
        """ξ(s, a) of every state and action of ``domain``, as indices into its distinct subsets.

        Parameters
        ----------
        domain : PatrolDomain
            The domain whose states the overrides' cells select.

        Returns
        -------
        table : ndarray of int, shape (S, A)
            The index of ξ(s, a) in ``subsets``.
        subsets : tuple of tuple of str
            The distinct subsets, each in feature order.
        """
        sets = [[set(self.action_subsets[a]) for a in ACTIONS] for _ in range(domain.n_states)]
        cells = domain.states[:, :2]
        for ov in self.overrides:
            if ov.cells is None:
                hit = np.ones(domain.n_states, dtype=bool)
            else:
                targets = {tuple(c) for c in ov.cells}
                hit = np.array([tuple(c) in targets for c in cells.tolist()])
            acts = [ACTIONS.index(a) for a in (ov.actions or ACTIONS)]
            for s in np.flatnonzero(hit):
                for a in acts:
                    sets[s][a] = (sets[s][a] | set(ov.add)) - set(ov.remove)
        order = {f: i for i, f in enumerate(self.features)}
        distinct: dict[tuple[str, ...], int] = {}
        table = np.empty((domain.n_states, len(ACTIONS)), dtype=int)
        for si, row in enumerate(sets):
            for a, subset in enumerate(row):
                key = tuple(sorted(subset, key=order.__getitem__))
                table[si, a] = distinct.setdefault(key, len(distinct))
        return table, tuple(distinct)

    def without(self, features: Iterable[str], actions: Iterable[str]) -> FeatureMap:
        """This ξ with ``features`` removed from the subsets of ``actions`` (overrides kept).

        What a world whose ``actions`` do not depend on those parts makes of it.

        Parameters
        ----------
        features : iterable of str
            Transition features to drop.
        actions : iterable of str
            The actions whose subsets lose them.

        Returns
        -------
        FeatureMap
            The reduced map.

        Raises
        ------
        ValueError
            A feature this map does not have.
        """
        drop, acts = set(features), set(actions)
        self._check(drop, set(self.features), "without")
        subsets = {
            a: tuple(f for f in subset if not (a in acts and f in drop))
            for a, subset in self.action_subsets.items()
        }
        return FeatureMap(self.features, subsets, self.overrides)

    @classmethod
    def from_dict(
        cls, data: Mapping, *, where: str = "transition_features", shape=None, frame=None
    ) -> FeatureMap:
        """ξ from a ``[transition_features]`` table.

        The table holds ``features``, ``actions`` and an optional ``override`` list; every value is
        type-checked (:mod:`mirl.world.schema`).

        Parameters
        ----------
        data : mapping
            The table as read from TOML.
        where : str, default "transition_features"
            The table's field path, for messages.
        shape : tuple of int, optional
            The map's (rows, cols); override cells are checked to lie on it if given.
        frame : MapFrame, optional
            If given, override cells may be written in metres of this frame.

        Returns
        -------
        FeatureMap
            The map the table describes.

        Raises
        ------
        FieldError
            A problem, naming the field path.
        """
        data = schema.table(
            data, where, ("features", "actions", "override"), ("features", "actions")
        )
        features = tuple(
            schema.name(v, f"{where}.features[{i}]", "transition feature")
            for i, v in enumerate(schema.array(data["features"], f"{where}.features"))
        )
        raw = data["actions"]  # any action names, but a table of them
        acts = schema.table(raw, f"{where}.actions", raw.keys() if isinstance(raw, dict) else ())
        actions = {a: _names(v, f"{where}.actions.{a}") for a, v in acts.items()}
        overrides = []
        for i, ov in enumerate(schema.array(data.get("override", []), f"{where}.override")):
            p = f"{where}.override[{i}]"
            ov = schema.table(ov, p, ("cells", "actions", "add", "remove"))
            # an override on no cell, for no action or adding and removing nothing would
            # change no ξ(s, a): written, it is a mistake, not a no-op to keep quiet about
            add = _names(ov.get("add", []), f"{p}.add")
            remove = _names(ov.get("remove", []), f"{p}.remove")
            if not (add or remove):
                raise schema.FieldError(p, "adds and removes no feature (give add or remove)")
            cells = None
            if "cells" in ov:
                items = schema.array(ov["cells"], f"{p}.cells", min_length=1)
                cells = tuple(
                    schema.cell(c, f"{p}.cells[{k}]", shape, frame=frame)
                    for k, c in enumerate(items)
                )
            overrides.append(
                FeatureOverride(
                    cells=cells,
                    actions=(
                        _names(ov["actions"], f"{p}.actions", min_length=1)
                        if "actions" in ov
                        else None
                    ),
                    add=add,
                    remove=remove,
                )
            )
        try:
            fm = cls(features, actions, tuple(overrides))
            fm._check_written()
        except ValueError as exc:
            raise schema.FieldError(where, str(exc)) from None
        return fm

    def _check_written(self) -> None:
        """Refuse what a written table cannot mean: an override that changes no ξ(s, a) on its
        cells (it adds features its actions have there and removes ones they lack, after the
        overrides before it), and a feature no action depends on anywhere (no step could tell
        its probability, which would stay at its prior). Only a table a user wrote is asked:
        a reduced map (:meth:`without`) may leave either, meaning what its world means."""
        named = sorted({tuple(c) for ov in self.overrides if ov.cells for c in ov.cells})
        keys: list[tuple | None] = [None, *named]  # None: every cell no override names
        sets = {(k, a): set(self.action_subsets[a]) for k in keys for a in ACTIONS}
        for i, ov in enumerate(self.overrides):
            changed = False
            for k in keys if ov.cells is None else [tuple(c) for c in ov.cells]:
                for a in ov.actions or ACTIONS:
                    new = (sets[k, a] | set(ov.add)) - set(ov.remove)
                    changed |= new != sets[k, a]
                    sets[k, a] = new
            if not changed:
                raise ValueError(
                    f"override {i + 1} changes no action's features on its cells: they have "
                    "every feature it adds and none it removes there already"
                )
        used = set().union(*sets.values())
        for f in self.features:
            if f not in used:
                raise ValueError(
                    f"transition feature '{f}' is in no action's subset on any cell: no step "
                    "could tell its probability"
                )


def _names(value, path: str, min_length: int = 0) -> tuple[str, ...]:
    items = schema.array(value, path, min_length=min_length)
    return tuple(schema.string(v, f"{path}[{i}]") for i, v in enumerate(items))


DEFAULT_FEATURE_MAP = FeatureMap(
    features=("left_wheel", "right_wheel", "navigation", "floor"),
    action_subsets={
        "forward": ("left_wheel", "right_wheel", "navigation", "floor"),
        # a left turn pivots on the left wheel, so only the right wheel drives it
        "turn_left": ("right_wheel", "navigation", "floor"),
        "turn_right": ("left_wheel", "navigation", "floor"),
        "stop": ("floor",),
    },
)


# the paper's four (docs/design.md, "Reward features")
REWARD_FEATURES: tuple[str, ...] = RewardSpec().names


class PatrolDomain:
    """States, actions, ψ, ξ and φ of one patroller on a map.

    Parameters
    ----------
    gridmap : GridMap
        The map; its patroller cells are the states' cells.
    feature_map : FeatureMap, default DEFAULT_FEATURE_MAP
        The transition features ξ of every (state, action).
    reward_spec : RewardSpec, optional
        The reward features φ; the paper's four by default.
    """

    actions = ACTIONS

    def __init__(
        self,
        gridmap: GridMap,
        feature_map: FeatureMap = DEFAULT_FEATURE_MAP,
        reward_spec: RewardSpec | None = None,
    ) -> None:
        self.map = gridmap
        self.feature_map = feature_map
        self.reward_spec = reward_spec or RewardSpec()
        self.cells = gridmap.patroller_cells
        self.n_cells = len(self.cells)
        self.n_states = self.n_cells * N_HEADINGS
        self.n_actions = len(ACTIONS)
        lut = np.full(gridmap.shape, -1, dtype=int)
        lut[self.cells[:, 0], self.cells[:, 1]] = np.arange(self.n_cells)
        self.cell_lut = lut
        headings = np.tile(np.arange(N_HEADINGS), self.n_cells)
        self.states = np.column_stack([np.repeat(self.cells, N_HEADINGS, axis=0), headings])

    # ---- indexing -------------------------------------------------------------------------
    def state_index(self, row, col, heading) -> np.ndarray:
        """Vectorised (row, col, heading) → state index.

        Parameters
        ----------
        row : int or array_like of int
            Rows.
        col : int or array_like of int
            Columns, broadcast with ``row``.
        heading : int or array_like of int
            Headings (0 east, 1 north, 2 west, 3 south), broadcast with both.

        Returns
        -------
        ndarray of int
            The state indices; -1 where (row, col, heading) is not a patroller state.
        """
        row, col, heading = (np.asarray(x, dtype=int) for x in (row, col, heading))
        rows, cols = self.map.shape
        inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        clipped = self.cell_lut[np.clip(row, 0, rows - 1), np.clip(col, 0, cols - 1)]
        cell = np.where(inside, clipped, -1)
        ok = (cell >= 0) & (heading >= 0) & (heading < N_HEADINGS)
        return np.where(ok, cell * N_HEADINGS + heading, -1)

    def state_cell(self, states) -> np.ndarray:
        """The cell index (into ``cells``) of each state.

        Parameters
        ----------
        states : int or array_like of int
            State indices.

        Returns
        -------
        ndarray of int
            Their cells' indices, of ``states``' shape.
        """
        return np.asarray(states) // N_HEADINGS

    # ---- ψ ----------------------------------------------------------------------------------
    @cached_property
    def intended(self) -> np.ndarray:
        """ψ as an (S, A) array of intended next states."""
        r, c, h = self.states.T
        out = np.empty((self.n_states, self.n_actions), dtype=int)
        s = np.arange(self.n_states)
        dr, dc = HEADING_DELTAS[h].T
        ahead = self.state_index(r + dr, c + dc, h)
        out[:, FORWARD] = np.where(ahead >= 0, ahead, s)
        out[:, TURN_LEFT] = s - h + (h + 1) % N_HEADINGS
        out[:, TURN_RIGHT] = s - h + (h + 3) % N_HEADINGS
        out[:, STOP] = s
        return out

    # ---- ξ ----------------------------------------------------------------------------------
    @cached_property
    def _subsets(self) -> tuple[np.ndarray, tuple[tuple[str, ...], ...]]:
        return self.feature_map.subset_table(self)

    @property
    def subset_index(self) -> np.ndarray:
        """(S, A) index into :attr:`subsets` of ξ(s, a)."""
        return self._subsets[0]

    @property
    def subsets(self) -> tuple[tuple[str, ...], ...]:
        """The distinct feature subsets ξ(s, a) takes, each in feature order."""
        return self._subsets[1]

    @cached_property
    def subset_masks(self) -> np.ndarray:
        """(n_subsets, n_features) bool incidence of features in each distinct subset."""
        names = self.feature_map.features
        return np.array([[f in sub for f in names] for sub in self.subsets], dtype=bool)

    def success_probabilities(self, feature_probabilities: Mapping[str, float]) -> np.ndarray:
        """(S, A) product of feature probabilities over ξ(s, a) (Eq. 2).

        Parameters
        ----------
        feature_probabilities : mapping of str to float
            A probability in [0, 1] for every transition feature.

        Returns
        -------
        ndarray of shape (S, A)
            The probability that (s, a) reaches its intended state ψ(s, a).

        Raises
        ------
        ValueError
            An unknown or missing feature, or a probability outside [0, 1].
        """
        names = self.feature_map.features
        unknown = set(feature_probabilities) - set(names)
        if unknown:
            raise ValueError(f"unknown transition feature '{sorted(unknown)[0]}'")
        try:
            p = np.array([float(feature_probabilities[f]) for f in names])
        except KeyError as exc:
            raise ValueError(f"no probability given for transition feature {exc}") from None
        if np.any(~np.isfinite(p)) or np.any((p < 0) | (p > 1)):
            bad = names[int(np.flatnonzero(~((p >= 0) & (p <= 1)))[0])]
            raise ValueError(f"probability of '{bad}' must be in [0, 1]")
        with np.errstate(divide="ignore"):
            log_p = np.where(self.subset_masks, np.log(p), 0.0).sum(axis=1)
        return np.exp(log_p)[self.subset_index]

    # ---- φ ----------------------------------------------------------------------------------
    @cached_property
    def turn_around_cells(self) -> tuple[tuple[int, int], ...]:
        """Cells of the (first) ``turn_around`` feature: its own, or the map's dead ends."""
        return self.reward_spec.turn_around_cells(self.map)

    def cell_mask(self, cells: Sequence[tuple[int, int]]) -> np.ndarray:
        """The states on ``cells``, every heading.

        Parameters
        ----------
        cells : sequence of (int, int)
            (row, col) hallway cells.

        Returns
        -------
        ndarray of bool, shape (S,)
            True on the states of those cells.

        Raises
        ------
        ValueError
            A cell off the hallway.
        """
        mask = np.zeros(self.n_states, dtype=bool)
        if len(cells):
            arr = np.asarray(cells, dtype=int)
            idx = self.cell_lut[arr[:, 0], arr[:, 1]]
            if np.any(idx < 0):
                bad = tuple(int(x) for x in arr[np.flatnonzero(idx < 0)[0]])
                raise ValueError(f"reward region cell {bad} is not a hallway cell")
            mask[(idx[:, None] * N_HEADINGS + np.arange(N_HEADINGS)).ravel()] = True
        return mask

    @cached_property
    def reward_features(self) -> np.ndarray:
        """φ as an (S, A, K) array over :attr:`reward_feature_names`."""
        feats = self.reward_spec.features
        phi = np.zeros((self.n_states, self.n_actions, len(feats)))
        for k, f in enumerate(feats):
            phi[:, :, k] = KINDS[f.kind].values(self, f)
        return phi

    @property
    def reward_feature_names(self) -> tuple[str, ...]:
        """The names of the reward features φ, in the order of their weights."""
        return self.reward_spec.names

    def rewards(self, weights: Sequence[float]) -> np.ndarray:
        """R(s, a) = φ(s, a)·w.

        Parameters
        ----------
        weights : sequence of float
            One weight per reward feature (:attr:`reward_feature_names`).

        Returns
        -------
        ndarray of shape (S, A)
            The rewards.

        Raises
        ------
        ValueError
            Not one weight per reward feature.
        """
        w = np.asarray(weights, dtype=float)
        k = len(self.reward_spec.features)
        if w.shape != (k,):
            raise ValueError(f"expected {k} reward weights, got {w.shape}")
        return self.reward_features @ w

    # ---- visibility -------------------------------------------------------------------------
    def visible_states(self, degree: float) -> np.ndarray:
        """The states whose cell L sees at observability ``degree``.

        Parameters
        ----------
        degree : float
            The observability, the fraction of the hallway L sees, in [0, 1].

        Returns
        -------
        ndarray of bool, shape (S,)
            True on the visible states.
        """
        mask = self.map.visible_mask(degree)
        return np.repeat(mask[self.cells[:, 0], self.cells[:, 1]], N_HEADINGS)


def detection_cells(
    gridmap: GridMap, row: int, col: int, heading: int, distance: int
) -> list[tuple[int, int]]:
    """Cells a patroller at (row, col, heading) sees.

    Straight ahead, up to ``distance`` cells, stopping at the first wall. L's room cells are never
    seen (docs/design.md, "Detection").

    Parameters
    ----------
    gridmap : GridMap
        The map.
    row : int
        The patroller's row.
    col : int
        Its column.
    heading : int
        Its heading (0 east, 1 north, 2 west, 3 south).
    distance : int
        How many cells ahead it sees.

    Returns
    -------
    list of (int, int)
        Its own cell, then the cells ahead in order.
    """
    dr, dc = HEADING_DELTAS[heading]
    rows, cols = gridmap.shape
    out = [(row, col)]
    r, c = row, col
    for _ in range(distance):
        r, c = r + dr, c + dc
        if not (0 <= r < rows and 0 <= c < cols) or not gridmap.patroller[r, c]:
            break
        out.append((r, c))
    return out
