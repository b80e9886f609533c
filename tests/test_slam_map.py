"""The SLAM core's map is drawn when it is asked for: whenever that is, it is every keyframe's scan drawn at the
keyframe's current pose, as if drawn afresh (what `subsumption map` saves and the slam node publishes)."""
from __future__ import annotations

import math

import numpy as np

from navigation.slam_core import GraphSlam, SlamParams
from navigation.slam_grid import CountGrid
from subsumption.mapfile import FREE, OCCUPIED, OccupancyMap
from subsumption.planar import compose
from tests.support.laser_room import laser_scan, room


def _cells(grid: OccupancyMap, value: int) -> set[tuple[int, int]]:
    """The world cells (x, y in cells of the map's resolution) holding `value`, wherever the grid's origin is."""
    rows, cols = np.nonzero(grid.occupancy == value)
    x = np.round((grid.origin[0] + (cols + 0.5) * grid.resolution) / grid.resolution).astype(int)
    y = np.round((grid.origin[1] + (rows + 0.5) * grid.resolution) / grid.resolution).astype(int)
    return set(zip(x.tolist(), y.tolist()))


def test_the_map_is_every_keyframe_drawn_where_it_is_now_whenever_asked():
    """Four times round a room with odometry whose heading wanders, loop closures on: they move the keyframes after
    their scans were first drawn. The map asked for half way and again at the end equals the scans drawn afresh
    at the final poses, cell for cell."""
    grid, rng = room(), np.random.default_rng(4)
    start = np.array([1.5, 1.2, 0.0])
    slam = GraphSlam(SlamParams(), start=start)
    truth, odom = start.copy(), start.copy()
    slam.add_scan(0.0, odom, laser_scan(truth, grid, math.pi / 2))
    lap = [np.array([0.3, 0.0, 0.0])] * 27 + [np.array([0.0, 0.0, math.pi / 8])] * 4 + \
        [np.array([0.3, 0.0, 0.0])] * 16 + [np.array([0.0, 0.0, math.pi / 8])] * 4
    steps = lap * 4
    for k, step in enumerate(steps, 1):
        truth = compose(truth, step)
        odom = compose(odom, step + np.array([0.0, 0.0, 0.02 * rng.standard_normal()]))
        slam.add_scan(float(k), odom, laser_scan(truth, grid, math.pi / 2))
        if k == len(steps) // 2:
            slam.occupancy()  # asked for half way: drawn there, and moved again by the closures after
    assert slam.stats.loop_closures > 0
    built = slam.occupancy()
    fresh = CountGrid(slam.params.delta, slam.params.occ_thresh)
    for kf in slam.keyframes:
        fresh.integrate(kf.pose, kf.beams, 1.0)
    afresh = fresh.to_map()
    assert _cells(built, OCCUPIED) == _cells(afresh, OCCUPIED) and len(_cells(built, OCCUPIED)) > 100
    assert _cells(built, FREE) == _cells(afresh, FREE)
