"""Adapters between a real base's sensors and what the reference robots' networks read, run by the robot profiles
(profiles/*.launch) as modules.

* :class:`ScanRing`: a LaserScan (a TurtleBot 3's 360-degree LDS, or a depth camera's scan) as Brooks' ring of
  sonars: one sensor_msgs/Range per sector, the nearest valid reading in it, so the wander robot's level 0 runs
  unchanged on a base without sonars. It also passes the scan on with REP 117's conventions (a driver's 0.0 "no
  return" as +inf), for level 2's look.
* :class:`KobukiBumper`: the Kobuki's bumper events (kobuki_msgs/BumperEvent, one per change) as the networks'
  bumper bitmask (std_msgs/UInt8: 1 left, 2 centre, 4 right), sent on every event and repeated while pressed.
"""
from __future__ import annotations

import math

import numpy as np
from sensor_msgs.msg import LaserScan, Range
from std_msgs.msg import UInt8

from subsumption import Input, Module, Output, Param, kobuki


class ScanRing(Module):
    """A laser scan as a ring of `count` virtual sonars on the robot's rim, sonar i facing i * 360/count degrees
    (counter-clockwise from straight ahead), each reading the distance from the rim to the nearest valid return
    whose bearing from the robot's centre lies within its `fov` cone, as Brooks' sonars (and the simulator's) read
    from the rim; a cone the scan does not cover, or where nothing returned, reads +inf (REP 117), a beam blinded
    by something too near (-inf) reads -inf. The scan's origin is `origin_x` m ahead of the centre (a TurtleBot 3's
    LDS: -0.032; a Kinect: -0.087). The ring is sent in order 0..count-1 (a sweep ends with the last, as the wander
    robot's Sonar module expects), frames ``<frame_prefix>sonar_<i>``."""

    scan = Input(LaserScan, "the base's laser scan (any field of view; 0.0 or below range_min: no return)")
    sonar = Output(Range, "count readings a scan, frame_id <frame_prefix>sonar_<i>")
    clean = Output(LaserScan, "the same scan with REP 117 ranges: no return (0.0, NaN) +inf")
    count = Param(12, "number of virtual sonars made from the scan", min=1)
    fov = Param(math.radians(30.0), "rad: each virtual sonar's cone")
    radius = Param(0.0, "m: the robot's radius, where the virtual sonars sit (readings are from the rim)", min=0.0)
    origin_x = Param(0.0, "m: the scan's origin ahead of the robot's centre (negative: behind it)")
    min_range = Param(0.05, "m: the ring's minimum range (nearer readings, REP 117: -inf)", min=0.0)
    frame_prefix = Param("", "prepended to sonar_<i>")

    def on_scan(self, scan: LaserScan) -> None:
        ranges = np.asarray(scan.ranges, dtype=float)
        valid = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges <= scan.range_max)
        too_near = ranges == -math.inf
        self.clean.publish(LaserScan(
            header=scan.header, angle_min=scan.angle_min, angle_max=scan.angle_max,
            angle_increment=scan.angle_increment, time_increment=scan.time_increment, scan_time=scan.scan_time,
            range_min=scan.range_min, range_max=scan.range_max,
            ranges=np.where(valid | too_near, ranges, math.inf).tolist(), intensities=scan.intensities))
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
        reach = np.where(valid, ranges, np.where(too_near, scan.range_min, 0.0))
        x, y = self.origin_x + reach * np.cos(angles), reach * np.sin(angles)
        bearing, rim = np.arctan2(y, x), np.hypot(x, y) - self.radius
        spacing = math.tau / self.count
        nearest = np.round(bearing / spacing).astype(int)
        off = np.abs(np.remainder(bearing - nearest * spacing + math.pi, math.tau) - math.pi)
        sector = np.where(off <= self.fov / 2, np.mod(nearest, self.count), -1)
        ring = np.full(self.count, math.inf)
        hits = valid & (sector >= 0)
        np.minimum.at(ring, sector[hits], rim[hits])
        ring[sector[too_near & (sector >= 0)]] = -math.inf
        ring[ring < self.min_range] = -math.inf
        for i, value in enumerate(ring.tolist()):
            msg = Range(radiation_type=Range.INFRARED, field_of_view=self.fov, min_range=self.min_range,
                        max_range=scan.range_max, range=value)
            msg.header.stamp = scan.header.stamp
            msg.header.frame_id = f"{self.frame_prefix}sonar_{i}"
            self.sonar.publish(msg)


class KobukiBumper(Module):
    """The Kobuki's bumper events as the bumper bitmask the networks read (1 left, 2 centre, 4 right): sent on
    each event, and every `repeat` s while a bumper is pressed, as the simulator sends it (every step in contact,
    then one 0)."""

    events = Input(kobuki.BumperEvent, "/mobile_base/events/bumper: one event per bumper that changed")
    bumper = Output(UInt8, "bitmask of the bumpers pressed now")
    repeat = Param(0.1, "s between repeats while pressed", min=0.01)

    def setup(self) -> None:
        self._bits = 0
        self.every(self.repeat, self._again)

    def on_events(self, msg) -> None:
        bit = kobuki.BUMPER_BITS.get(msg.bumper, 0)
        self._bits = self._bits | bit if msg.state == kobuki.BumperEvent.PRESSED else self._bits & ~bit
        self.bumper.publish(UInt8(self._bits))

    def _again(self) -> None:
        if self._bits:
            self.bumper.publish(UInt8(self._bits))
