"""Grid maps: the plain-text format of the reference maps, visibility order, and the metric frame
(:class:`MapFrame`) that places a grid in a ROS-style map frame.

Legend (one character per cell, row 0 at the top): ``.`` hallway (patrollers and L), ``#`` wall,
``L`` L's start (a room cell, L only), ``G`` L's goal on a hallway cell, ``g`` L's goal in a room
(L only). Lines starting with ``;`` are comments; trailing blank lines are ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

__all__ = [
    "dead_ends",
    "MAX_MAP_SIDE",
    "GridMap",
    "MapError",
    "MapFrame",
    "parse_map",
    "line_of_sight",
    "HEADING_DELTAS",
    "HEADING_YAWS",
]

# heading 0 = east (col+1), 1 = north (row-1), 2 = west, 3 = south
HEADING_DELTAS = np.array([[0, 1], [-1, 0], [0, -1], [1, 0]])
# ... and the same headings as yaw in a ROS map frame (x east, y north): 0, π/2, π, −π/2
HEADING_YAWS = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2])

_LEGEND = set(".#LGg")


# the largest map mirl plans on: its per-state arrays grow with 4 x cells (the office generator
# has the same limit)
MAX_MAP_SIDE = 1000


class MapError(ValueError):
    """A map file that cannot be used; the message names the file and the problem."""


# Bounds on a metric frame, far beyond any building, so that positions keep centimetres in
# float64 and cell arithmetic cannot overflow (1e308 was accepted and overflowed later)
MIN_CELL_SIZE, MAX_CELL_SIZE = 1e-3, 1e3  # metres a cell
MAX_FRAME_ORIGIN = 1e7  # metres, |x| and |y|


@dataclass(frozen=True)
class MapFrame:
    """Where the grid lies in a metric map frame (x east, y north, as in ROS).

    x grows with the column and y with decreasing row, so heading 0 (east) is yaw 0 and heading 1
    (north) is yaw π/2.

    Parameters
    ----------
    cell_size : float, default 1.0
        Metres per cell, in [0.001, 1000].
    origin_x : float, default 0.0
        The map-frame x of the *centre* of cell (0, 0), within 10^7 m.
    origin_y : float, default 0.0
        Its y, within 10^7 m.

    Raises
    ------
    MapError
        A value that is not finite or out of its range.
    """

    cell_size: float = 1.0  # metres per cell
    origin_x: float = 0.0
    origin_y: float = 0.0

    def __post_init__(self) -> None:
        values = (self.cell_size, self.origin_x, self.origin_y)
        if not all(np.isfinite(values)):
            raise MapError(f"map frame must be finite, got {values}")
        if not MIN_CELL_SIZE <= self.cell_size <= MAX_CELL_SIZE:
            raise MapError(
                f"cell size must be in [{MIN_CELL_SIZE:g}, {MAX_CELL_SIZE:g}] m, "
                f"got {self.cell_size:g}"
            )
        if max(abs(self.origin_x), abs(self.origin_y)) > MAX_FRAME_ORIGIN:
            raise MapError(
                f"origin x and y must be within {MAX_FRAME_ORIGIN:g} m of the map frame's, got "
                f"({self.origin_x:g}, {self.origin_y:g})"
            )

    def cell_centre(self, row, col):
        """Map-frame (x, y) of the centre of cell (row, col); arrays broadcast.

        Parameters
        ----------
        row : float or array_like
            Rows (fractional rows allowed).
        col : float or array_like
            Columns.

        Returns
        -------
        x : ndarray
            Metres east.
        y : ndarray
            Metres north.
        """
        x = self.origin_x + np.asarray(col, dtype=float) * self.cell_size
        y = self.origin_y - np.asarray(row, dtype=float) * self.cell_size
        return x, y

    def cell_coordinates(self, x, y):
        """Fractional (row, col) of map-frame points: the inverse of :meth:`cell_centre`.

        Parameters
        ----------
        x : float or array_like
            Metres east.
        y : float or array_like
            Metres north, broadcast with ``x``.

        Returns
        -------
        row : ndarray
            Fractional rows.
        col : ndarray
            Fractional columns.
        """
        col = (np.asarray(x, dtype=float) - self.origin_x) / self.cell_size
        row = (self.origin_y - np.asarray(y, dtype=float)) / self.cell_size
        return row, col

    def cell_of(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Integer (row, col) of the cell whose centre is nearest each map-frame point.

        The cell may lie outside the grid; arrays broadcast.

        Parameters
        ----------
        x : float or array_like
            Metres east.
        y : float or array_like
            Metres north.

        Returns
        -------
        row : ndarray of int
            Rows.
        col : ndarray of int
            Columns.
        """
        row, col = self.cell_coordinates(x, y)
        return np.rint(row).astype(int), np.rint(col).astype(int)


class _LazyVisibilityOrder:
    """GridMap.visibility_order: the order given, or computed from the map on first use (a ray
    cast to every free cell: seconds and, unchunked, gigabytes on a real map at its native
    resolution, so a map loaded only to be measured or refused, or whose placeholder start a
    scenario replaces, never pays for it)."""

    def __get__(self, obj: Any, objtype: Any = None) -> Any:
        if obj is None:
            return None  # the dataclass field's default: compute from the map
        order = obj.__dict__.get("_visibility_order")
        if order is None:
            order = default_visibility_order(obj.patroller, obj.observer_start, obj.free)
            obj.__dict__["_visibility_order"] = order
        return order

    def __set__(self, obj: Any, value: np.ndarray | None) -> None:
        obj.__dict__["_visibility_order"] = value


@dataclass(frozen=True, eq=False)
class GridMap:
    """A grid of cells with L's start, goals, and the nested visibility order.

    The order is that of docs/design.md, "The visibility order".

    Parameters
    ----------
    name : str
        The map's name.
    patroller : ndarray of bool, shape (rows, cols)
        The hallway: cells patrollers (and L) may occupy.
    observer_only : ndarray of bool, shape (rows, cols)
        Room cells only L may occupy.
    observer_start : (int, int)
        L's start cell.
    goals : tuple of (int, int)
        L's goal cells, the first the one a run aims for.
    visibility_order : ndarray of int, shape (n, 2), optional
        The patroller cells, most exposed first; computed from the map on first use if None.
    source : str, default "<memory>"
        Where the map came from, for messages.
    frame : MapFrame, default MapFrame()
        Its metric placement (poses, physics).
    marked : bool, default True
        Whether the map marks L's start and goal itself; a plain ROS map does not, and its
        ``observer_start`` and ``goals`` are placeholders until a scenario gives them.

    Raises
    ------
    MapError
        A map larger than :data:`MAX_MAP_SIDE` on a side.
    """

    name: str
    patroller: np.ndarray  # (rows, cols) bool: cells patrollers (and L) may occupy
    observer_only: np.ndarray  # (rows, cols) bool: room cells only L may occupy
    observer_start: tuple[int, int]
    goals: tuple[tuple[int, int], ...]
    # (n, 2) patroller cells, most exposed first; None: computed from the map
    visibility_order: _LazyVisibilityOrder = _LazyVisibilityOrder()
    source: str = "<memory>"
    frame: MapFrame = field(default_factory=MapFrame)  # metric placement (poses, physics)
    # whether the map marks L's start and goal itself; a plain ROS map does not, and its
    # observer_start and goals are placeholders until a scenario gives them
    marked: bool = True

    def __post_init__(self) -> None:
        rows, cols = self.patroller.shape
        if rows > MAX_MAP_SIDE or cols > MAX_MAP_SIDE:
            raise MapError(
                f"{self.source}: map of {rows}x{cols} cells is larger than the limit of "
                f"{MAX_MAP_SIDE}x{MAX_MAP_SIDE}"
            )

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the grid."""
        return self.patroller.shape

    @property
    def free(self) -> np.ndarray:
        """Cells L may occupy: hallway plus rooms."""
        return self.patroller | self.observer_only

    def free_pieces(self) -> np.ndarray:
        """The connected pieces of the free cells: side-adjacent free cells, the moves a robot
        can make, join a piece.

        Returns
        -------
        ndarray of int, shape (rows, cols)
            Each free cell's piece (0, 1, …), -1 on walls.
        """
        from scipy.sparse import coo_array
        from scipy.sparse.csgraph import connected_components

        free = self.free
        n = int(free.sum())
        index = np.full(free.shape, -1)
        index[free] = np.arange(n)
        right = free[:, :-1] & free[:, 1:]
        down = free[:-1, :] & free[1:, :]
        a = np.concatenate([index[:, :-1][right], index[:-1, :][down]])
        b = np.concatenate([index[:, 1:][right], index[1:, :][down]])
        graph = coo_array((np.ones(len(a)), (a, b)), shape=(n, n))
        _, labels = connected_components(graph, directed=False)
        out = np.full(free.shape, -1)
        out[free] = labels
        return out

    @property
    def patroller_cells(self) -> np.ndarray:
        """(n, 2) patroller cells in row-major order."""
        return np.argwhere(self.patroller)

    @property
    def n_patroller_cells(self) -> int:
        """The number of hallway (patroller) cells."""
        return int(self.patroller.sum())

    def visible_mask(self, degree: float) -> np.ndarray:
        """The first round(degree·n) cells of the visibility order.

        Parameters
        ----------
        degree : float
            The observability, in [0, 1].

        Returns
        -------
        ndarray of bool, shape (rows, cols)
            True on the cells L sees.

        Raises
        ------
        ValueError
            A degree outside [0, 1].
        """
        if not 0.0 <= degree <= 1.0:
            raise ValueError(f"observability degree must be in [0, 1], got {degree}")
        n = int(round(degree * len(self.visibility_order)))
        mask = np.zeros(self.shape, dtype=bool)
        cells = self.visibility_order[:n]
        mask[cells[:, 0], cells[:, 1]] = True
        return mask

    def in_line_of_sight(self) -> np.ndarray:
        """The patroller cells in line of sight of L's start.

        Returns
        -------
        ndarray of bool, shape (rows, cols)
            :func:`line_of_sight` over the map's free cells, on the hallway.
        """
        return line_of_sight(self.free, self.observer_start) & self.patroller

    def with_observer(self, start: tuple[int, int], goal: tuple[int, int]) -> GridMap:
        """The map with L's start at ``start`` and ``goal`` as its goal.

        The map's own marks are only defaults; the visibility order is computed again from the new
        start. The map's rooms stay L-only cells.

        Parameters
        ----------
        start : (int, int)
            L's start cell.
        goal : (int, int)
            L's goal cell.

        Returns
        -------
        GridMap
            The new map, or ``self`` when nothing changes.
        """
        start, goal = (int(start[0]), int(start[1])), (int(goal[0]), int(goal[1]))
        if start == self.observer_start and goal == self.goals[0] and self.marked:
            return self
        others = (g for g in self.goals if g != goal) if self.marked else ()  # not placeholders
        goals = (goal, *others)
        same_start = start == self.observer_start
        return replace(
            self,
            observer_start=start,
            goals=goals,
            visibility_order=self.__dict__.get("_visibility_order") if same_start else None,
            marked=True,
        )

    def to_text(self) -> str:
        """The map in the text format (an unmarked map without its placeholder L and G).

        Returns
        -------
        str
            One line per row, in the legend of this module.
        """
        chars = np.full(self.shape, "#")
        chars[self.patroller] = "."
        chars[self.observer_only] = "."
        if self.marked:
            for r, c in self.goals:
                chars[r, c] = "G" if self.patroller[r, c] else "g"
            chars[self.observer_start] = "L"
        return "\n".join("".join(row) for row in chars)


def default_visibility_order(
    patroller: np.ndarray, start: tuple[int, int], free: np.ndarray | None = None
) -> np.ndarray:
    """Order patroller cells by exposure to L's start.

    The cells in line of sight of L's start (:func:`line_of_sight` through the ``free`` cells;
    ``patroller`` cells and L's start if not given) come first, then the others; within each
    group the cells keep the exposure order: first the cells on straight lines from L's start
    (along rows and columns, nearest first, east/north/west/south), then the rest by
    breadth-first distance from the cells already seen, ties broken row-major. On boyd2 this
    gives the order of docs/design.md, "The visibility order": (0,1)…(0,8), (1,1)…(16,1), then
    the lower hallway."""
    exposure = _exposure_order(patroller, start)
    if len(exposure) == 0:
        return exposure
    if free is None:
        free = patroller.copy()
    sight = line_of_sight(free, start)
    seen = sight[exposure[:, 0], exposure[:, 1]]
    return np.concatenate([exposure[seen], exposure[~seen]])


def _exposure_order(patroller: np.ndarray, start: tuple[int, int]) -> np.ndarray:
    """Patroller cells by exposure: straight lines from ``start``, then breadth-first."""
    rows, cols = patroller.shape
    order: list[tuple[int, int]] = []
    seen = np.zeros_like(patroller, dtype=bool)
    for dr, dc in HEADING_DELTAS:
        r, c = start[0] + dr, start[1] + dc
        while 0 <= r < rows and 0 <= c < cols and patroller[r, c]:
            if not seen[r, c]:
                order.append((r, c))
                seen[r, c] = True
            r, c = r + dr, c + dc
    frontier = list(order)
    if not frontier:  # door opens on no hallway line: start from the nearest patroller cells
        cells = np.argwhere(patroller)
        if len(cells) == 0:
            return np.zeros((0, 2), dtype=int)
        d = np.abs(cells - np.asarray(start)).sum(axis=1)
        r0, c0 = map(int, cells[np.argmin(d)])
        frontier = [(r0, c0)]
        order.extend(frontier)
        seen[frontier[0]] = True
    while frontier:
        nxt: list[tuple[int, int]] = []
        for r, c in frontier:
            for dr, dc in HEADING_DELTAS:
                rr, cc = r + dr, c + dc
                if 0 <= rr < rows and 0 <= cc < cols and patroller[rr, cc] and not seen[rr, cc]:
                    seen[rr, cc] = True
                    nxt.append((rr, cc))
        nxt.sort()
        order.extend(nxt)
        frontier = nxt
    # cells unreachable from the door come last, row-major, so every cell has a rank
    rest = [(int(r), int(c)) for r, c in np.argwhere(patroller & ~seen)]
    order.extend(rest)
    return np.asarray(order, dtype=int).reshape(-1, 2)


def line_of_sight(
    open_cells: np.ndarray, origin: tuple[int, int], max_range: float | None = None
) -> np.ndarray:
    """The cells whose centre the straight segment from the centre of ``origin`` reaches without
    passing through a closed cell (``~open_cells``).

    The rule of the physics world's cameras, which cast rays against wall boxes of one cell
    each: the segment is blocked by a closed cell whose interior it crosses, and by two closed
    cells that touch diagonally at a corner it passes through; it is not blocked by a closed
    cell it only touches at a corner. Closed cells are never in sight; ``origin`` always is
    (when it lies on the grid).

    Parameters
    ----------
    open_cells : ndarray of bool, shape (rows, cols)
        The cells a line of sight may cross.
    origin : (int, int)
        The viewer's cell.
    max_range : float, optional
        Cells, centre to centre, beyond which nothing is seen; unbounded if None.

    Returns
    -------
    ndarray of bool, shape (rows, cols)
        True on the cells in sight.
    """
    open_cells = np.asarray(open_cells, dtype=bool)
    rows, cols = open_cells.shape
    out = np.zeros((rows, cols), dtype=bool)
    r0, c0 = int(origin[0]), int(origin[1])
    if not (0 <= r0 < rows and 0 <= c0 < cols):
        return out
    passable = np.pad(open_cells, 1)  # a border of closed cells: rays never leave the grid
    passable[r0 + 1, c0 + 1] = True
    targets = np.argwhere(open_cells)
    dr, dc = targets[:, 0] - r0, targets[:, 1] - c0
    if max_range is not None:
        near = np.hypot(dr, dc) <= max_range + 1e-9
        targets, dr, dc = targets[near], dr[near], dc[near]
    blocked = np.zeros(len(targets), dtype=bool)
    # a few million crossings at a time: every target at once takes gigabytes on a real map at
    # its native resolution (10^5 cells, hundreds of crossings each)
    crossings = np.cumsum(np.abs(dr) + np.abs(dc))
    total = int(crossings[-1]) if len(crossings) else 0
    bounds = np.searchsorted(crossings, np.arange(_LOS_CHUNK, total, _LOS_CHUNK))
    for lo, hi in zip([0, *bounds.tolist()], [*bounds.tolist(), len(targets)], strict=True):
        if hi > lo:
            blocked[lo:hi] = _rays_blocked(passable, r0, c0, dr[lo:hi], dc[lo:hi])
    seen = targets[~blocked]
    out[seen[:, 0], seen[:, 1]] = True
    return out


_LOS_CHUNK = 2_000_000  # grid-line crossings per batch of rays (about 0.3 GB of temporaries)


def _rays_blocked(passable: np.ndarray, r0: int, c0: int, dr: np.ndarray, dc: np.ndarray):
    """(n,) bool: whether the segment from (r0, c0) to each (r0 + dr, c0 + dc) is blocked, over
    ``passable`` (the grid padded by one closed cell)."""
    blocked = np.zeros(len(dr), dtype=bool)
    # crossings of the grid's vertical lines (axis 1) and horizontal lines (axis 0), in integer
    # arithmetic: the j-th crossing (j = 1..|d|) lies at parameter t = (2j - 1) / (2|d|)
    for along, across in ((dc, dr), (dr, dc)):
        n = np.abs(along)
        k = np.repeat(np.arange(len(dr)), n)
        if len(k) == 0:
            continue
        j = np.arange(len(k)) - np.repeat(np.cumsum(n) - n, n) + 1
        step = np.sign(along[k])
        den = 2 * n[k]
        num = across[k] * (2 * j - 1) + n[k]  # (position across + 0.5) * den
        at_corner = num % den == 0
        line = num // den  # the cell across (below the line at a corner)
        before, after = (j - 1) * step, j * step  # the cells along, on either side
        if along is dc:  # axis 1: 'along' is a column offset, 'across' a row offset
            cell_a = (r0 + line + 1, c0 + before + 1)
            cell_b = (r0 + line + 1, c0 + after + 1)
            up_a, up_b = (r0 + line, c0 + before + 1), (r0 + line, c0 + after + 1)
        else:
            cell_a = (r0 + before + 1, c0 + line + 1)
            cell_b = (r0 + after + 1, c0 + line + 1)
            up_a, up_b = (r0 + before + 1, c0 + line), (r0 + after + 1, c0 + line)
        a, b = passable[cell_a], passable[cell_b]
        ua, ub = passable[up_a], passable[up_b]
        # off a corner the segment crosses from cell a into cell b; at a corner it goes from
        # one of the four cells around it to the diagonal one, and the other two are touched
        toward_up = np.sign(across[k]) < 0
        diag_1 = np.where(toward_up, a & ub, ua & b)  # the cells it passes through
        side_1 = np.where(toward_up, ua | b, a | ub)  # one of the touched pair must be open
        ok = np.where(at_corner, diag_1 & side_1, a & b)
        np.logical_or.at(blocked, k[~ok], True)
    return blocked


def parse_map(text: str, *, name: str = "map", source: str = "<memory>") -> GridMap:
    """Parse the plain-text map format.

    Parameters
    ----------
    text : str
        The map's text, in the legend of this module.
    name : str, default "map"
        The map's name.
    source : str, default "<memory>"
        Where the text came from; messages name it.

    Returns
    -------
    GridMap
        The map, its visibility order computed on first use.

    Raises
    ------
    MapError
        An empty or ragged map, an unknown character, not exactly one ``L``, no goal, fewer than
        two hallway cells, or a map larger than :data:`MAX_MAP_SIDE` on a side.
    """
    # (line number in the text, line): errors name the text's own line, comments counted
    numbered = [
        (i, ln.rstrip("\r\n"))
        for i, ln in enumerate(text.splitlines(), 1)
        if not ln.startswith(";")
    ]
    while numbered and not numbered[-1][1].strip():
        numbered.pop()
    while numbered and not numbered[0][1].strip():  # blank lines above the map, as below it
        numbered.pop(0)
    lines = [ln for _, ln in numbered]
    if not lines:
        raise MapError(f"{source}: map is empty")
    width = len(lines[0])
    if len(lines) > MAX_MAP_SIDE or width > MAX_MAP_SIDE:
        raise MapError(
            f"{source}: map of {len(lines)}x{width} cells is larger than the limit of "
            f"{MAX_MAP_SIDE}x{MAX_MAP_SIDE}"
        )
    for i, ln in numbered:
        if len(ln) != width:
            raise MapError(f"{source}: line {i} has {len(ln)} cells, expected {width}")
        bad = set(ln) - _LEGEND
        if bad:
            raise MapError(f"{source}: line {i} has unknown character {sorted(bad)[0]!r}")
    chars = np.array([list(ln) for ln in lines])
    starts = np.argwhere(chars == "L")
    if len(starts) != 1:
        raise MapError(f"{source}: expected exactly one 'L' (observer start), found {len(starts)}")
    goals = [(int(r), int(c)) for r, c in np.argwhere((chars == "G") | (chars == "g"))]
    if not goals:
        raise MapError(f"{source}: no goal cell ('G' or 'g')")
    patroller = (chars == ".") | (chars == "G")
    if patroller.sum() < 2:
        raise MapError(f"{source}: fewer than 2 hallway cells")
    return GridMap(
        name=name,
        patroller=patroller,
        observer_only=(chars == "L") | (chars == "g"),
        observer_start=(int(starts[0][0]), int(starts[0][1])),
        goals=tuple(goals),
        source=source,
    )


def dead_ends(gridmap: GridMap) -> tuple[tuple[int, int], ...]:
    """Patroller cells with exactly one patroller neighbour: where a patrol must turn around.

    Parameters
    ----------
    gridmap : GridMap
        The map.

    Returns
    -------
    tuple of (int, int)
        The dead ends' (row, col), row-major.
    """
    P = np.pad(gridmap.patroller, 1)
    neighbours = P[:-2, 1:-1].astype(int) + P[2:, 1:-1] + P[1:-1, :-2] + P[1:-1, 2:]
    ends = np.argwhere(gridmap.patroller & (neighbours == 1))
    return tuple((int(r), int(c)) for r, c in ends)
