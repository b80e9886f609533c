"""From a ``sensor_msgs/LaserScan`` to beams in the robot's base frame, read per REP 117, and the sensor's
mounting from tf.

REP 117: ``+inf`` means nothing within ``range_max`` (the beam saw free space up to there), ``-inf`` an
object closer than ``range_min`` (no usable geometry), NaN an invalid reading (dropped). A finite value
outside [range_min, range_max] is read the same way. Both the map builder and the localizer go through
:func:`beams_of`, so a laser and a depth camera's fake scan are read alike.

The mounting (``base_link -> laser``) comes from ``/tf_static`` through tf2's own buffer,
``tf2_py.BufferCore``, fed by the module's NodeHandle: no rospy, so it works in-process as under ROS. A
sensor mounted upside down (its z axis pointing down, as some depth cameras' scan frames are) has its beam
angles mirrored.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import genpy
import numpy as np
import tf2_py
import yaml
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from subsumption.runtime import NodeHandle

from subsumption.planar import yaw_of


@dataclass
class Beams:
    """Usable beams of one scan in the robot's base frame: each starts at `origin` and points along `angles`.
    `hit` beams end on something at `ranges`; the others saw free space up to `ranges` (no return)."""

    origin: np.ndarray  # (2,) sensor position in the base frame
    angles: np.ndarray  # (n,) beam directions in the base frame
    ranges: np.ndarray  # (n,) metres
    hit: np.ndarray  # (n,) bool

    def endpoints(self) -> np.ndarray:
        """(n, 2) beam ends in the base frame (hits and free ends alike)."""
        return np.column_stack((self.origin[0] + self.ranges * np.cos(self.angles),
                                self.origin[1] + self.ranges * np.sin(self.angles)))

    def hits(self) -> np.ndarray:
        """(m, 2) the points where beams hit something, base frame."""
        return self.endpoints()[self.hit]

    def extended(self, distance: float) -> "Beams":
        """The same beams with the hits carried `distance` further: a return lies on a surface, exactly on a
        cell border when the wall is aligned with the grid, and this puts it inside the cell it hit."""
        return Beams(self.origin, self.angles, self.ranges + np.where(self.hit, distance, 0.0), self.hit)

    def subsample(self, count: int) -> "Beams":
        """At most `count` beams, evenly spread over the scan (amcl's laser_max_beams)."""
        n = len(self.ranges)
        if count <= 0 or n <= count:
            return self
        keep = np.unique(np.linspace(0, n - 1, count).round().astype(int))
        return Beams(self.origin, self.angles[keep], self.ranges[keep], self.hit[keep])


def beams_of(scan: LaserScan, mount: tuple[np.ndarray, bool] = (np.zeros(3), False),
             max_usable_range: float = math.inf) -> Beams:
    """The scan's beams in the base frame. A return beyond `max_usable_range` (gmapping's maxUrange) is not
    trusted as a hit: the beam only says the space up to there is free."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    n = len(ranges)
    angles = scan.angle_min + scan.angle_increment * np.arange(n)
    lo, hi = float(scan.range_min), float(scan.range_max)
    with np.errstate(invalid="ignore"):
        # NaN invalid; -inf or too close: nothing usable; 0 (no range_min set): a driver's "no reading", never a
        # surface at the sensor itself
        valid = ~np.isnan(ranges) & ~(ranges < lo) & (ranges > 0)
        hit = valid & (ranges <= hi) & (ranges <= max_usable_range)
    reach = min(hi, max_usable_range)
    ranges = np.where(hit, ranges, reach)[valid]
    hit = hit[valid]
    pose, flipped = mount
    angles = angles[valid]
    if flipped:
        angles = -angles
    return Beams(pose[:2].copy(), angles + pose[2], ranges, hit)


class Mounts:
    """Where sensors sit on the robot (planar x, y, yaw and whether upside down), from transforms as tf2's buffer
    chains them: a laser on ``base_link -> base_scan`` under ``base_footprint -> base_link``, a depth camera's frame
    under the camera's own, are each found in whatever base frame odometry names. Fed by :class:`MountListener` on a
    running graph, and from a bag's ``/tf_static`` by :mod:`navigation.bag_read`: both paths place a scan alike."""

    def __init__(self, cache_time: float = 10.0) -> None:
        self.buffer = tf2_py.BufferCore(genpy.Duration.from_sec(cache_time))
        self._mounts: dict[tuple[str, str], tuple[np.ndarray, bool]] = {}
        self._until_next_transform: set[tuple[str, str]] = set()  # kept only until /tf_static says more

    def add(self, transform) -> str | None:
        """Take one static geometry_msgs/TransformStamped; the reason if tf2 raises for it, else None (tf2 itself
        prints the transforms it ignores without raising, such as a frame given as its own parent)."""
        try:
            self.buffer.set_transform_static(transform, "navigation")
        except tf2_py.TransformException as error:
            return f"{transform.header.frame_id} -> {transform.child_frame_id}: {error}"
        while self._until_next_transform:  # a sensor nothing placed may be placed now
            self._mounts.pop(self._until_next_transform.pop(), None)
        return None

    def mount(self, base_frame: str, sensor_frame: str) -> tuple[np.ndarray, bool] | None:
        """(x, y, yaw) of `sensor_frame` in `base_frame` and whether it is upside down, or None if tf cannot
        tell yet. A mounting is looked up once and kept: sensors do not move on the robot. An empty `base_frame`
        (odometry whose driver leaves ``child_frame_id`` empty) stands for the top of the sensor's chain of static
        frames, the robot's own base on every robot's tree."""
        base_frame, sensor_frame = base_frame.lstrip("/"), sensor_frame.lstrip("/")  # tf2 names have no slash
        key = (base_frame, sensor_frame)
        if key not in self._mounts:
            if not base_frame:
                base_frame = self.top_of(sensor_frame)
                if base_frame == sensor_frame:  # nothing places the sensor (yet): kept until /tf_static says more
                    self._until_next_transform.add(key)
            if sensor_frame == base_frame:
                self._mounts[key] = (np.zeros(3), False)
            else:
                try:
                    t = self.buffer.lookup_transform_core(base_frame, sensor_frame, genpy.Time()).transform
                except tf2_py.TransformException:
                    return None
                q = t.rotation
                # the sensor's z axis in the base frame: its z component is 1 - 2(x^2 + y^2)
                flipped = 1.0 - 2.0 * (q.x * q.x + q.y * q.y) < 0.0
                # yaw_of gives the direction of the sensor's x axis, upside down or not
                self._mounts[key] = (np.array([t.translation.x, t.translation.y, yaw_of(q)]), flipped)
        return self._mounts[key]

    def top_of(self, frame: str) -> str:
        """The frame at the top of `frame`'s chain of parents in the buffer (`frame` itself if it has none)."""
        parents = {child: fields["parent"] for child, fields in
                   (yaml.safe_load(self.buffer.all_frames_as_yaml()) or {}).items()}
        seen = {frame}
        while frame in parents and parents[frame] not in seen:
            frame = parents[frame]
            seen.add(frame)
        return frame


class MountListener(Mounts):
    """:class:`Mounts` fed from ``/tf_static`` through a NodeHandle. Sensors are mounted rigidly: parsing every
    ``/tf`` message would cost time for nothing (and the odometry's moving frames are no sensor's mount)."""

    def __init__(self, node: NodeHandle, cache_time: float = 10.0) -> None:
        super().__init__(cache_time)
        self.node = node
        node.subscribe("/tf_static", TFMessage, self._add)

    def _add(self, msg: TFMessage) -> None:
        for transform in msg.transforms:
            refused = self.add(transform)
            if refused:
                self.node.log("warn", f"tf: ignored {refused}")
