"""One map drawn on one matplotlib axis, for the pictures `subsumption map --bag` and `subsumption localize` write:
the grid in map_server's grey levels (or another image over the same cells), cropped to its walls."""
from __future__ import annotations

import numpy as np

from subsumption.mapfile import OCCUPIED, OccupancyMap

MARGIN_M = 1.0  # room kept round the walls when cropping


def walls_extent(grid: OccupancyMap) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the occupied cells and MARGIN_M round them (the whole grid without any): rays
    with no return draw free space far beyond a building's walls."""
    rows, cols = np.nonzero(grid.occupancy == OCCUPIED)
    if not len(rows):
        return grid.extent()
    x0, y0, cell = grid.origin[0], grid.origin[1], grid.resolution
    return (x0 + cols.min() * cell - MARGIN_M, x0 + cols.max() * cell + MARGIN_M,
            y0 + rows.min() * cell - MARGIN_M, y0 + rows.max() * cell + MARGIN_M)


def draw_map(ax, grid: OccupancyMap, image: np.ndarray | None = None) -> None:
    """Show the grid (:meth:`OccupancyMap.draw`: its grey levels, or `image` over its cells) on `ax`, equal axes,
    cropped to :func:`walls_extent`."""
    grid.draw(ax, image)
    ax.set_aspect("equal")
    xmin, xmax, ymin, ymax = walls_extent(grid)
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
