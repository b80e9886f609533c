"""Adapters between a real base's sensors and what the reference robots' networks read, run by the robot profiles
(profiles/*.launch) as modules.

* :class:`ScanRing`: a LaserScan (a TurtleBot 3's 360-degree LDS, or a depth camera's scan) as Brooks' ring of
  sonars: one sensor_msgs/Range per sector, the nearest valid reading in it, so the wander robot's level 0 runs
  unchanged on a base without sonars. It also passes the scan on with REP 117's conventions (a driver's 0.0 "no
  return" as +inf), for level 2's look.
* :class:`KobukiBumper`: the Kobuki's bumper and cliff events (kobuki_msgs/BumperEvent, CliffEvent, one per
  change) as the networks' bumper bitmask (std_msgs/UInt8: 1 left, 2 centre, 4 right), sent on every event and
  repeated while pressed: a cliff under a sensor reads as a contact on that side, so level 0 backs off it.
"""
from __future__ import annotations

import math

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, Range
from std_msgs.msg import UInt8

from navigation.obstacle_memory import ObstacleMemory
from navigation.scan_geometry import beams_of
from subsumption import Input, Module, Output, Param, kobuki
from subsumption.planar import from_pose_msg


class ScanRing(Module):
    """A laser scan as a ring of `count` virtual sonars on the robot's rim, sonar i facing i * 360/count degrees
    (counter-clockwise from straight ahead), each reading the distance from the rim to the nearest valid return
    whose bearing from the robot's centre lies within its `fov` cone, as Brooks' sonars (and the simulator's) read
    from the rim; a cone the scan does not cover, or where nothing returned, reads +inf (REP 117), a beam blinded
    by something too near (-inf) reads -inf. The scan's origin is `origin_x` m ahead of the centre (a TurtleBot 3's
    LDS: -0.032; a Kinect: -0.087). The ring is sent in order 0..count-1 (a sweep ends with the last, as the wander
    robot's Sonar module expects), frames ``<frame_prefix>sonar_<i>``. With ``memory`` > 0 and odometry, what the
    scan saw is remembered (moved by odometry) while the scan cannot see its place, so a narrow sensor's ring
    (a Kinect's 57 degrees) still knows the wall it has just turned from."""

    scan = Input(LaserScan, "the base's laser scan (any field of view; 0.0 or below range_min: no return)")
    odom = Input(Odometry, "the base's odometry (only with memory > 0: moves what is remembered)")
    sonar = Output(Range, "count readings a scan, frame_id <frame_prefix>sonar_<i>")
    clean = Output(LaserScan, "the same scan with REP 117 ranges: no return (0.0, NaN) +inf")
    count = Param(12, "number of virtual sonars made from the scan", min=1)
    fov = Param(math.radians(30.0), "rad: each virtual sonar's cone")
    radius = Param(0.0, "m: the robot's radius, where the virtual sonars sit (readings are from the rim)", min=0.0)
    origin_x = Param(0.0, "m: the scan's origin ahead of the robot's centre (negative: behind it)")
    min_range = Param(0.05, "m: the ring's minimum range (nearer readings, REP 117: -inf)", min=0.0)
    max_range = Param(3.0, "m: the ring's maximum range, as a sonar's (farther: +inf). The wander robot's force "
                           "field expects sonars that see 3 m: with a laser's range, far walls add up to a force "
                           "that sets off runaway all the time in a corridor", min=0.0)
    memory = Param(0.0, "s: remember what the scan saw this long while it cannot see the place (outside its view, "
                        "nearer than its minimum range): a narrow sensor's ring then covers the robot's sides; "
                        "0: the scan alone", min=0.0)
    reach = Param(1.5, "m from the robot beyond which remembered points are forgotten", min=0.0)
    frame_prefix = Param("", "prepended to sonar_<i>")

    def setup(self) -> None:
        # navigation's obstacle memory (costmap_2d's obstacle layer for a narrow scan), one point per 5 cm
        self._memory = ObstacleMemory(self.memory, self.reach, cell=0.05) if self.memory > 0 else None

    def on_scan(self, scan: LaserScan) -> None:
        ranges = np.asarray(scan.ranges, dtype=float)
        valid = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges <= scan.range_max)
        too_near = ranges == -math.inf
        self.clean.publish(LaserScan(
            header=scan.header, angle_min=scan.angle_min, angle_max=scan.angle_max,
            angle_increment=scan.angle_increment, time_increment=scan.time_increment, scan_time=scan.scan_time,
            range_min=scan.range_min, range_max=scan.range_max,
            ranges=np.where(valid | too_near, ranges, math.inf).tolist(), intensities=scan.intensities))
        beams = beams_of(scan, (np.array([self.origin_x, 0.0, 0.0]), False))
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))[too_near]
        blinded = np.column_stack((self.origin_x + scan.range_min * np.cos(angles), scan.range_min * np.sin(angles)))
        points = np.concatenate([beams.hits(), blinded])
        if self._memory is not None and self.registers.odom is not None:
            pose = from_pose_msg(self.registers.odom.pose.pose)
            kept = self._memory.update(self.now(), pose, beams, scan.range_min, points)
            points = np.concatenate([points, kept])
        self._publish_ring(points, scan)

    def _publish_ring(self, points: np.ndarray, scan: LaserScan) -> None:
        """Each virtual sonar: the distance from the rim to the nearest point whose bearing is in its cone."""
        bearing = np.arctan2(points[:, 1], points[:, 0])
        rim = np.hypot(points[:, 0], points[:, 1]) - self.radius
        spacing = math.tau / self.count
        nearest = np.round(bearing / spacing).astype(int)
        off = np.abs(np.remainder(bearing - nearest * spacing + math.pi, math.tau) - math.pi)
        sector = np.where(off <= self.fov / 2, np.mod(nearest, self.count), -1)
        ring = np.full(self.count, math.inf)
        inside = sector >= 0
        np.minimum.at(ring, sector[inside], rim[inside])
        ring[ring < self.min_range] = -math.inf
        ring[ring > self.max_range] = math.inf
        for i, value in enumerate(ring.tolist()):
            msg = Range(radiation_type=Range.INFRARED, field_of_view=self.fov, min_range=self.min_range,
                        max_range=self.max_range, range=value)
            msg.header.stamp = scan.header.stamp
            msg.header.frame_id = f"{self.frame_prefix}sonar_{i}"
            self.sonar.publish(msg)


class KobukiBumper(Module):
    """The Kobuki's bumper and cliff events as the bumper bitmask the networks read (1 left, 2 centre, 4 right):
    sent on each event, and every `repeat` s while a bumper is pressed or a cliff seen, as the simulator sends it
    (every step in contact, then one 0). A cliff under the left, centre or right cliff sensor sets that side's bit:
    to the patrol robot's level 0 (backaway, bumpturn, blindspot) a stair edge is a thing touched on that side,
    which is what Brooks' level 0 does with any contact: back off it and turn away. (The motor guard has already
    stopped the base from the event itself; this is what makes the robot leave.)"""

    events = Input(kobuki.BumperEvent, "/mobile_base/events/bumper: one event per bumper that changed")
    cliff = Input(kobuki.CliffEvent, "/mobile_base/events/cliff: one event per cliff sensor that changed")
    bumper = Output(UInt8, "bitmask of the bumpers pressed and cliff sensors over a cliff now")
    repeat = Param(0.1, "s between repeats while pressed", min=0.01)

    def setup(self) -> None:
        self._pressed = 0
        self._cliffs = 0
        self.every(self.repeat, self._again)

    def on_events(self, msg) -> None:
        bit = kobuki.BUMPER_BITS.get(msg.bumper, 0)
        self._pressed = self._pressed | bit if msg.state == kobuki.BumperEvent.PRESSED else self._pressed & ~bit
        self.bumper.publish(UInt8(self._pressed | self._cliffs))

    def on_cliff(self, msg) -> None:
        bit = kobuki.BUMPER_BITS.get(msg.sensor, 0)  # cliff sensors LEFT 0, CENTER 1, RIGHT 2, as the bumpers
        self._cliffs = self._cliffs | bit if msg.state == kobuki.CliffEvent.CLIFF else self._cliffs & ~bit
        self.bumper.publish(UInt8(self._pressed | self._cliffs))

    def _again(self) -> None:
        if self._pressed | self._cliffs:
            self.bumper.publish(UInt8(self._pressed | self._cliffs))
