"""Line of sight over a grid written from its geometric definition, in exact rational arithmetic:
the independent reference for :func:`mirl.world.maps.line_of_sight`.

Cell (r, c) is the open square of side 1 centred at (r, c). The segment from the centre of the
origin to the centre of a target is blocked when it meets the interior of a closed cell, or
when it passes through a grid corner where two diagonal cells are both closed.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

HALF = Fraction(1, 2)


def _open_interval(p0: int, d: int, lo: Fraction, hi: Fraction):
    """Open interval of t in which p0 + t·d lies strictly inside (lo, hi); None if empty."""
    if d == 0:
        return (Fraction(-1), Fraction(2)) if lo < p0 < hi else None
    a, b = (lo - p0) / d, (hi - p0) / d
    return (min(a, b), max(a, b))


def _crosses_interior(origin, target, cell) -> bool:
    (r0, c0), (r1, c1) = origin, target
    lo, hi = Fraction(0), Fraction(1)
    for p0, d, centre in ((r0, r1 - r0, cell[0]), (c0, c1 - c0, cell[1])):
        span = _open_interval(p0, d, centre - HALF, centre + HALF)
        if span is None:
            return False
        lo, hi = max(lo, span[0]), min(hi, span[1])
    return lo < hi


def _squeezed(origin, target, closed) -> bool:
    """Whether the segment passes through a corner between two diagonally closed cells."""
    (r0, c0), (r1, c1) = origin, target
    dr, dc = r1 - r0, c1 - c0
    if dr == 0 or dc == 0:
        return False
    for j in range(1, abs(dc) + 1):  # the crossings of vertical grid lines
        t = Fraction(2 * j - 1, 2 * abs(dc))
        r = r0 + dr * t
        if (r + HALF).denominator != 1:
            continue
        below = int(r + HALF)
        c = c0 + int(np.sign(dc)) * (j - 1)
        c2 = c0 + int(np.sign(dc)) * j
        quad = [(below - 1, c), (below - 1, c2), (below, c), (below, c2)]
        shut = [closed(q) for q in quad]
        if (shut[0] and shut[3]) or (shut[1] and shut[2]):
            return True
    return False


def line_of_sight(open_cells: np.ndarray, origin: tuple[int, int]) -> np.ndarray:
    rows, cols = open_cells.shape

    def closed(cell) -> bool:
        r, c = cell
        if (r, c) == tuple(origin):
            return False
        return not (0 <= r < rows and 0 <= c < cols and open_cells[r, c])

    walls = [tuple(w) for w in np.argwhere(~open_cells).tolist() if tuple(w) != tuple(origin)]
    out = np.zeros_like(open_cells, dtype=bool)
    for target in map(tuple, np.argwhere(open_cells).tolist()):
        hit = any(_crosses_interior(origin, target, w) for w in walls)
        out[target] = not hit and not _squeezed(origin, target, closed)
    return out
