"""The global planner: known shortest paths, no path through a wall, A*'s cost equal to a reference Dijkstra's,
and the same with landmarks as without."""
from __future__ import annotations

import math

import numpy as np
import pytest
from skimage.graph import MCP_Geometric

from navigation.costmap import INSCRIBED, Costmap, InflationParams
from navigation.landmarks import build, relaxed_weights, relaxes, step_weights
from navigation.planner import LANDMARKS, PlanError, PlannerParams, search, plan, plan_cells
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
    landmarks = build(costs, relaxed_weights(0.0, INSCRIBED), 3, seed=5 * 150 + 5)
    _, with_marks = plan_cells(costs, (5, 5), (110, 140), PlannerParams(cost_factor=0.0, shorten=False),
                               landmarks=landmarks)
    assert with_marks == pytest.approx(reference, rel=1e-3)
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


def inflated_maze(seed: int) -> np.ndarray:
    """A 120 x 150 costmap with walls, inflation costs and a closed pocket: what the landmarks must bound."""
    rng = np.random.default_rng(seed)
    occ = np.zeros((120, 150), dtype=np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    for col in range(20, 150, 25):  # walls across, each with a gap somewhere
        occ[:, col] = 100
        gap = int(rng.integers(5, 110))
        occ[gap:gap + 6, col] = 0
    occ[rng.random(occ.shape) < 0.02] = 100
    occ[50:60, 60:70] = 100
    occ[52:58, 62:68] = 0  # a pocket no start reaches
    return costmap_of(occ, radius=0.1).static_costs


@pytest.mark.parametrize("seed", [1, 2])
def test_landmarks_leave_the_cost_exact_and_search_less(seed):
    costs = inflated_maze(seed)
    params = PlannerParams(cost_factor=3.0, shorten=False, landmarks=0)
    relaxed = relaxed_weights(3.0, INSCRIBED)
    free = np.argwhere(costs < INSCRIBED)
    landmarks = build(costs, relaxed, 4, seed=int(free[0][0] * costs.shape[1] + free[0][1]))
    assert len(landmarks.cells) == 4
    # the live costmap: the static one with a few scan obstacles (only dearer), as the planner gets it
    live = costs.copy()
    live[30:33, 40:90] = 254
    assert relaxes(costs, live, relaxed, step_weights(3.0, True, INSCRIBED))
    rng = np.random.default_rng(seed)
    closed_octile = closed_marks = 0
    for _ in range(15):
        a, b = (tuple(int(v) for v in free[i]) for i in rng.integers(len(free), size=2))
        for grid in (costs, live):
            try:
                cells, total, closed = search(grid, a, b, params, INSCRIBED, None)
            except PlanError:
                with pytest.raises(PlanError):
                    search(grid, a, b, params, INSCRIBED, landmarks)
                continue
            cells2, total2, closed2 = search(grid, a, b, params, INSCRIBED, landmarks)
            assert total2 == pytest.approx(total, rel=1e-6)  # same cost (the 1e-4 tie-break aside, exact)
            closed_octile += closed
            closed_marks += closed2
    assert closed_marks < 0.8 * closed_octile


def test_a_cell_cheaper_than_on_the_static_map_is_found():
    costs = inflated_maze(3)
    relaxed = relaxed_weights(3.0, INSCRIBED)
    weight = step_weights(3.0, True, INSCRIBED)
    freed = costs.copy()
    freed[costs == 254] = 0  # an obstacle of the map gone: the landmarks' bound could overshoot there
    assert not relaxes(costs, freed, relaxed, weight)
    inscribed = costs.copy()
    inscribed[costs == INSCRIBED] = 252  # what plan() does round a start in a wall's inflation: still bounded
    assert relaxes(costs, inscribed, relaxed, weight)


def test_plan_builds_landmarks_once_searching_has_cost_as_much():
    costmap = Costmap(OccupancyMap(np.where(inflated_maze(4) == 254, 100, 0).astype(np.int8), 0.05, (0.0, 0.0)),
                      InflationParams(robot_radius=0.1, inflation_radius=0.3))
    free = np.argwhere(costmap.static_costs == 0)
    rng = np.random.default_rng(4)
    costs_seen = []
    for k in range(40):
        a, b = (costmap.centres_of(*free[i])[0] for i in rng.integers(len(free), size=2))
        try:
            costs_seen.append(plan(costmap, tuple(a), tuple(b)).cost)
        except PlanError:
            continue
        state, landmarks = LANDMARKS.get(costmap, costmap.static_costs, 3.0, INSCRIBED, 4)
        if landmarks is not None:
            break
        assert state.closed < 5 * state.enterable  # not built before the searches cost as much as a build
    assert landmarks is not None and len(landmarks.cells) == 4
    # once built, the same plans cost the same as with the octile heuristic alone
    octile = PlannerParams(landmarks=0)
    for _ in range(10):
        a, b = (tuple(costmap.centres_of(*free[i])[0]) for i in rng.integers(len(free), size=2))
        try:
            with_marks = plan(costmap, a, b).cost
        except PlanError:
            continue
        assert with_marks == pytest.approx(plan(Costmap(costmap.grid, costmap.params), a, b, octile).cost, rel=1e-6)


def _held_build(monkeypatch) -> "threading.Event":
    """Make the landmarks' build wait until the returned event is set (at most 30 s, then the build fails), so
    that a test can plan while a background build is certainly under way."""
    import threading

    from navigation import landmarks as module

    gate = threading.Event()
    real = module.build

    def held(*args, **kwargs):
        if not gate.wait(30.0):
            raise RuntimeError("the test never let the build finish")
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "build", held)
    return gate


def test_plans_while_the_landmarks_are_built_in_the_background_are_the_octile_plans(monkeypatch):
    gate = _held_build(monkeypatch)
    costmap = Costmap(OccupancyMap(np.where(inflated_maze(4) == 254, 100, 0).astype(np.int8), 0.05, (0.0, 0.0)),
                      InflationParams(robot_radius=0.1, inflation_radius=0.3))
    octile_map = Costmap(costmap.grid, costmap.params)
    octile = PlannerParams(landmarks=0)
    free = np.argwhere(costmap.static_costs == 0)
    rng = np.random.default_rng(4)
    pairs = [tuple(tuple(costmap.centres_of(*free[i])[0]) for i in rng.integers(len(free), size=2))
             for _ in range(80)]
    compared = 0
    for a, b in pairs:
        try:
            result = plan(costmap, a, b, background=True)
        except PlanError:
            continue
        state, landmarks = LANDMARKS.get(costmap, costmap.static_costs, 3.0, INSCRIBED, 4)
        assert landmarks is None  # none handed out while the build is held
        reference = plan(octile_map, a, b, octile)
        np.testing.assert_array_equal(result.points, reference.points)
        assert result.cost == reference.cost
        if state.builder is not None:
            assert state.builder.is_alive()  # this plan returned while the build was still waiting
            compared += 1
    assert state.builder is not None and compared >= 10  # the build started, and plans went on during it
    gate.set()
    state.builder.join(30.0)
    _, landmarks = LANDMARKS.get(costmap, costmap.static_costs, 3.0, INSCRIBED, 4)
    assert landmarks is not None and landmarks.distances.shape == (4, costmap.static_costs.size)
    for a, b in pairs[:20]:  # now with them: the same costs
        try:
            with_marks = plan(costmap, a, b, background=True).cost
        except PlanError:
            continue
        assert with_marks == pytest.approx(plan(octile_map, a, b, octile).cost, rel=1e-6)


def test_a_build_under_way_when_the_costmap_changes_is_not_handed_out(monkeypatch):
    from navigation.landmarks import LandmarkCache

    gate = _held_build(monkeypatch)
    cache = LandmarkCache()
    costmap = costmap_of(np.where(inflated_maze(2) == 254, 100, 0).astype(np.int8))
    static = costmap.static_costs
    old, _ = cache.get(costmap, static, 3.0, INSCRIBED, 2)
    cache.searched(old, 10 ** 9, int(np.flatnonzero(static == 0)[0]), background=True)
    assert old.builder is not None and old.builder.is_alive()
    changed = static.copy()  # new static costs (another map), then other planner parameters, meanwhile
    new, landmarks = cache.get(costmap, changed, 3.0, INSCRIBED, 2)
    assert new is not old and landmarks is None
    gate.set()
    old.builder.join(30.0)
    assert old.landmarks is not None  # the build finished, into the state it was started for only
    assert cache.get(costmap, changed, 3.0, INSCRIBED, 2)[1] is None
    assert cache.get(costmap, changed, 2.0, INSCRIBED, 2)[1] is None
    assert cache.get(costmap, static, 3.0, INSCRIBED, 2)[1] is None  # a new state again: built anew when due


def test_a_background_build_that_raises_is_logged_and_tried_again_after_as_many_searches(monkeypatch, caplog):
    from navigation import landmarks as module
    from navigation.landmarks import LandmarkCache

    real = module.build
    calls = []

    def fails_first(*args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise MemoryError("no room for the landmarks")
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "build", fails_first)
    cache = LandmarkCache()
    costmap = costmap_of(np.where(inflated_maze(2) == 254, 100, 0).astype(np.int8))
    static = costmap.static_costs
    seed = int(np.flatnonzero(static == 0)[0])
    state, _ = cache.get(costmap, static, 3.0, INSCRIBED, 2)
    due = 3 * state.enterable  # (count + 1) passes over the enterable cells
    with caplog.at_level("ERROR", logger="navigation.landmarks"):
        cache.searched(state, due, seed, background=True)
        state.builder.join(30.0)
    assert "octile heuristic" in caplog.text and "no room for the landmarks" in caplog.text
    assert state.failures == 1 and state.landmarks is None and state.builder is None and state.closed == 0
    cache.searched(state, due - 1, seed, background=True)  # not yet: the count started again
    assert state.builder is None and len(calls) == 1
    cache.searched(state, 1, seed, background=True)
    state.builder.join(30.0)
    assert len(calls) == 2 and state.landmarks is not None and len(state.landmarks.cells) == 2
