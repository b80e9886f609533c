"""Exact nearest-neighbour search in the plane on a bucket grid (numba), for scan matching's target clouds.

Why not a kd-tree: scan matching builds a new target cloud (the local map: about 40 keyframes' points, 2-17
thousand) for every keyframe and queries it only some 20 times with 200 points, searching no farther than
0.5 m. With scipy's cKDTree, building the trees and querying them took about half of SLAM's time (a profile of
the room with the laser).
Points sorted into square buckets (a counting sort, linear time) and searched ring by ring outwards from the
query's bucket give the same nearest neighbours (exact, not approximate) for a fraction of the cost: a ring
``r`` buckets out lies at least ``r - 1`` bucket widths away (plus the query's distance from its own bucket's
nearest side), so the search stops as soon as the best distance found is within that, or at the bound.

:class:`BucketGrid.query` answers like ``cKDTree.query(x, distance_upper_bound=d)``: distance ``inf`` and index
``n`` (the number of points) where nothing lies within ``d``.
"""
from __future__ import annotations

import math

import numba
import numpy as np

BUCKET = 0.05  # m: the bucket width (a map cell); the searches ask for 0.1-0.5 m
MAX_BUCKETS = 4_000_000  # buckets at most (a cloud spread wider gets wider buckets)


@numba.njit(cache=True, nogil=True)
def _bounds(points):
    """(min x, min y, max x, max y): numpy's min over axis 0 of an (n, 2) array is ten times slower."""
    x0, y0, x1, y1 = np.inf, np.inf, -np.inf, -np.inf
    for i in range(points.shape[0]):
        x0, x1 = min(x0, points[i, 0]), max(x1, points[i, 0])
        y0, y1 = min(y0, points[i, 1]), max(y1, points[i, 1])
    return x0, y0, x1, y1


@numba.njit(cache=True, nogil=True)
def _build(points, x0, y0, width, cols, rows):
    """(order, start): points' indices sorted by bucket, and where each bucket's run starts (rows*cols + 1)."""
    n = points.shape[0]
    cell = np.empty(n, np.int64)
    start = np.zeros(rows * cols + 1, np.int64)
    for i in range(n):
        c = min(cols - 1, max(0, int((points[i, 0] - x0) / width)))
        r = min(rows - 1, max(0, int((points[i, 1] - y0) / width)))
        cell[i] = r * cols + c
        start[cell[i] + 1] += 1
    for k in range(rows * cols):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    order = np.empty(n, np.int64)
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return order, start


@numba.njit(cache=True, nogil=True)
def _query(points, order, start, x0, y0, width, cols, rows, queries, bound, query_normals, point_normals):
    m = queries.shape[0]
    facing = query_normals.shape[0] > 0
    n = points.shape[0]
    dist = np.full(m, np.inf)
    index = np.full(m, n, np.int64)
    rings = int(math.ceil(bound / width)) + 1
    bound2 = bound * bound
    for q in range(m):
        qx, qy = queries[q, 0], queries[q, 1]
        fc, fr = (qx - x0) / width, (qy - y0) / width
        qc, qr = int(math.floor(fc)), int(math.floor(fr))
        best, best_i = bound2, -1
        # how far the query lies inside its own bucket from each side (in widths)
        inside = min(fc - qc, qc + 1 - fc, fr - qr, qr + 1 - fr)
        for ring in range(rings + 1):
            # every point in this ring or beyond lies outside the square of the rings before, at least
            # (ring - 1 + inside) widths away (buckets at the grid's edge hold the points beyond it, clamped)
            if ring >= 1:
                near = (ring - 1 + inside) * width
                if near * near > best:
                    break
            for r in range(qr - ring, qr + ring + 1):
                if r < 0 or r >= rows:
                    continue
                edge_row = r == qr - ring or r == qr + ring
                step = 1 if edge_row else 2 * ring
                c = qc - ring
                while c <= qc + ring:
                    if 0 <= c < cols:
                        k = r * cols + c
                        for j in range(start[k], start[k + 1]):
                            p = order[j]
                            if facing and (query_normals[q, 0] * point_normals[p, 0]
                                           + query_normals[q, 1] * point_normals[p, 1]) <= 0.0:
                                continue
                            dx, dy = points[p, 0] - qx, points[p, 1] - qy
                            d2 = dx * dx + dy * dy
                            if d2 < best or (d2 == best and best_i >= 0 and p < best_i):
                                best, best_i = d2, p
                    c += step
        if best_i >= 0:
            dist[q] = math.sqrt(best)
            index[q] = best_i
    return dist, index


class BucketGrid:
    """Points (n, 2) sorted into square buckets; see the module's doc."""

    def __init__(self, points: np.ndarray, width: float = BUCKET) -> None:
        self.points = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
        x0, y0, x1, y1 = _bounds(self.points) if len(self.points) else (0.0, 0.0, 0.0, 0.0)
        if not all(map(math.isfinite, (x0, y0, x1, y1))):
            raise ValueError("BucketGrid: points must be finite")
        low, span = np.array([x0, y0]), np.array([x1 - x0, y1 - y0])
        while (int(span[0] / width) + 1) * (int(span[1] / width) + 1) > MAX_BUCKETS:
            width *= 2.0
        self.width = float(width)
        self.x0, self.y0 = float(low[0]), float(low[1])
        self.cols, self.rows = int(span[0] / width) + 1, int(span[1] / width) + 1
        self.order, self.start = _build(self.points, self.x0, self.y0, self.width, self.cols, self.rows)

    def __len__(self) -> int:
        return len(self.points)

    def query(self, queries: np.ndarray, distance_upper_bound: float,
              facing: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(distances, indices) of each query point's nearest point within the bound (inf and n where none). With
        `facing` (the queries' normals, the points' normals), only points whose normal faces the query's way
        count."""
        queries = np.ascontiguousarray(queries, dtype=float).reshape(-1, 2)
        if not math.isfinite(distance_upper_bound) or distance_upper_bound <= 0:
            raise ValueError(f"BucketGrid.query: distance_upper_bound must be finite and > 0, "
                             f"got {distance_upper_bound}")
        query_normals, point_normals = (np.zeros((0, 2)), np.zeros((0, 2))) if facing is None else \
            (np.ascontiguousarray(facing[0], dtype=float), np.ascontiguousarray(facing[1], dtype=float))
        if facing is not None and (query_normals.shape != queries.shape or point_normals.shape != self.points.shape):
            raise ValueError(f"BucketGrid.query: facing needs a normal per query ({len(queries)}) and per point "
                             f"({len(self.points)}), got {len(query_normals)} and {len(point_normals)}")
        return _query(self.points, self.order, self.start, self.x0, self.y0, self.width, self.cols, self.rows,
                      queries, float(distance_upper_bound), query_normals, point_normals)
