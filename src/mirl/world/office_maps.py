"""A generated large office floor for scale tests (docs/design.md, "Generated office maps": e.g. 60
× 60 with ≥ 800 free cells).

Design: horizontal and vertical one-cell-wide corridors, evenly spread about
``corridor_spacing`` cells apart (outermost ones one cell in from the border), each interior
corridor jittered by ±1 cell while keeping at least two wall cells between parallel corridors.
The corridors cross at junctions and split into *segments* (the cells strictly between two
consecutive junctions). A share ``removal`` of the segments is then knocked out in random
order, each removal kept only if all hallway cells stay connected, which leaves dead ends and
irregular blocks like a real floor. L's start is a room cell (observer-only) in a wall block
with exactly one hallway neighbour (its door); goals are such room cells far (by hallway
distance) from L's door. Everything is drawn from ``numpy.random.default_rng(seed)``, so a seed
fixes the map.

Names: ``office`` (60 × 60, seed 0), ``office-80x80``, ``office-80x80-s3`` (rows × cols, seed);
see :func:`office_map_from_name`.
"""

from __future__ import annotations

import re

import numpy as np
from scipy import ndimage

from mirl.world.maps import HEADING_DELTAS, GridMap, MapError

__all__ = ["generate_office_map", "office_map_from_name", "OFFICE_NAME_RE"]

OFFICE_NAME_RE = re.compile(r"^office(?:-(?P<rows>\d+)x(?P<cols>\d+))?(?:-s(?P<seed>\d+))?$")

_FOUR = ndimage.generate_binary_structure(2, 1)


def _lines(size: int, spacing: int, rng: np.random.Generator) -> np.ndarray:
    """Corridor positions in [1, size - 2], about ``spacing`` apart, interior ones jittered."""
    n = max(2, int(round((size - 3) / spacing)) + 1)
    pos = np.round(np.linspace(1, size - 2, n)).astype(int)
    for i in range(1, n - 1):
        cand = pos[i] + int(rng.integers(-1, 2))
        if cand - pos[i - 1] >= 3 and pos[i + 1] - cand >= 3:
            pos[i] = cand
    return pos


def _connected(hall: np.ndarray) -> bool:
    _, n = ndimage.label(hall, structure=_FOUR)
    return n == 1


def _hall_distance(hall: np.ndarray, src: tuple[int, int]) -> np.ndarray:
    rows, cols = hall.shape
    dist = np.full(hall.shape, -1, dtype=int)
    dist[src] = 0
    frontier = [src]
    while frontier:
        nxt = []
        for r, c in frontier:
            for dr, dc in HEADING_DELTAS:
                rr, cc = r + dr, c + dc
                if 0 <= rr < rows and 0 <= cc < cols and hall[rr, cc] and dist[rr, cc] < 0:
                    dist[rr, cc] = dist[r, c] + 1
                    nxt.append((rr, cc))
        frontier = nxt
    return dist


def _door_candidates(hall: np.ndarray) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """(room cell, its door) for wall cells with exactly one hallway neighbour."""
    rows, cols = hall.shape
    out = []
    for r, c in np.argwhere(~hall):
        doors = [
            (r + dr, c + dc)
            for dr, dc in HEADING_DELTAS
            if 0 <= r + dr < rows and 0 <= c + dc < cols and hall[r + dr, c + dc]
        ]
        if len(doors) == 1:
            out.append(((int(r), int(c)), (int(doors[0][0]), int(doors[0][1]))))
    return out


def generate_office_map(
    rows: int = 60,
    cols: int = 60,
    *,
    seed: int = 0,
    corridor_spacing: int = 6,
    removal: float = 0.2,
    n_goals: int = 2,
    name: str | None = None,
) -> GridMap:
    """Generate a deterministic office floor (see the module docstring for the design).

    At the defaults (60 × 60, spacing 6, 20% of segments removed) the floor has about 950 hallway
    cells.

    Parameters
    ----------
    rows : int, default 60
        The grid's rows, at least 5.
    cols : int, default 60
        Its columns, at least 5.
    seed : int, default 0
        Seeds the corridor positions, the removed segments and the rooms.
    corridor_spacing : int, default 6
        About this many cells between parallel corridors, at least 3.
    removal : float, default 0.2
        The fraction of corridor segments removed (keeping the hallway connected), in [0, 1).
    n_goals : int, default 2
        Goal rooms placed, at least 1, in the farthest quarter of room sites from L's room.
    name : str, optional
        The map's name; ``office-{rows}x{cols}-s{seed}`` by default.

    Returns
    -------
    GridMap
        The floor, L's room its start.

    Raises
    ------
    ValueError
        Impossible parameters, or too few room sites for L and the goals.
    """
    if rows < 5 or cols < 5:
        raise ValueError(f"office map must be at least 5x5 cells, got {rows}x{cols}")
    if corridor_spacing < 3:
        raise ValueError(f"corridor_spacing must be >= 3, got {corridor_spacing}")
    if not 0.0 <= removal < 1.0:
        raise ValueError(f"removal must be in [0, 1), got {removal}")
    if n_goals < 1:
        raise ValueError(f"n_goals must be >= 1, got {n_goals}")
    rng = np.random.default_rng(seed)
    hr = _lines(rows, corridor_spacing, rng)  # rows of horizontal corridors
    vc = _lines(cols, corridor_spacing, rng)  # cols of vertical corridors

    hall = np.zeros((rows, cols), dtype=bool)
    c0, c1 = vc[0], vc[-1]
    r0, r1 = hr[0], hr[-1]
    hall[hr, c0 : c1 + 1] = True
    hall[r0 : r1 + 1, vc] = True

    # segments: cells strictly between consecutive junctions
    segments: list[tuple[np.ndarray, np.ndarray]] = []
    for r in hr:
        for a, b in zip(vc[:-1], vc[1:], strict=True):
            cs = np.arange(a + 1, b)
            segments.append((np.full_like(cs, r), cs))
    for c in vc:
        for a, b in zip(hr[:-1], hr[1:], strict=True):
            rs = np.arange(a + 1, b)
            segments.append((rs, np.full_like(rs, c)))
    target = int(round(removal * len(segments)))
    removed = 0
    for k in rng.permutation(len(segments)):
        if removed >= target:
            break
        rs, cs = segments[k]
        hall[rs, cs] = False
        if _connected(hall):
            removed += 1
        else:
            hall[rs, cs] = True

    # L's room and the goal rooms: wall cells with exactly one hallway neighbour
    cands = _door_candidates(hall)
    if len(cands) < 1 + n_goals:
        raise ValueError(f"office map {rows}x{cols} has too few room sites for L and goals")
    room, door = cands[int(rng.integers(len(cands)))]
    dist = _hall_distance(hall, door)
    taken = {room}
    goals: list[tuple[int, int]] = []
    far = sorted(cands, key=lambda rd: -dist[rd[1]])
    pool = far[: max(n_goals, len(far) // 4)]  # the farthest quarter of room sites
    for i in rng.permutation(len(pool)):
        g, _ = pool[i]
        if any(abs(g[0] - t[0]) + abs(g[1] - t[1]) <= 1 for t in taken):
            continue  # keep rooms apart so each has its own walls
        goals.append(g)
        taken.add(g)
        if len(goals) == n_goals:
            break
    if len(goals) < n_goals:
        raise ValueError(f"office map {rows}x{cols}: could not place {n_goals} goal rooms")

    observer_only = np.zeros_like(hall)
    observer_only[room] = True
    for g in goals:
        observer_only[g] = True
    return GridMap(
        name=name or f"office-{rows}x{cols}-s{seed}",
        patroller=hall,
        observer_only=observer_only,
        observer_start=room,
        goals=tuple(sorted(goals)),
        source=f"generated office map ({rows}x{cols}, seed {seed})",
    )


def office_map_from_name(name: str) -> GridMap | None:
    """The generated office map for a name like ``office``, ``office-60x60``, ``office-80x80-s3``.

    Parameters
    ----------
    name : str
        The name; sizes default to 60 × 60 and the seed to 0.

    Returns
    -------
    GridMap or None
        The map, or None if ``name`` is not an office-map name (so callers can try other loaders).

    Raises
    ------
    MapError
        The name is an office map's but it cannot be generated (the message names it).
    """
    m = OFFICE_NAME_RE.match(str(name))
    if m is None:
        return None
    rows = int(m["rows"]) if m["rows"] else 60
    cols = int(m["cols"]) if m["cols"] else 60
    seed = int(m["seed"]) if m["seed"] else 0
    if rows > 1000 or cols > 1000:
        raise MapError(f"{name}: office maps are limited to 1000x1000 cells")
    try:
        return generate_office_map(rows, cols, seed=seed, name=str(name))
    except ValueError as exc:
        raise MapError(f"{name}: {exc}") from None
