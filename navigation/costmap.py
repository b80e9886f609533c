"""costmap_2d's idea in numpy: a static map's walls and what the scan sees now, inflated by the robot's size.

Costs are costmap_2d's (uint8): 254 ``LETHAL`` (an obstacle in the cell), 253 ``INSCRIBED`` (the robot's centre
there would touch it), 252 down to 1 decaying as ``252 * exp(-cost_scaling_factor * (d - inscribed_radius))``
out to ``inflation_radius``, 0 free, 255 ``NO_INFORMATION`` (unknown, when unknown space is tracked).
Distances come from one exact Euclidean distance transform (scipy), not from costmap_2d's cell-by-cell
propagation: the same numbers, in a few milliseconds for a 1000 x 1000 map.

Layers, as move_base's default global costmap has them: the **static** layer (the map's occupied cells) and
an **obstacle** layer holding only the latest scan's hits (people and robots move: what the scan saw a second
ago is not kept), both inflated together. For rviz, :func:`costmap_msg` turns costs into an OccupancyGrid with
costmap_2d's translation (0..252 -> 0..98, 253 -> 99, 254 -> 100, 255 -> -1).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from nav_msgs.msg import OccupancyGrid
from scipy.ndimage import distance_transform_edt

from subsumption.mapfile import OCCUPIED, UNKNOWN, OccupancyMap

from .grid_messages import grid_msg

FREE_SPACE, INSCRIBED, LETHAL, NO_INFORMATION = 0, 253, 254, 255


@dataclass(frozen=True)
class InflationParams:
    """costmap_2d's inflation layer and robot footprint parameters (their names)."""

    robot_radius: float = 0.18  # m: the footprint's radius (inscribed = circumscribed for a round robot)
    inflation_radius: float = 0.55  # m: costs reach this far from an obstacle
    cost_scaling_factor: float = 10.0  # 1/m: how fast the cost falls beyond the inscribed radius
    track_unknown_space: bool = False  # unknown cells as NO_INFORMATION (else free)


def inflate(obstacles: np.ndarray, resolution: float, params: InflationParams,
            unknown: np.ndarray | None = None) -> np.ndarray:
    """uint8 costs of a grid whose `obstacles` (bool) are lethal; `unknown` (bool) cells become NO_INFORMATION
    when tracked (they neither block nor inflate)."""
    if obstacles.any():
        distance = distance_transform_edt(~obstacles) * resolution
    else:
        distance = np.full(obstacles.shape, np.inf)
    costs = np.zeros(obstacles.shape, dtype=np.uint8)
    around = (distance > 0) & (distance <= params.inflation_radius)
    decay = 252.0 * np.exp(-params.cost_scaling_factor * (distance[around] - params.robot_radius))
    costs[around] = np.clip(np.round(decay), 1, 252).astype(np.uint8)
    costs[(distance > 0) & (distance <= params.robot_radius)] = INSCRIBED
    costs[obstacles] = LETHAL
    if unknown is not None and params.track_unknown_space:
        costs[unknown & ~obstacles] = NO_INFORMATION
    return costs


class Costmap:
    """The static map plus the latest scan's obstacles, inflated, in the map's grid and frame.

    ``set_map`` once per map; ``set_scan_points`` with the scan's hits in the map frame (metres) whenever a
    scan arrives; ``costs`` is recomputed lazily. Points off the map are ignored."""

    def __init__(self, grid: OccupancyMap, params: InflationParams) -> None:
        self.grid = grid
        self.params = params
        self.static = grid.occupancy == OCCUPIED
        self.unknown = grid.occupancy == UNKNOWN
        self.static_costs = inflate(self.static, grid.resolution, params, self.unknown)
        self._wall_distance: np.ndarray | None = None
        self._points = np.zeros((0, 2))
        self._costs: np.ndarray | None = self.static_costs

    @property
    def resolution(self) -> float:
        """Metres per cell."""
        return self.grid.resolution

    @property
    def shape(self) -> tuple[int, int]:
        """Rows and columns of the costmap."""
        return self.grid.shape

    @property
    def wall_distance(self) -> np.ndarray:
        """m from each cell to the static map's nearest wall (computed on first use)."""
        if self._wall_distance is None:
            self._wall_distance = (distance_transform_edt(~self.static) * self.resolution if self.static.any()
                                   else np.full(self.shape, np.inf))
        return self._wall_distance

    def set_scan_points(self, points: np.ndarray) -> None:
        """Set the latest scan's hits (N x 2, map frame); the costs are recomputed when next asked for."""
        self._points = np.asarray(points, dtype=float).reshape(-1, 2)
        self._costs = None

    def scan_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the cells the latest scan's hits fall in (those inside the map)."""
        rows, cols = self.cells_of(self._points)
        inside = (rows >= 0) & (rows < self.shape[0]) & (cols >= 0) & (cols < self.shape[1])
        return rows[inside], cols[inside]

    @property
    def costs(self) -> np.ndarray:
        """uint8 (rows, cols), row 0 at the lowest y."""
        if self._costs is None:
            rows, cols = self.scan_cells()
            if len(rows) == 0:
                self._costs = self.static_costs
            else:
                self._costs = self._with_scan(rows, cols)
        return self._costs

    def _with_scan(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The static costs with the scan's cells added, inflated again only where they can change anything:
        the scan's bounding box grown by the inflation radius (the cells whose costs may change), itself grown
        by the radius again (every obstacle that inflates into them). On a 1000 x 1000 map that is a few
        metres around the robot instead of a distance transform of the whole map at every replan."""
        reach = int(np.ceil(self.params.inflation_radius / self.resolution)) + 1
        height, width = self.shape
        inner = (max(int(rows.min()) - reach, 0), min(int(rows.max()) + reach + 1, height),
                 max(int(cols.min()) - reach, 0), min(int(cols.max()) + reach + 1, width))
        outer = (max(inner[0] - reach, 0), min(inner[1] + reach, height),
                 max(inner[2] - reach, 0), min(inner[3] + reach, width))
        window = (slice(outer[0], outer[1]), slice(outer[2], outer[3]))
        obstacles = self.static[window].copy()
        obstacles[rows - outer[0], cols - outer[2]] = True
        local = inflate(obstacles, self.resolution, self.params, self.unknown[window])
        costs = self.static_costs.copy()
        r0, r1, c0, c1 = inner[0] - outer[0], inner[1] - outer[0], inner[2] - outer[2], inner[3] - outer[2]
        costs[inner[0]:inner[1], inner[2]:inner[3]] = local[r0:r1, c0:c1]
        return costs

    def cells_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of world points (n, 2); may lie outside the grid."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        ox, oy = self.grid.origin
        return (np.floor((xy[:, 1] - oy) / self.resolution).astype(np.int64),
                np.floor((xy[:, 0] - ox) / self.resolution).astype(np.int64))

    def centres_of(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The map-frame centres of the given cells (N x 2)."""
        ox, oy = self.grid.origin
        return np.column_stack((ox + (np.asarray(cols) + 0.5) * self.resolution,
                                oy + (np.asarray(rows) + 0.5) * self.resolution))

    def contains(self, x: float, y: float) -> bool:
        """Whether the point (x, y) in the map frame lies on the costmap."""
        row, col = self.grid.cell_of(x, y)
        return 0 <= row < self.shape[0] and 0 <= col < self.shape[1]

    def cost_at(self, x: float, y: float, static_only: bool = False) -> int:
        """The cost of the cell holding (x, y); NO_INFORMATION off the map."""
        row, col = self.grid.cell_of(x, y)
        if not (0 <= row < self.shape[0] and 0 <= col < self.shape[1]):
            return NO_INFORMATION
        return int((self.static_costs if static_only else self.costs)[row, col])


def costmap_msg(costs: np.ndarray, grid: OccupancyMap, stamp: float, frame: str) -> OccupancyGrid:
    """costs as rviz shows a costmap (costmap_2d's translation table)."""
    values = np.round(costs.astype(np.float64) * 98.0 / 252.0).astype(np.int16)
    values[costs == INSCRIBED] = 99
    values[costs == LETHAL] = 100
    values[costs == NO_INFORMATION] = -1
    return grid_msg(OccupancyMap(values.astype(np.int8), grid.resolution, grid.origin, grid.source), stamp, frame)
