"""Costmap: costmap_2d's inflation numbers, the scan's obstacles (kept only until the next scan), rviz's values."""
from __future__ import annotations

import math

import numpy as np
import pytest

from navigation.costmap import INSCRIBED, LETHAL, NO_INFORMATION, Costmap, InflationParams, costmap_msg, inflate
from subsumption.mapfile import OccupancyMap

PARAMS = InflationParams(robot_radius=0.18, inflation_radius=0.55, cost_scaling_factor=10.0)


def test_inflation_follows_costmap_2d():
    obstacles = np.zeros((41, 41), dtype=bool)
    obstacles[20, 20] = True
    costs = inflate(obstacles, 0.05, PARAMS)
    assert costs[20, 20] == LETHAL
    rows, cols = np.indices(costs.shape)
    distance = np.hypot(rows - 20, cols - 20) * 0.05
    assert (costs[(distance > 0) & (distance <= 0.18)] == INSCRIBED).all()
    ring = (distance > 0.18) & (distance <= 0.55)
    expected = np.clip(np.round(252 * np.exp(-10.0 * (distance[ring] - 0.18))), 1, 252)
    assert np.array_equal(costs[ring], expected)
    assert (costs[distance > 0.55] == 0).all()
    assert costs[20, 20 + 4] == 252 * 0 + round(252 * math.exp(-10 * (0.2 - 0.18)))  # 0.2 m away


def test_unknown_space_tracked_only_when_asked():
    occ = np.zeros((20, 20), dtype=np.int8)
    occ[:, 15:] = -1
    grid = OccupancyMap(occ, 0.05, (0.0, 0.0))
    assert (Costmap(grid, PARAMS).costs[:, 15:] == 0).all()
    tracked = Costmap(grid, InflationParams(track_unknown_space=True))
    assert (tracked.costs[:, 15:] == NO_INFORMATION).all()


def test_scan_obstacles_mark_and_are_forgotten_with_the_next_scan():
    occ = np.zeros((40, 40), dtype=np.int8)
    costmap = Costmap(OccupancyMap(occ, 0.05, (-1.0, -1.0)), PARAMS)
    assert costmap.costs.max() == 0
    costmap.set_scan_points(np.array([[0.0, 0.0], [5.0, 5.0]]))  # the second is off the map: ignored
    assert costmap.cost_at(0.01, 0.01) == LETHAL and costmap.cost_at(0.15, 0.0) == INSCRIBED
    costmap.set_scan_points(np.zeros((0, 2)))
    assert costmap.cost_at(0.01, 0.01) == 0
    assert costmap.cost_at(3.0, 0.0) == NO_INFORMATION  # off the map


def test_costmap_message_uses_rviz_values_and_the_map_frame():
    costs = np.array([[0, 126, 252], [253, 254, 255]], dtype=np.uint8)
    msg = costmap_msg(costs, OccupancyMap(np.zeros((2, 3), np.int8), 0.05, (1.0, 2.0)), 3.0, "map")
    assert list(msg.data) == [0, 49, 98, 99, 100, -1]
    assert msg.header.frame_id == "map" and msg.info.width == 3 and msg.info.height == 2
    assert msg.info.origin.position.x == pytest.approx(1.0)


def test_scan_obstacles_inflated_in_a_window_give_the_whole_map_inflation():
    """Only the scan's neighbourhood is inflated again: the result must equal inflating the whole map."""
    rng = np.random.default_rng(3)
    occ = np.zeros((120, 160), dtype=np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[rng.integers(0, 120, 60), rng.integers(0, 160, 60)] = 100
    occ[50:55, 70:90] = -1
    grid = OccupancyMap(occ, 0.05, (-1.0, 2.0))
    params = InflationParams(track_unknown_space=True)
    costmap = Costmap(grid, params)
    points = np.column_stack((rng.uniform(1.0, 4.0, 40), rng.uniform(3.0, 6.0, 40)))
    costmap.set_scan_points(points)
    obstacles = costmap.static.copy()
    rows, cols = costmap.scan_cells()
    obstacles[rows, cols] = True
    np.testing.assert_array_equal(costmap.costs, inflate(obstacles, 0.05, params, costmap.unknown))
