"""The global planner: known shortest paths, no path through a wall, A*'s cost equal to a reference Dijkstra's."""
from __future__ import annotations

import math

import numpy as np
import pytest
from skimage.graph import MCP_Geometric

from navigation.costmap import Costmap, InflationParams
from navigation.planner import PlanError, PlannerParams, plan, plan_cells
from subsumption.mapfile import OccupancyMap

GEOMETRIC = PlannerParams(cost_factor=0.0, allow_unknown=False, lookahead_cells=10_000)


def room(rows: int = 60, cols: int = 80) -> np.ndarray:
    occ = np.zeros((rows, cols), dtype=np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    return occ


def costmap_of(occ: np.ndarray, radius: float = 0.1) -> Costmap:
    return Costmap(OccupancyMap(occ, 0.05, (0.0, 0.0)), InflationParams(robot_radius=radius, inflation_radius=radius))


def test_open_space_gives_the_straight_line():
    result = plan(costmap_of(room()), (0.5, 0.5), (3.5, 2.5), GEOMETRIC)
    assert result.length() == pytest.approx(math.hypot(3.0, 2.0), abs=1e-9)
    assert len(result.points) == 2


def test_the_path_goes_around_a_wall_through_its_gap_by_the_shortest_way():
    occ = room()
    occ[:, 40] = 100   # a wall across the room at x = 2.0-2.05 m
    occ[45:50, 40] = 0  # with a gap, y = 2.25-2.5 m
    costmap = costmap_of(occ, radius=0.06)  # cells within 0.06 m of the wall are closed: the gap's middle row is open
    result = plan(costmap, (0.5, 0.5), (3.5, 0.5), GEOMETRIC)
    # through the gap: the path's points must pass x = 2.0..2.05 within y 2.25..2.5
    xs = np.linspace(0, 1, 200)
    crossing = [p0 + t * (p1 - p0) for p0, p1 in zip(result.points[:-1], result.points[1:]) for t in xs]
    at_wall = [p for p in crossing if 2.0 <= p[0] <= 2.05]
    assert at_wall and all(2.25 <= p[1] <= 2.5 for p in at_wall)
    # the shortest length through the gap's open cells (rows 46-48; 45 and 49 are within 0.06 m of the wall):
    # two straight legs meeting at the lowest open cell's centre, y = 2.325
    best = min(np.hypot(2.025 - 0.5, y - 0.5) + np.hypot(3.5 - 2.025, y - 0.5) for y in (2.325, 2.375, 2.425))
    assert result.length() == pytest.approx(best, abs=1e-6)


def test_no_path_through_a_wall():
    occ = room()
    occ[:, 40] = 100
    with pytest.raises(PlanError, match="no path"):
        plan(costmap_of(occ), (0.5, 0.5), (3.5, 0.5), GEOMETRIC)


def test_goal_in_a_wall_or_off_the_map_is_refused_with_the_reason():
    occ = room()
    occ[20:30, 20:30] = 100
    costmap = costmap_of(occ)
    with pytest.raises(PlanError, match="in an obstacle"):
        plan(costmap, (0.5, 0.5), (1.25, 1.25), GEOMETRIC)
    with pytest.raises(PlanError, match="off the map"):
        plan(costmap, (0.5, 0.5), (9.0, 1.0), GEOMETRIC)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_astar_cost_equals_dijkstra_on_random_obstacles(seed):
    rng = np.random.default_rng(seed)
    costs = np.where(rng.random((120, 150)) < 0.25, 254, 0).astype(np.uint8)
    costs[5, 5] = costs[110, 140] = 0
    blocked = costs >= 253
    mcp = MCP_Geometric(np.where(blocked, np.inf, 1.0), fully_connected=True)
    cumulative, _ = mcp.find_costs([(5, 5)], [(110, 140)])
    reference = cumulative[110, 140]
    if not np.isfinite(reference):
        with pytest.raises(PlanError):
            plan_cells(costs, (5, 5), (110, 140), PlannerParams(cost_factor=0.0, shorten=False))
        return
    cells, total = plan_cells(costs, (5, 5), (110, 140), PlannerParams(cost_factor=0.0, shorten=False))
    assert total == pytest.approx(reference, rel=1e-3)
    assert not blocked[cells[:, 0], cells[:, 1]].any()
    steps = np.abs(np.diff(cells, axis=0))
    assert steps.max() <= 1  # 8-connected, no jumps


def test_inflation_cost_keeps_the_plan_off_the_walls_where_there_is_room():
    occ = room(60, 120)
    occ[30, 10:110] = 100  # a long wall in the middle; going along it from one end to the other
    costmap = Costmap(OccupancyMap(occ, 0.05, (0.0, 0.0)), InflationParams(robot_radius=0.18, inflation_radius=0.55))
    start, goal = (0.3, 1.8), (5.7, 1.8)  # 0.25 m from the wall's surface (y = 1.55)
    result = plan(costmap, start, goal, PlannerParams(cost_factor=3.0))
    t = np.linspace(0, 1, 50)[:, None]
    along = np.concatenate([p0 + t * (p1 - p0) for p0, p1 in zip(result.points[:-1], result.points[1:])])
    middle = along[(along[:, 0] > 2.0) & (along[:, 0] < 4.0)]
    assert (middle[:, 1] - 1.55).min() > 0.35  # stays further off the wall than the straight line would
    assert result.length() < 1.1 * (goal[0] - start[0])  # without a long detour
