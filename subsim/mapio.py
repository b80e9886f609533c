"""The simulator's maps: a map_server map (read by :mod:`subsumption.mapfile`) plus what physics needs of it.

The simulator treats unknown cells as solid, because in a map made by SLAM the unknown is what lies beyond
the walls. The file format itself lives in the core (:mod:`subsumption.mapfile`), shared with navigation.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from subsumption.mapfile import (FREE, OCCUPIED, UNKNOWN, MapError, OccupancyMap, occupancy_from_pixels,
                                 read_map_file, save_map)


@dataclass
class GridMap(OccupancyMap):
    """A static occupancy grid plus what the simulator derives from it once (solid mask, wall distances)."""

    solid: np.ndarray = field(init=False, repr=False)  # uint8 (rows, cols): 1 where a robot cannot be
    wall_distance: np.ndarray = field(init=False, repr=False)  # float32 metres from a cell centre to a solid one

    def __post_init__(self) -> None:
        super().__post_init__()
        self.solid = np.ascontiguousarray(self.occupancy != FREE, dtype=np.uint8)
        # Distance from every free cell centre to the nearest solid cell centre, computed once: it lets the
        # physics skip the exact contact test whenever a robot is clearly far from every wall.
        free = (1 - self.solid).astype(np.uint8)
        dist = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        self.wall_distance = (dist * self.resolution).astype(np.float32)


def load_map(yaml_path: str | Path) -> GridMap:
    """Read a map_server YAML file and its image. Raises MapError naming the file and the faulty field."""
    grid = read_map_file(yaml_path)
    return GridMap(grid.occupancy, grid.resolution, grid.origin, grid.source)


__all__ = ["FREE", "OCCUPIED", "UNKNOWN", "MapError", "GridMap", "load_map", "occupancy_from_pixels", "save_map"]
