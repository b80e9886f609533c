"""The global planner (navfn's / global_planner's job): the cheapest path on an inflated costmap.

A* on the 8-connected grid in a numba kernel: a step costs its length times ``1 + cost_factor * cost / 252``
(so the robot keeps away from walls where it can, as global_planner's ``cost_factor`` does), cells at or above
``INSCRIBED`` cannot be entered, and the heuristic is the octile distance or, once a map has been planned on
enough, the larger bound of a few landmarks (:mod:`navigation.landmarks`; both consistent, so the cost is
exact). skimage's MCP was measured first: 0.6-1.0 s on a 1000 x 1000 map, against the 50 ms target; this
kernel explores only what A* must. The path is then shortened by line of sight where the straight line is no
costlier than the cells it replaces (so shortcuts never bring the robot closer to a wall), and given as cell
centres in metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from . import grid_heap as heap
from .costmap import INSCRIBED, NO_INFORMATION, Costmap
from .landmarks import LandmarkCache, Landmarks, build, relaxed_weights, relaxes, step_weights

SQRT2 = math.sqrt(2.0)


_NO_MARKS = np.zeros((0, 1), dtype=np.float32)
_NO_MARKS_GOAL = np.zeros(0, dtype=np.float64)
LANDMARKS = LandmarkCache()  # per costmap, for plan()


class PlanError(ValueError):
    """No plan: the reason says why (start or goal blocked, off the map, no path)."""


@numba.njit(cache=True, nogil=True)  # nogil: a landmark build in another thread runs alongside
def _astar(costs, weight, start_r, start_c, goal_r, goal_c, marks, marks_goal):
    """A* with :mod:`navigation.grid_heap`'s indexed 4-ary heap (each cell at most once in it); `weight` is a
    step's multiplier per cost value, -1 where a cell cannot be entered. The heuristic is the octile distance,
    or where larger a landmark's bound ``marks_goal[l] - marks[l, n]`` (see :mod:`navigation.landmarks`; `marks`
    may have no rows). Returns (path, cost, cells closed)."""
    rows, cols = costs.shape
    n = rows * cols
    parent = np.full(n, -1, dtype=np.int32)
    goal = goal_r * cols + goal_c
    g, pos, keys, vals, size = heap.start(n, start_r * cols + start_c)
    flat = costs.ravel()
    cells = np.empty(8, dtype=np.int64)
    reached = np.empty(8)
    found = False
    closed = 0
    count = marks.shape[0]
    while size > 0:
        current, size = heap.pop(keys, vals, pos, size)
        closed += 1
        if current == goal:
            found = True
            break
        for j in range(heap.cheaper_neighbours(current, rows, cols, flat, weight, g, pos, cells, reached)):
            nxt = cells[j]
            g[nxt] = reached[j]
            parent[nxt] = current
            ar = abs(goal_r - nxt // cols)
            ac = abs(goal_c - nxt % cols)
            h = ((ar + ac) + (SQRT2 - 2.0) * min(ar, ac)) * 1.0001
            for m in range(count):
                bound = marks_goal[m] - marks[m, nxt]
                if bound > h:
                    h = bound
            size = heap.push(keys, vals, pos, size, nxt, reached[j] + h)
    if not found:
        return np.zeros(0, dtype=np.int64), np.inf, closed
    length = 0
    node = goal
    while node != -1:
        length += 1
        node = parent[node]
    path = np.empty(length, dtype=np.int64)
    node = goal
    for i in range(length - 1, -1, -1):
        path[i] = node
        node = parent[node]
    return path, g[goal], closed


@numba.njit(cache=True)
def _line_cost(weight, costs, r0, c0, r1, c1):
    """The planner's cost of the straight line (Bresenham cells) between two cells, in cell lengths; inf if
    it enters a cell that cannot be entered."""
    dr = abs(r1 - r0)
    dc = abs(c1 - c0)
    sr = 1 if r1 > r0 else -1
    sc = 1 if c1 > c0 else -1
    err = dc - dr
    r, c = r0, c0
    total = 0.0
    count = 0
    while True:
        if not (r == r0 and c == c0):
            w = weight[costs[r, c]]
            if w < 0.0:
                return np.inf
            total += w
            count += 1
        if r == r1 and c == c1:
            break
        e2 = 2 * err
        if e2 > -dr:
            err -= dr
            c += sc
        if e2 < dc:
            err += dc
            r += sr
    if count == 0:
        return 0.0
    return total / count * math.sqrt(dr * dr + dc * dc)


@numba.njit(cache=True)
def _shorten(costs, rows, cols, weight, lookahead):
    """Greedy line-of-sight shortening: from each kept cell jump to the furthest later cell (within
    `lookahead` cells) whose straight line costs no more, by the planner's own measure, than the path it
    replaces: shortcuts never trade clearance for length."""
    n = len(rows)
    cum = np.zeros(n)
    for k in range(1, n):
        step = math.sqrt((rows[k] - rows[k - 1]) ** 2 + (cols[k] - cols[k - 1]) ** 2)
        cum[k] = cum[k - 1] + step * weight[costs[rows[k], cols[k]]]
    keep = [0]
    i = 0
    while i < n - 1:
        best = i + 1
        j = i + 2
        while j < n and j - i <= lookahead:
            if _line_cost(weight, costs, rows[i], cols[i], rows[j], cols[j]) <= cum[j] - cum[i] + 1e-9:
                best = j
            j += 1
        keep.append(best)
        i = best
    out = np.empty(len(keep), dtype=np.int64)
    for k in range(len(keep)):
        out[k] = keep[k]
    return out


@dataclass(frozen=True)
class PlannerParams:
    """global_planner's names where the idea is the same."""

    cost_factor: float = 3.0  # how much a cell's cost lengthens a step through it
    allow_unknown: bool = True  # plan through NO_INFORMATION cells (exploration)
    shorten: bool = True  # line-of-sight shortening
    lookahead_cells: int = 200  # how far a shortcut may reach
    landmarks: int = 4  # ALT landmarks per static map, built once planning on it has cost as much (0: octile only)


@dataclass
class Plan:
    points: np.ndarray  # (n, 2) metres, map frame, start first
    cost: float  # A*'s cost in cell lengths

    def length(self) -> float:
        return float(np.hypot(*np.diff(self.points, axis=0).T).sum()) if len(self.points) > 1 else 0.0


def plan_cells(costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int],
               params: PlannerParams = PlannerParams(), lethal_from: int = INSCRIBED,
               landmarks: Landmarks | None = None) -> tuple[np.ndarray, float]:
    """A* on `costs` from cell `start` to cell `goal` (row, col): (path cells (n, 2), cost), or PlanError.
    `landmarks` (built on these costs or on a relaxation of them: :func:`navigation.landmarks.relaxes`) only
    make the search shorter; the path's cost is the same."""
    cells, total, _ = search(costs, start, goal, params, lethal_from, landmarks)
    return cells, total


def search(costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int], params: PlannerParams,
           lethal_from: int, landmarks: Landmarks | None) -> tuple[np.ndarray, float, int]:
    """plan_cells, with the number of cells the search closed (what tells a heuristic's effort)."""
    rows, cols = costs.shape
    for name, (r, c) in (("start", start), ("goal", goal)):
        if not (0 <= r < rows and 0 <= c < cols):
            raise PlanError(f"{name} cell ({r}, {c}) is off the map ({cols} x {rows} cells)")
    costs = np.ascontiguousarray(costs, dtype=np.uint8)
    marks, marks_goal = _NO_MARKS, _NO_MARKS_GOAL
    if landmarks is not None and len(landmarks.cells):
        if landmarks.distances.shape[1] != costs.size:
            raise ValueError(f"landmarks built on {landmarks.distances.shape[1]} cells, costs have {costs.size}")
        at_goal = landmarks.distances[:, goal[0] * cols + goal[1]].astype(np.float64)
        at_goal[~np.isfinite(at_goal)] = -np.inf  # a landmark the goal cannot be reached from bounds nothing
        marks, marks_goal = landmarks.distances, at_goal
    weight = step_weights(params.cost_factor, params.allow_unknown, lethal_from)
    path, total, closed = _astar(costs, weight, start[0], start[1], goal[0], goal[1], marks, marks_goal)
    if len(path) == 0:
        raise PlanError("no path: the goal cannot be reached from the start without touching an obstacle")
    cells = np.column_stack((path // cols, path % cols))
    if params.shorten and len(cells) > 2:
        keep = _shorten(costs, cells[:, 0].copy(), cells[:, 1].copy(), weight, int(params.lookahead_cells))
        cells = cells[keep]
    return cells, float(total), int(closed)


def warm_up(params: PlannerParams = PlannerParams()) -> None:
    """Compile (or load from numba's cache) every kernel a plan may need, landmarks included, on a tiny map: a
    node calls it at start-up, so that its first plans do not hold it for a second while the robot drives on."""
    tiny = np.zeros((3, 3), dtype=np.uint8)
    relaxed = relaxed_weights(params.cost_factor, INSCRIBED)
    relaxes(tiny, tiny, relaxed, step_weights(params.cost_factor, params.allow_unknown, INSCRIBED))
    plan_cells(tiny, (0, 0), (2, 2), params, landmarks=build(tiny, relaxed, 1))


def plan(costmap: Costmap, start_xy: tuple[float, float], goal_xy: tuple[float, float],
         params: PlannerParams = PlannerParams(), static_only: bool = False, background: bool = False) -> Plan:
    """The plan from a start to a goal in metres (map frame), on the static map alone with `static_only`.
    The start may lie in an inflated cell (a robot that came close to a wall must still get out): the inflated
    cells around it are made passable. Landmarks on the costmap's static costs are kept for later plans (see
    :mod:`navigation.landmarks`) and used whenever the costs planned on relax to them. With `background`, the
    plan that makes them worth building starts their build in a thread and returns; plans use the octile
    heuristic until they are ready (the same costs: the heuristic changes only how much A* searches)."""
    costs = costmap.static_costs if static_only else costmap.costs
    start = costmap.grid.cell_of(*start_xy)
    goal = costmap.grid.cell_of(*goal_xy)
    rows, cols = costs.shape
    if not (0 <= goal[0] < rows and 0 <= goal[1] < cols):
        raise PlanError(f"goal ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) is off the map")
    if not (0 <= start[0] < rows and 0 <= start[1] < cols):
        raise PlanError(f"start ({start_xy[0]:.2f}, {start_xy[1]:.2f}) is off the map")
    goal_cost = costs[goal]
    if goal_cost >= INSCRIBED and goal_cost != NO_INFORMATION:
        raise PlanError(f"goal ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) is in an obstacle or closer to one than "
                        f"the robot's radius")
    costs = _free_around(costs, start)
    state, landmarks = LANDMARKS.get(costmap, costmap.static_costs, params.cost_factor, INSCRIBED, params.landmarks)
    if landmarks is not None and costs is not costmap.static_costs and not relaxes(
            costmap.static_costs, costs, landmarks.relaxed,
            step_weights(params.cost_factor, params.allow_unknown, INSCRIBED)):
        landmarks = None  # a cell cheaper than on the static map: the landmarks' bound could overshoot
    cells, total, closed = search(costs, start, goal, params, INSCRIBED, landmarks)
    LANDMARKS.searched(state, closed, start[0] * cols + start[1], background)
    points = costmap.centres_of(cells[:, 0], cells[:, 1])
    points[0] = start_xy
    points[-1] = goal_xy
    return Plan(points, total)


def _free_around(costs: np.ndarray, cell: tuple[int, int]) -> np.ndarray:
    """A copy of `costs` whose inflated (not lethal) cells next to `cell` are passable: a robot that ended up
    in the inflation of a wall is let out of it by the shortest way."""
    r, c = cell
    if costs[r, c] < INSCRIBED:
        return costs
    out = costs.copy()
    window = out[max(r - 5, 0): r + 6, max(c - 5, 0): c + 6]
    window[window == INSCRIBED] = 252
    return out
