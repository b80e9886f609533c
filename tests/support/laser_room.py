"""A synthetic room and a noiseless laser in it, for tests that drive the SLAM core where the truth is exact."""
from __future__ import annotations

import numpy as np

from navigation.scan_geometry import Beams
from subsim.mapio import GridMap
from subsim.raycast import cast_rays

RES = 0.02  # m per cell of the room's grid: the laser's walls as a 2 cm grid draws them


def room() -> GridMap:
    """A 12 x 8 m room, two pillars and a stub wall, so that a scan pins every axis down."""
    occupancy = np.zeros((int(8 / RES) + 6, int(12 / RES) + 6), np.int8)   # rows: y, columns: x, 3 cells of wall
    occupancy[:3, :] = occupancy[-3:, :] = occupancy[:, :3] = occupancy[:, -3:] = 100

    def block(x0: float, y0: float, x1: float, y1: float) -> None:
        occupancy[int(y0 / RES) + 3:int(y1 / RES) + 3, int(x0 / RES) + 3:int(x1 / RES) + 3] = 100

    block(3.5, 3.4, 4.1, 4.0)   # pillars
    block(8.0, 4.5, 8.4, 4.9)
    block(6.0, 6.6, 6.1, 8.0)   # a stub wall from the north side
    return GridMap(occupancy, RES, (-3 * RES, -3 * RES), "room.yaml")


def laser_scan(pose: np.ndarray, grid: GridMap, half_fov: float) -> Beams:
    """A noiseless laser scan from `pose`: 181 beams over +-`half_fov`, 20 m range."""
    angles = np.linspace(-half_fov, half_fov, 181)
    n = len(angles)
    ranges = cast_rays(grid.solid, grid.wall_distance, grid.origin[0], grid.origin[1], RES, np.full(n, pose[0]),
                       np.full(n, pose[1]), angles + pose[2], np.full(n, 20.0), np.zeros((0, 3)))
    hit = np.isfinite(ranges)
    return Beams(np.zeros(2), angles, np.where(hit, ranges, 20.0), hit)
