"""The occupancy grid a map builder draws: gmapping's counting model, on a grid that grows as the robot goes.

Per cell, ``visits`` counts the beams that reached it and ``hits`` the beams that ended on something in it;
a cell is occupied when ``hits / visits > occ_thresh`` (gmapping's ``occ_thresh``, 0.25), free when it was
visited and is not occupied, unknown when no beam reached it. Counts add up, so a scan drawn at a pose can be
taken back out exactly (weight -1) and drawn again where a loop closure moved it: the map follows the
optimised trajectory without being redrawn from scratch.

Beams are traced with exact cell traversal (Amanatides-Woo) in a numba kernel. The grid's origin stays on a
multiple of the resolution, so its cells line up with any map of the same resolution drawn from 0.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from subsumption.mapfile import FREE, OCCUPIED, UNKNOWN, OccupancyMap

from .scan_geometry import Beams
from subsumption.planar import transform_points


@numba.njit(cache=True, nogil=True)
def _trace(hits, visits, ox, oy, res, sx, sy, ex, ey, hit, weight):
    rows, cols = visits.shape
    for k in range(ex.shape[0]):
        x0, y0 = (sx - ox) / res, (sy - oy) / res
        x1, y1 = (ex[k] - ox) / res, (ey[k] - oy) / res
        c, r = int(math.floor(x0)), int(math.floor(y0))
        c_end, r_end = int(math.floor(x1)), int(math.floor(y1))
        dx, dy = x1 - x0, y1 - y0
        step_c = 1 if dx > 0 else -1
        step_r = 1 if dy > 0 else -1
        t_dc = abs(1.0 / dx) if dx != 0 else 1e30
        t_dr = abs(1.0 / dy) if dy != 0 else 1e30
        t_c = ((c + 1 - x0) if dx > 0 else (x0 - c)) * t_dc if dx != 0 else 1e30
        t_r = ((r + 1 - y0) if dy > 0 else (y0 - r)) * t_dr if dy != 0 else 1e30
        n = abs(c_end - c) + abs(r_end - r)
        for _ in range(n):
            if 0 <= r < rows and 0 <= c < cols:
                visits[r, c] += weight
            if t_c < t_r:
                c += step_c
                t_c += t_dc
            else:
                r += step_r
                t_r += t_dr
        if 0 <= r_end < rows and 0 <= c_end < cols:
            visits[r_end, c_end] += weight
            if hit[k]:
                hits[r_end, c_end] += weight


HIT_DEPTH = 0.01  # m a hit is carried beyond the surface, into the cell it hit (see Beams.extended)


class CountGrid:
    """Hit and visit counts on a growing grid; see the module's doc."""

    def __init__(self, resolution: float = 0.05, occ_thresh: float = 0.25, margin: float = 4.0) -> None:
        self.resolution = float(resolution)
        self.occ_thresh = float(occ_thresh)
        self.margin = float(margin)
        self.origin = (0.0, 0.0)
        self.hits = np.zeros((0, 0), dtype=np.float32)
        self.visits = np.zeros((0, 0), dtype=np.float32)

    @property
    def shape(self) -> tuple[int, int]:
        return self.visits.shape  # type: ignore[return-value]

    def ensure(self, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        """Grow (never shrink) so that the box lies inside, with `margin` metres to spare."""
        res = self.resolution
        rows, cols = self.shape
        ox, oy = self.origin
        if rows and xmin >= ox and ymin >= oy and xmax < ox + cols * res and ymax < oy + rows * res:
            return
        if rows:
            xmin, ymin = min(xmin, ox), min(ymin, oy)
            xmax, ymax = max(xmax, ox + cols * res), max(ymax, oy + rows * res)
        new_ox = math.floor((xmin - self.margin) / res) * res
        new_oy = math.floor((ymin - self.margin) / res) * res
        new_cols = int(math.ceil((xmax + self.margin - new_ox) / res))
        new_rows = int(math.ceil((ymax + self.margin - new_oy) / res))
        hits = np.zeros((new_rows, new_cols), dtype=np.float32)
        visits = np.zeros((new_rows, new_cols), dtype=np.float32)
        if rows:
            r0, c0 = int(round((oy - new_oy) / res)), int(round((ox - new_ox) / res))
            hits[r0:r0 + rows, c0:c0 + cols] = self.hits
            visits[r0:r0 + rows, c0:c0 + cols] = self.visits
        self.hits, self.visits, self.origin = hits, visits, (new_ox, new_oy)

    def integrate(self, pose: np.ndarray, beams: Beams, weight: float = 1.0) -> None:
        """Draw one scan taken at `pose` (map frame); weight -1 takes it back out."""
        beams = beams.extended(HIT_DEPTH)
        ends = transform_points(pose, beams.endpoints())
        start = transform_points(pose, beams.origin[None, :])[0]
        if weight > 0:
            self.ensure(min(ends[:, 0].min(initial=start[0]), start[0]), min(ends[:, 1].min(initial=start[1]), start[1]),
                        max(ends[:, 0].max(initial=start[0]), start[0]), max(ends[:, 1].max(initial=start[1]), start[1]))
        _trace(self.hits, self.visits, self.origin[0], self.origin[1], self.resolution, float(start[0]),
               float(start[1]), np.ascontiguousarray(ends[:, 0]), np.ascontiguousarray(ends[:, 1]),
               np.ascontiguousarray(beams.hit), np.float32(weight))

    def occupancy(self) -> np.ndarray:
        """int8 grid, row 0 at the lowest y: 100 occupied, 0 free, -1 unknown."""
        grid = np.full(self.shape, UNKNOWN, dtype=np.int8)
        seen = self.visits > 0.5
        occupied = seen & (self.hits > self.occ_thresh * self.visits)
        grid[seen] = FREE
        grid[occupied] = OCCUPIED
        return grid

    def to_map(self, source: str = "slam") -> OccupancyMap:
        return OccupancyMap(self.occupancy(), self.resolution, self.origin, source)
