"""Scoring a built map and a SLAM trajectory against the truth the simulator knows (never fed to SLAM).

* ``ate_m``: RMS distance between SLAM's final (optimised) keyframe poses and the true poses at the same
  instants; ``ate_online_m`` the same for the pose SLAM published at every odometry message while it ran
  (``map -> odom -> base_link``), and ``ate_yaw_deg`` the RMS heading error of the keyframes.
* What the robot *saw*: its scans drawn at its true poses (every scan, not only SLAM's keyframes) on the true
  map's grid. Seen free cells are the true free cells the beams crossed; seen walls the true occupied cells
  where beams ended.
* ``free_mapped_free``: of the seen free cells, the share the built map has free;
  ``walls_within_cell``: of the seen walls, the share with an occupied built cell within one cell (8-
  neighbourhood); ``occupied_precision``: of the built map's occupied cells, the share within one cell of a
  true wall (how few walls it invented).
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from navigation.scan_geometry import Beams
from subsumption.planar import wrap
from navigation.slam_grid import CountGrid
from subsumption.mapfile import FREE, OCCUPIED, OccupancyMap


def _lookup(grid: OccupancyMap, xs: np.ndarray, ys: np.ndarray, outside: int = -1) -> np.ndarray:
    """Values of `grid` at world points (outside the grid: `outside`)."""
    rows = np.floor((ys - grid.origin[1]) / grid.resolution).astype(int)
    cols = np.floor((xs - grid.origin[0]) / grid.resolution).astype(int)
    inside = (rows >= 0) & (rows < grid.shape[0]) & (cols >= 0) & (cols < grid.shape[1])
    out = np.full(xs.shape, outside, dtype=grid.occupancy.dtype)
    out[inside] = grid.occupancy[rows[inside], cols[inside]]
    return out


def trajectory_error(stamps: np.ndarray, poses: np.ndarray, truth: dict[float, np.ndarray]) -> tuple[float, float, int]:
    """(RMS position error m, RMS yaw error deg, poses compared) of poses at stamps against truth by stamp."""
    errors, yaw_errors = [], []
    for t, p in zip(stamps, poses):
        true = truth.get(round(float(t), 3))
        if true is not None:
            errors.append(math.hypot(p[0] - true[0], p[1] - true[1]))
            yaw_errors.append(float(wrap(p[2] - true[2])))
    if not errors:
        return math.nan, math.nan, 0
    return (float(np.sqrt(np.mean(np.square(errors)))), math.degrees(float(np.sqrt(np.mean(np.square(yaw_errors))))),
            len(errors))


def seen_cells(truth: OccupancyMap, scans: list[tuple[np.ndarray, Beams]]) -> tuple[np.ndarray, np.ndarray]:
    """(seen free, seen walls) boolean masks on the true map's grid, from scans drawn at true poses."""
    counts = CountGrid(truth.resolution, margin=0.0)
    counts.origin = truth.origin
    counts.hits = np.zeros(truth.shape, dtype=np.float32)
    counts.visits = np.zeros(truth.shape, dtype=np.float32)
    for pose, beams in scans:
        counts.integrate(pose, beams)  # hits are carried into the wall cell they hit (CountGrid.integrate)
    if counts.shape != truth.shape:  # grew: the scans reached beyond the true map
        raise ValueError("scans reach beyond the true map")
    seen_free = (counts.visits > 0) & (truth.occupancy == FREE)
    seen_walls = (counts.hits > 0) & (truth.occupancy == OCCUPIED)
    return seen_free, seen_walls


def map_quality(built: OccupancyMap, truth: OccupancyMap, seen_free: np.ndarray, seen_walls: np.ndarray) -> dict:
    res = truth.resolution
    rows, cols = np.nonzero(seen_free)
    xs, ys = truth.origin[0] + (cols + 0.5) * res, truth.origin[1] + (rows + 0.5) * res
    free_ok = _lookup(built, xs, ys) == FREE
    near_built = cv2.dilate((built.occupancy == OCCUPIED).astype(np.uint8), np.ones((3, 3), np.uint8))
    near = OccupancyMap(near_built.astype(np.int8), built.resolution, built.origin)
    rows, cols = np.nonzero(seen_walls)
    xs, ys = truth.origin[0] + (cols + 0.5) * res, truth.origin[1] + (rows + 0.5) * res
    walls_ok = _lookup(near, xs, ys, outside=0) == 1
    near_truth = cv2.dilate((truth.occupancy == OCCUPIED).astype(np.uint8), np.ones((3, 3), np.uint8))
    near_t = OccupancyMap(near_truth.astype(np.int8), truth.resolution, truth.origin)
    rows, cols = np.nonzero(built.occupancy == OCCUPIED)
    xs, ys = built.origin[0] + (cols + 0.5) * built.resolution, built.origin[1] + (rows + 0.5) * built.resolution
    invented_ok = _lookup(near_t, xs, ys, outside=0) == 1
    return {
        "seen_free_cells": int(seen_free.sum()),
        "seen_wall_cells": int(seen_walls.sum()),
        "free_mapped_free": round(float(free_ok.mean()) if len(free_ok) else math.nan, 4),
        "walls_within_cell": round(float(walls_ok.mean()) if len(walls_ok) else math.nan, 4),
        "occupied_precision": round(float(invented_ok.mean()) if len(invented_ok) else math.nan, 4),
    }
