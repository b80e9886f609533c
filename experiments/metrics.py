"""Numbers that describe a run: how far the robot went, how much ground it covered, how often it hit."""
from __future__ import annotations

import cv2
import numpy as np

from subsim.mapio import GridMap

COVERAGE_RADIUS = 1.0  # m: free ground that came within this distance of the robot's path counts as covered


def path_length(xy: np.ndarray) -> float:
    """Metres travelled along a trajectory of (x, y) rows."""
    if len(xy) < 2:
        return 0.0
    return float(np.hypot(*np.diff(xy[:, :2], axis=0).T).sum())


def coverage_m2(grid: GridMap, xy: np.ndarray, radius: float = COVERAGE_RADIUS) -> float:
    """Free area (m^2) within `radius` of the path: the path is drawn into the grid, a distance transform gives
    every cell's distance to it, and free cells within the radius are counted."""
    if len(xy) == 0:
        return 0.0
    cells = np.column_stack(((xy[:, 0] - grid.origin[0]) / grid.resolution,
                             (xy[:, 1] - grid.origin[1]) / grid.resolution))
    path = np.full(grid.shape, 255, dtype=np.uint8)
    cv2.polylines(path, [np.round(cells).astype(np.int32).reshape(-1, 1, 2)], isClosed=False, color=0, thickness=1)
    distance = cv2.distanceTransform(path, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * grid.resolution
    covered = (distance <= radius) & (grid.solid == 0)
    return float(covered.sum() * grid.resolution ** 2)


def free_area_m2(grid: GridMap) -> float:
    return float((grid.solid == 0).sum() * grid.resolution ** 2)
