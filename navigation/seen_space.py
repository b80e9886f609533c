"""Where the scan saw free space lately: the ground a robot with a narrow sensor may drive onto.

Why: the TurtleBot's depth camera sees 57 degrees ahead and nothing nearer than 0.45 m. A person who walks up
beside a robot that stands (waiting, turning towards its plan) is never seen, and no memory of hits can hold
what was never hit. In the office with walkers that really walk, move_base turned and drove at 0.4 m/s into
people standing beside it, out of view, four times in one run (seed 1: at 227, 248, 400 and 416 s), once right
after a recovery had cleared its memory. A careful driver moves only onto ground it has looked at lately.

A grid in the odometry frame keeps, per cell, when a beam last passed over it: a beam that ends on something
saw the ray up to there (a thing nearer, even inside the blind range, would have hidden that return); a beam
with no return (REP 117 +inf: nothing within range_max, or a thing too near for the camera, which blindspot's
memory reports as a hit at the rim only if it saw it come) saw the ray from the blind depth (``blind``: the
camera's minimum, a depth along its axis) to range_max. The robot's own footprint (plus
``footprint_margin``) counts as seen: it stands there. Cells not seen for ``keep`` s near the robot are the
*unseen* points the local planner keeps the footprint off when it drives (turning on the spot moves no part of a
round robot onto new ground).
"""
from __future__ import annotations

import math

import numpy as np

from .scan_geometry import Beams
from subsumption.planar import inverse, transform_points

SAMPLE_STEP = 0.5  # of a cell: spacing of the points marked along a beam


class SeenSpace:
    """Per-cell time of the last sight, odometry frame, on a fixed grid of `size` m centred on the first pose."""

    def __init__(self, resolution: float = 0.1, size: float = 60.0, reach: float = 3.0,
                 footprint: float = 0.18, footprint_margin: float = 0.03, blind: float = 0.0) -> None:
        self.resolution = resolution
        self.reach = reach  # m along a beam marked at most
        self.footprint = footprint
        self.footprint_margin = footprint_margin
        self.blind = blind  # m of depth (along the sensor's axis) nearer than which a beam gives no return
        self.cells = int(math.ceil(size / resolution))
        self.origin: np.ndarray | None = None  # odometry-frame corner of the grid
        self.seen = np.full((self.cells, self.cells), -np.inf)
        self.view: tuple[np.ndarray, float, float] | None = None  # the last scan's origin and angle range, base frame

    def clear(self) -> None:
        self.origin = None
        self.seen.fill(-np.inf)

    def _index(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ij = np.floor((points - self.origin) / self.resolution).astype(np.int64)
        inside = (ij >= 0).all(axis=1) & (ij < self.cells).all(axis=1)
        return ij[:, 0], ij[:, 1], inside

    def update(self, now: float, odom: np.ndarray, beams: Beams) -> None:
        """One scan (`beams` in the base frame) taken with the robot at `odom` (x, y, yaw, odometry frame)."""
        if self.origin is None or not (np.abs(odom[:2] - self.origin - self.cells * self.resolution / 2)
                                       < self.cells * self.resolution / 2 - self.reach - 1.0).all():
            self.origin = odom[:2] - self.cells * self.resolution / 2  # (re)centred: what was seen is forgotten
            self.seen.fill(-np.inf)
        step = self.resolution * SAMPLE_STEP
        points = [self._footprint_points(step)]
        if len(beams.angles):
            self.view = (beams.origin.copy(), float(beams.angles.min()), float(beams.angles.max()))
            length = np.minimum(beams.ranges - np.where(beams.hit, self.resolution, 0.0), self.reach)
            # no return: nothing within range, or a thing inside the blind depth (the Kinect says neither): the
            # ray is seen only beyond the blind depth, range_min / cos(angle) off the sensor's axis
            axis = float(np.median(beams.angles))
            start = np.where(beams.hit, 0.0, self.blind / np.maximum(np.cos(beams.angles - axis), 0.1))
            most = int(math.ceil(float(length.max(initial=0.0)) / step)) + 1
            along = step * np.arange(most)
            keep = (along[None, :] <= length[:, None]) & (along[None, :] >= start[:, None])
            rays = np.stack([np.cos(beams.angles), np.sin(beams.angles)], axis=1)
            pts = beams.origin[None, None, :] + along[None, :, None] * rays[:, None, :]
            points.append(pts[keep])
        base = np.concatenate(points)
        i, j, inside = self._index(transform_points(odom, base))
        self.seen[i[inside], j[inside]] = now

    def _footprint_points(self, step: float) -> np.ndarray:
        r = self.footprint + self.footprint_margin
        grid = np.arange(-r, r + 1e-9, step)
        xx, yy = np.meshgrid(grid, grid)
        disc = np.hypot(xx, yy) <= r
        return np.column_stack((xx[disc], yy[disc]))

    def rim_clearance(self, robot_radius: float, margin: float = 0.05) -> float:
        """How far a robot's centre keeps from the centre of a cell not seen lately so that its rim stays `margin`
        off the whole cell (its half diagonal): someone may stand anywhere in it. With the rim kept `margin` off the
        centre only, the robot crept at 0.067 m/s into a person standing out of view beside it (office seed 1,
        268.8 s)."""
        return robot_radius + margin + self.resolution * math.sqrt(0.5)

    def unseen(self, now: float, odom: np.ndarray, keep: float, radius: float) -> np.ndarray:
        """Centres (base frame of the robot at `odom`) of the cells within `radius` m not seen for `keep` s, but for
        those in the sensor's view nearer than its blind depth: there blindspot reports what it saw come in (without
        this a robot that stood facing a long corridor, where no beam returns, could not go on)."""
        if self.origin is None:
            return np.zeros((0, 2))
        ci, cj, _ = self._index(odom[None, :2])
        span = int(math.ceil(radius / self.resolution)) + 1
        i0, j0 = max(int(ci[0]) - span, 0), max(int(cj[0]) - span, 0)
        window = self.seen[i0: int(ci[0]) + span + 1, j0: int(cj[0]) + span + 1]
        ii, jj = np.nonzero(now - window > keep)
        centres = self.origin + (np.column_stack((ii + i0, jj + j0)) + 0.5) * self.resolution
        centres = centres[np.hypot(*(centres - odom[:2]).T) <= radius]
        if not len(centres):
            return np.zeros((0, 2))
        local = transform_points(inverse(odom), centres)
        if self.view is not None and self.blind > 0:
            origin, low, high = self.view
            rel = local - origin
            bearing = np.arctan2(rel[:, 1], rel[:, 0])
            axis = (low + high) / 2
            in_cone = (bearing >= low) & (bearing <= high)
            depth = np.hypot(*rel.T) * np.cos(bearing - axis)
            local = local[~(in_cone & (depth < self.blind + self.resolution))]
        return local
