"""Temporary home of :class:`MapFrame` until the layout (issue 9) adds it to ``mirl.world.maps``.

The map frame ties grid cells to metres: x east (growing with the column), y north (growing
with decreasing row); ``origin_x, origin_y`` are the map-frame coordinates of the centre of
cell (0, 0). Heading 0 (east) is yaw 0, 1 (north) yaw π/2, 2 (west) yaw π, 3 (south) yaw −π/2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MapFrame", "map_frame"]


@dataclass(frozen=True)
class MapFrame:
    cell_size: float = 1.0  # metres per grid cell
    origin_x: float = 0.0  # map-frame x of the centre of cell (0, 0)
    origin_y: float = 0.0  # map-frame y of the centre of cell (0, 0)

    def cell_centre(self, row, col):
        """Map-frame (x, y) of cell centres (arrays ok)."""
        return (
            self.origin_x + np.asarray(col, dtype=float) * self.cell_size,
            self.origin_y - np.asarray(row, dtype=float) * self.cell_size,
        )

    def cell_coordinates(self, x, y):
        """Fractional (row, col) of map-frame points; the centre of cell (r, c) is (r, c)."""
        return (
            (self.origin_y - np.asarray(y, dtype=float)) / self.cell_size,
            (np.asarray(x, dtype=float) - self.origin_x) / self.cell_size,
        )


def map_frame(gridmap) -> MapFrame:
    """The map's frame, or the default one (1 m cells, cell (0, 0) centred on the origin)."""
    return getattr(gridmap, "frame", None) or MapFrame()
