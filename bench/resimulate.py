"""A real log re-simulated with exact truth: the same building, the same path, every scan cast again.

A corrected log's reference poses are someone's map, good to a few cm and a fraction of a degree per pose
(docs/real_data.md, "How good is the reference?"); a mapper scored against them cannot tell its own error from the
reference's below that. Re-simulated, the log's geometry and motion stay (its corridors, doors, clutter and the
robot's path and scan spacing) and the truth is exact:

* **The world** is drawn from the log's own scans at their reference poses: each scan's hits joined into walls where
  neighbouring beams hit within ``LINK`` m (or ``LINK_SHARE`` of the range), every scan's walls drawn ``SPREAD`` m
  thick either side on 1 cm cells, and the band they make thinned to its middle line (scikit-image's skeleton),
  2 cm thick. The reference's poses are good to a fraction of a degree, so the scans lay each wall down a few cm
  apart; drawn as they are, the wall a ray hits would depend on where it came from, and a wall seen once with
  gaps between its beams would let rays through into the rooms behind it, as the log's laser never saw.
* **The scans** are cast again (:func:`subsim.raycast.cast_rays`) from each reference pose and laser mount, at the
  log's own beam angles and range limit, with Gaussian range noise of ``RANGE_NOISE`` (a SICK LMS's is about 1 cm).

The stamps, the reference poses (now the truth) and the mount are the log's; odometry is drifted from the truth as
for the log itself (:func:`navigation.carmen.drifted`). What the re-simulation lacks: people who move, glass, beams
that graze an edge, a laser's skew while turning; what it adds: spurs of a few cm where a thinned wall branches. ``python -m bench.real_laser --resimulate`` maps such logs.
"""
from __future__ import annotations

import copy

import cv2
import numpy as np
from skimage.morphology import skeletonize

from navigation.carmen import CarmenLog, CarmenScan
from subsim.raycast import cast_rays
from subsumption.planar import compose

RESOLUTION = 0.01  # m per cell of the drawn world
SPREAD = 0.04  # m: each scan's walls are drawn this thick either side before they are thinned to one line
LINK, LINK_SHARE = 0.3, 0.05  # neighbouring hits within this many m, or this share of the range, are one wall
RANGE_NOISE = 0.01  # m, standard deviation of the cast ranges
MAX_RANGE = 30.0  # m: hits beyond are not drawn and not cast (bench.real_laser's --max-range default)


def _scan_hits(scan: CarmenScan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(laser pose (3,), beam angles in the map frame (n,), hit points (n, 2), NaN where no hit) of a log scan at its
    reference pose."""
    laser = compose(scan.pose, scan.mount)
    angles = laser[2] + scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    ranges = np.asarray(scan.ranges, dtype=float)
    hit = np.isfinite(ranges) & (ranges > 0.05) & (ranges < MAX_RANGE)
    points = np.column_stack((laser[0] + ranges * np.cos(angles), laser[1] + ranges * np.sin(angles)))
    points[~hit] = np.nan
    return laser, angles, points


def world_of(log: CarmenLog) -> tuple[np.ndarray, tuple[float, float]]:
    """The log's walls as a solid grid (uint8, rows: y) at RESOLUTION and its origin (x, y of cell (0, 0))."""
    return _world([_scan_hits(scan) for scan in log.scans])


def _world(scans: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> tuple[np.ndarray, tuple[float, float]]:
    """:func:`world_of` from each scan's (laser pose, beam angles, hit points) as :func:`_scan_hits` gives them."""
    every = np.vstack([points[np.isfinite(points[:, 0])] for _, _, points in scans])
    low = every.min(axis=0) - 2.0
    cols, rows = (np.ceil((every.max(axis=0) + 2.0 - low) / RESOLUTION).astype(int) + 1).tolist()
    band = np.zeros((rows, cols), np.uint8)
    width = 2 * round(SPREAD / RESOLUTION) + 1
    for laser, _, points in scans:
        segments = _segments(laser, points)
        if len(segments):
            cv2.polylines(band, list(np.round((segments - low) / RESOLUTION).astype(np.int32)), False, 1,
                          thickness=width)
    middle = skeletonize(band.astype(bool)).astype(np.uint8)
    solid = cv2.dilate(middle, np.ones((2, 2), np.uint8))
    return solid, (float(low[0]), float(low[1]))


def _segments(laser: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(k, 2, 2): one scan's wall segments, neighbouring hits joined where they lie within LINK m or LINK_SHARE of
    the range."""
    a, b = points[:-1], points[1:]
    reach = np.hypot(b[:, 0] - laser[0], b[:, 1] - laser[1])
    with np.errstate(invalid="ignore"):
        linked = np.hypot(*(b - a).T) < np.maximum(LINK, LINK_SHARE * reach)  # False where either end is NaN
    return np.stack([a[linked], b[linked]], axis=1)


def resimulated(log: CarmenLog, seed: int = 1) -> CarmenLog:
    """A copy of corrected `log` whose scans are cast again in :func:`world_of` from their reference poses."""
    hits = [_scan_hits(scan) for scan in log.scans]
    solid, (x0, y0) = _world(hits)
    distance = cv2.distanceTransform((1 - solid).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    wall_distance = (distance * RESOLUTION).astype(np.float32)
    rng = np.random.default_rng([28, 52, seed])
    out = copy.copy(log)
    out.scans = []
    for scan, (laser, angles, _) in zip(log.scans, hits):
        n = len(angles)
        ranges = cast_rays(solid, wall_distance, x0, y0, RESOLUTION, np.full(n, laser[0]), np.full(n, laser[1]),
                           angles, np.full(n, MAX_RANGE), np.zeros((0, 3)))
        ranges = np.where(np.isfinite(ranges), ranges + rng.normal(0.0, RANGE_NOISE, n), np.inf)
        again = copy.copy(scan)
        again.ranges = ranges
        out.scans.append(again)
    return out
