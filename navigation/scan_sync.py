"""Pairs each range scan with the odometry pose at the scan's own time.

A scan and the odometry of the same instant may arrive in either order (the simulator sends the scan first;
under ROS the order is anyone's), so a scan newer than the latest odometry waits, and the pose at its stamp
is interpolated from the odometry kept for the last few seconds. Map builder and localizer share this.
"""
from __future__ import annotations

import bisect
import math
from typing import Callable

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from subsumption.planar import from_pose_msg, wrap

ODOM_HISTORY = 5.0  # s of odometry kept


class OdometryHistory:
    """The last few seconds of odometry poses, interpolated at a scan's stamp."""

    def __init__(self) -> None:
        self.stamps: list[float] = []
        self.poses: list[np.ndarray] = []

    def add(self, stamp: float, pose: np.ndarray) -> None:
        if self.stamps and stamp < self.stamps[-1]:  # time went backwards: a restarted simulation
            self.stamps.clear()
            self.poses.clear()
        self.stamps.append(stamp)
        self.poses.append(pose)
        cut = bisect.bisect_left(self.stamps, stamp - ODOM_HISTORY)
        if cut:
            del self.stamps[:cut], self.poses[:cut]

    @property
    def latest(self) -> float:
        return self.stamps[-1] if self.stamps else -math.inf

    def at(self, stamp: float) -> np.ndarray | None:
        """The pose at `stamp`, or None if it is outside what is kept."""
        i = bisect.bisect_left(self.stamps, stamp)
        if i < len(self.stamps) and abs(self.stamps[i] - stamp) < 1e-6:
            return self.poses[i]
        if i == 0 or i == len(self.stamps):
            return None
        t0, t1 = self.stamps[i - 1], self.stamps[i]
        a, b = self.poses[i - 1], self.poses[i]
        f = (stamp - t0) / (t1 - t0)
        return np.array([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * float(wrap(b[2] - a[2]))])


class ScanOdometrySync:
    """Feed it odometry and scans; it calls ``handler(scan, odom_pose)`` once the pose at the scan's time is
    known (or ``missing(scan)`` if that time is older than the odometry kept). ``frames`` holds the odometry's
    (odom frame, base frame) once the first odometry message came."""

    def __init__(self, handler: Callable[[LaserScan, np.ndarray], None],
                 missing: Callable[[LaserScan], None] | None = None) -> None:
        self.history = OdometryHistory()
        self.handler, self.missing = handler, missing
        self.frames: tuple[str, str] | None = None
        self.odom: np.ndarray | None = None  # the latest odometry pose
        self._pending: LaserScan | None = None

    def on_odom(self, msg: Odometry) -> None:
        if self.frames is None:
            self.frames = (msg.header.frame_id, msg.child_frame_id)
        self.odom = from_pose_msg(msg.pose.pose)
        self.history.add(msg.header.stamp.to_sec(), self.odom)
        if self._pending is not None and self._pending.header.stamp.to_sec() <= self.history.latest + 1e-9:
            scan, self._pending = self._pending, None
            self._deliver(scan)

    def on_scan(self, msg: LaserScan) -> None:
        if msg.header.stamp.to_sec() <= self.history.latest + 1e-9:
            self._deliver(msg)
        else:  # the odometry of that instant is not here yet: keep the newest such scan until it is
            self._pending = msg

    def _deliver(self, scan: LaserScan) -> None:
        odom = self.history.at(scan.header.stamp.to_sec())
        if odom is None:
            if self.missing is not None:
                self.missing(scan)
            return
        self.handler(scan, odom)
