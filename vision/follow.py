"""Following a tracked target: the box's bearing turns the robot, its range sets the speed.

Range comes from the registered depth image (the near part of the box's core, see :func:`~vision.boxes.box_depth`)
and, where the depth has no reading (too near or beyond the sensor's range), from the box's height and the
target's known size (``d = f * H / h``). The command drives the range towards the following distance and the
bearing towards zero; it slows down while the target is off to the side (turn first, then go) and never drives
forward into something nearer than ``stop_m`` in its way (0.6 m: a Kinect sees nothing within 0.45 m, so the
robot must stop before a thing gets that near).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .boxes import Box, Pinhole, box_depth


@dataclass
class FollowSettings:
    distance_m: float = 1.2       # the following distance to keep
    max_v: float = 0.5            # m/s forward; backing off is limited to half of it
    max_w: float = 1.5            # rad/s
    k_v: float = 0.8              # m/s per metre of range error
    k_w: float = 2.0              # rad/s per radian of bearing
    target_height_m: float = 0.16  # true height of what the box holds (a face), for range from size
    stop_m: float = 0.6           # nothing nearer in the robot's way: no forward motion (the Kinect is blind within 0.45 m)
    half_width_m: float = 0.25    # half the width of the robot's way (a TurtleBot's radius, 0.177 m, plus a margin)
    dead_band_m: float = 0.05     # range error small enough to stand still

    def check(self) -> None:
        for name in ("distance_m", "max_v", "max_w", "k_v", "k_w", "target_height_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"follow setting {name} must be > 0, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class FollowCommand:
    v: float
    w: float
    bearing: float
    range_m: float
    range_from: str  # 'depth' or 'size'


def target_range(box: Box, camera: Pinhole, depth_m: np.ndarray | None, target_height_m: float) -> tuple[float, str]:
    """Distance to the target: from the depth image when it has a reading there, else from the box's size."""
    if depth_m is not None:
        measured = box_depth(depth_m, box)
        if math.isfinite(measured):
            return measured, "depth"
    return camera.fy * target_height_m / max(box.h, 1.0), "size"


def clearance_ahead(depth_m: np.ndarray | None, camera: Pinhole | None = None, half_width_m: float = 0.25) -> float:
    """The nearest depth (m) in the robot's way: in a band of rows round the horizon (the floor shows only lower
    down, and far away in this band for a level camera), the points whose sideways offset ``(u - cx) / fx * z``
    is within `half_width_m` of the optical axis, what the base would run into driving straight on (a door jamb
    beside the way too, which the image's middle third alone misses when it is near). Without `camera`: the
    middle third of the image."""
    if depth_m is None:
        return math.inf
    height, width = depth_m.shape
    band = depth_m[int(0.4 * height):int(0.6 * height)]
    if camera is None:
        band, lateral = band[:, width // 3: 2 * width // 3], None
    else:
        lateral = np.abs((np.arange(width) - camera.cx) / camera.fx)[None, :] * band
    valid = np.isfinite(band) & (band > 0)
    if lateral is not None:
        valid &= lateral <= half_width_m
    near = band[valid]
    return float(np.percentile(near, 2)) if near.size else math.inf


def blank_ahead(depth_m: np.ndarray | None) -> bool:
    """Whether most of the band straight ahead has no depth reading. A Kinect reads nothing nearer than its
    minimum range (0.45 m) as well as beyond its maximum; when the target itself has a reading, a blank band
    ahead is something too near to measure (a wall the robot is about to touch), not open space."""
    if depth_m is None:
        return False
    height, width = depth_m.shape
    band = depth_m[int(0.4 * height):int(0.6 * height), width // 3: 2 * width // 3]
    return int(np.count_nonzero(np.isfinite(band) & (band > 0))) < band.size / 2


def follow_command(box: Box, camera: Pinhole, depth_m: np.ndarray | None, settings: FollowSettings) -> FollowCommand:
    """The Twist (v, w) that brings the target to the image centre at the following distance."""
    u, _ = box.centre
    bearing = camera.bearing(u)
    range_m, source = target_range(box, camera, depth_m, settings.target_height_m)
    error = range_m - settings.distance_m
    v = 0.0 if abs(error) < settings.dead_band_m else settings.k_v * error
    v = float(np.clip(v, -settings.max_v / 2, settings.max_v)) * max(0.0, math.cos(bearing)) ** 2
    blocked = clearance_ahead(depth_m, camera, settings.half_width_m) < settings.stop_m
    if v > 0 and (blocked or (source == "depth" and blank_ahead(depth_m))):
        v = 0.0
    w = float(np.clip(settings.k_w * bearing, -settings.max_w, settings.max_w))
    return FollowCommand(v, w, bearing, range_m, source)


__all__ = ["FollowSettings", "FollowCommand", "follow_command", "target_range", "clearance_ahead", "blank_ahead"]
