"""What the scan saw off the map a moment ago and cannot see now: costmap_2d's obstacle-layer memory, for a
narrow scan.

move_base's obstacle layer holds only the latest scan's hits, which suits a 270-degree laser. The TurtleBot's
depth camera sees 57 degrees and nothing nearer than 0.45 m: a person the robot turns away from, or walks up
to, leaves the scan, and the planners drove into her (the patrol robot in the office world, at the person's
turning point by a door, every seed). Here a hit off the map (a person, a robot) is remembered in the odometry
frame for ``keep`` seconds while the scan cannot see its place: outside the field of view, nearer than the
sensor's minimum range, or behind something nearer. Where a beam of the current scan reaches the place, the
scan itself tells (a hit there now, or free: cleared), as costmap_2d's raytrace clearing does.
"""
from __future__ import annotations

import numpy as np

from .scan_geometry import Beams
from subsumption.planar import inverse, transform_points

CLEAR_MARGIN = 0.1  # m: a remembered point this much short of a beam's end is seen by it (the scan says now)


class ObstacleMemory:
    """Remembered hits in the odometry frame, with the time each was seen."""

    def __init__(self, keep: float, reach: float, cell: float = 0.0) -> None:
        self.keep = keep  # s a point is remembered at most
        self.reach = reach  # m: points further than this from the robot are forgotten
        self.cell = cell  # m: one point (the newest) is kept per cell of this size (0: every point)
        self.points = np.zeros((0, 2))  # odometry frame
        self.seen = np.zeros(0)  # time each was last seen

    def clear(self) -> None:
        self.points, self.seen = np.zeros((0, 2)), np.zeros(0)

    def update(self, now: float, odom: np.ndarray, beams: Beams, range_min: float, off_map: np.ndarray) -> np.ndarray:
        """Forget what is old, far, or in view now; remember `off_map` (this scan's hits off the map, base frame).
        Returns the remembered points the scan cannot see now, in the base frame."""
        kept = np.zeros((0, 2))
        if len(self.points):
            base = transform_points(inverse(odom), self.points)
            unseen = ~self.in_view(base, beams, range_min)
            near = np.hypot(base[:, 0], base[:, 1]) <= self.reach
            keep = unseen & near & (now - self.seen <= self.keep)
            self.points, self.seen, kept = self.points[keep], self.seen[keep], base[keep]
        if len(off_map):
            self.points = np.concatenate([self.points, transform_points(odom, off_map)])
            self.seen = np.concatenate([self.seen, np.full(len(off_map), now)])
            if self.cell > 0:
                self._thin()
        return kept

    def _thin(self) -> None:
        """One point per `cell` (the newest): a wall that leaves the view scan after scan would otherwise be
        remembered once per scan."""
        keys = np.floor(self.points[::-1] / self.cell).astype(np.int64)
        _, first = np.unique(keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True)  # one number per cell
        newest = len(self.points) - 1 - np.sort(first)[::-1]
        self.points, self.seen = self.points[newest], self.seen[newest]

    @staticmethod
    def in_view(points: np.ndarray, beams: Beams, range_min: float) -> np.ndarray:
        """Which points (base frame) a beam of this scan reaches: within the beams' angular spacing of a usable
        beam, no nearer than the sensor's minimum range, and not beyond that beam's end."""
        in_view = np.zeros(len(points), dtype=bool)
        if len(beams.angles) < 2:
            return in_view
        rel = points - beams.origin
        bearing = np.arctan2(rel[:, 1], rel[:, 0])
        distance = np.hypot(rel[:, 0], rel[:, 1])
        order = np.argsort(beams.angles)
        angles, ranges = beams.angles[order], beams.ranges[order]
        spacing = float(np.median(np.diff(angles)))
        i = np.clip(np.searchsorted(angles, bearing), 1, len(angles) - 1)
        nearest = np.where(np.abs(angles[i - 1] - bearing) <= np.abs(angles[i] - bearing), i - 1, i)
        close = np.abs(angles[nearest] - bearing) <= 1.5 * spacing
        return close & (distance >= range_min) & (distance <= ranges[nearest] + CLEAR_MARGIN)
