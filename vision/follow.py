"""Following a tracked target: the box's bearing turns the robot, its range sets the speed.

Range comes from the registered depth image (the near part of the box's core, see :func:`~vision.boxes.box_depth`)
and, where the depth has no reading (too near or beyond the sensor's range), from the box's height and the
target's known size (``d = f * H / h``). The command drives the range towards the following distance and the
bearing towards zero; it slows down while the target is off to the side (turn first, then go) and never drives
forward into something nearer than ``stop_m`` in its way (0.6 m: a Kinect sees nothing within 0.45 m, so the
robot must stop before a thing gets that near).

Why a feed-forward term: a target that drives away is a moving set point. A proportional law alone needs a
range error to move at all, so it trails a target driving at 0.3 m/s by ``0.3 / k_v`` beyond the set distance,
and more while it is speed-limited (measured in the ping-pong room: 2-3 m behind for a 1.2 m setting).
:class:`TargetMotion` estimates the target's own speed along the line of sight from how the range changes plus
the robot's own speed, and the command adds it: ``v = v_target + k_v * (range - distance)``. The error then
closes to zero however fast the target goes (up to ``max_v``).
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
    still_speed: float = 0.05     # m/s: a target estimated slower than this is taken to stand still
    brake_k: float = 1.0          # m/s per metre of clearance beyond stop_m: slow down before anything in the way

    def check(self) -> None:
        """Raise a ValueError naming the first setting that must be positive and is not."""
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


@dataclass
class TargetMotion:
    """The target's own speed along the line of sight (m/s, away positive): the range's rate of change plus the
    robot's own forward speed (its last command; the base follows it within a tenth of a second), smoothed over
    `time_constant_s` because a range read from depth or box size jitters by centimetres from frame to frame.
    A gap longer than `max_gap_s` or a change of range source (depth <-> size) starts the estimate again."""

    time_constant_s: float = 0.5
    max_gap_s: float = 0.5
    max_speed: float = 1.0
    speed: float = 0.0
    _last: tuple[float, float, str] | None = None

    def reset(self) -> None:
        """Forget the target's motion (a new target)."""
        self.speed, self._last = 0.0, None

    def update(self, t: float, range_m: float, source: str, own_v: float) -> float:
        """The target's own speed towards or away from the robot, filtered, from its range now and the robot's speed."""
        last, self._last = self._last, (t, range_m, source)
        if last is None or t - last[0] > self.max_gap_s or source != last[2]:
            self.speed = 0.0
            return self.speed
        dt = t - last[0]
        if dt <= 0:
            return self.speed
        raw = float(np.clip((range_m - last[1]) / dt + own_v, -self.max_speed, self.max_speed))
        alpha = dt / (self.time_constant_s + dt)
        self.speed += alpha * (raw - self.speed)
        return self.speed


def follow_command(box: Box, camera: Pinhole, depth_m: np.ndarray | None, settings: FollowSettings,
                   target_speed: float = 0.0) -> FollowCommand:
    """The Twist (v, w) that brings the target to the image centre at the following distance; `target_speed`
    (from :class:`TargetMotion`, m/s away from the robot) is fed forward so that a moving target is followed at
    the set distance, not behind it."""
    u, _ = box.centre
    bearing = camera.bearing(u)
    range_m, source = target_range(box, camera, depth_m, settings.target_height_m)
    error = range_m - settings.distance_m
    feed = target_speed if abs(target_speed) >= settings.still_speed else 0.0  # a standing target: no creeping
    v = feed + (0.0 if abs(error) < settings.dead_band_m else settings.k_v * error)
    v = float(np.clip(v, -settings.max_v / 2, settings.max_v)) * max(0.0, math.cos(bearing)) ** 2
    clearance = clearance_ahead(depth_m, camera, settings.half_width_m)
    if v > 0:
        # slow down towards anything in the way (the target itself too), stop at stop_m: braking from max_v
        # takes a few centimetres and the sensor is blind within 0.45 m
        v = min(v, max(0.0, settings.brake_k * (clearance - settings.stop_m)))
    if v > 0 and source == "depth" and blank_ahead(depth_m):
        v = 0.0
    w = float(np.clip(settings.k_w * bearing, -settings.max_w, settings.max_w))
    return FollowCommand(v, w, bearing, range_m, source)


__all__ = ["FollowSettings", "FollowCommand", "TargetMotion", "follow_command", "target_range", "clearance_ahead",
           "blank_ahead"]
