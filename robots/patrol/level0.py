"""Level 0, avoid contact: the TurtleBot stays where it is and backs away from whatever comes towards it.

scan (depth camera) -> depthmap -> map -> feelforce -> force -> runaway -> heading -> backaway -> cmd_vel
bumper ------------------------------------------------------------------------^

The wander robot's feelforce and runaway do the same job here, fed by the depth camera's scan instead of the
sonar ring; what differs on the TurtleBot is written here. Its depth camera looks ahead only (about 58
degrees) and sees nothing nearer than about 0.45 m, so ``depthmap`` reads "too near" as very near (as the
wander robot's sonar module does) and the bumper tells about a thing touching the front. And since the robot
cannot see behind it, ``backaway`` reverses away from what comes at it, keeping it in view, instead of turning
its back on it as the wander robot's turn and forward would.
"""
from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64, UInt8

from subsumption import Input, Module, Output, Param

BUMPER_LEFT, BUMPER_CENTRE, BUMPER_RIGHT = 1, 2, 4  # std_msgs/UInt8 bits, as the Kobuki base reports them


class Depthmap(Module):
    """Turns the depth camera's scan into a coarse robot-centred obstacle map: a LaserScan of `sectors` beams,
    each the nearest reading within its sector of the camera's view. REP 117 readings nearer than the minimum
    (-inf) count as the minimum, so an object inside the camera's blind distance reads "very close"; +inf
    (nothing within range) and NaN add nothing. feelforce and collide read this map as they read the
    wander robot's sonar map."""

    scan = Input(LaserScan, "the depth camera's scan (or any forward-looking scan)")
    map = Output(LaserScan, "one range per sector, sector i centred at angle_min + i * angle_increment")
    sectors = Param(3, "number of sectors the view is cut into", min=1)

    def on_scan(self, scan: LaserScan) -> None:
        ranges = np.asarray(scan.ranges, dtype=float)
        if ranges.size == 0:
            return
        near = np.isneginf(ranges) | (np.isfinite(ranges) & (ranges < scan.range_min))
        ranges = np.where(near, scan.range_min, ranges)
        ranges = np.where(np.isnan(ranges) | (ranges > scan.range_max), np.inf, ranges)
        parts = np.array_split(ranges, min(self.sectors, ranges.size))
        width = scan.angle_increment * ranges.size / len(parts)
        out = LaserScan()
        out.header = scan.header
        out.angle_min = scan.angle_min - scan.angle_increment / 2 + width / 2
        out.angle_increment = width
        out.angle_max = out.angle_min + width * (len(parts) - 1)
        out.range_min, out.range_max = scan.range_min, scan.range_max
        out.ranges = [float(part.min()) for part in parts]
        self.map.publish(out)


class Backaway(Module):
    """The TurtleBot's level-0 motor module: stands still until told to flee, then reverses away, keeping the
    thing that comes at it in front of the camera. A heading behind the robot (runaway's "away from it")
    backs it up, steering so that its back points that way; a heading ahead drives it forward (something
    touched it from behind). A bumper hit backs it straight up for `bump_hold` seconds, whatever the scan says:
    the camera cannot see a thing that close."""

    heading = Input(Float64, "runaway: the way away from the obstacles, rad relative to the robot")
    bumper = Input(UInt8, "bumper bits: 1 left, 2 centre, 4 right; 0 released")
    cmd_vel = Output(Twist, "velocity command to the base")
    speed = Param(0.5, "m/s backing away (faster than a person walking slowly at the robot)")
    max_rate = Param(1.0, "rad/s")
    gain = Param(2.0, "rad/s per rad of heading error")
    period = Param(0.1, "s between commands")
    hold = Param(0.5, "s a heading stays valid")
    bump_hold = Param(1.0, "s the robot keeps backing up after a bumper hit")

    def setup(self) -> None:
        self._heading_at = -math.inf
        self._bumped_at = -math.inf
        self.every(self.period, self.drive)

    def on_heading(self, msg: Float64) -> None:
        self._heading_at = self.now()

    def on_bumper(self, msg: UInt8) -> None:
        if msg.data & (BUMPER_LEFT | BUMPER_CENTRE | BUMPER_RIGHT):
            self._bumped_at = self.now()

    def drive(self) -> None:
        now = self.now()
        command = Twist()
        if now - self._bumped_at <= self.bump_hold:
            command.linear.x = -self.speed
        elif self.registers.heading is not None and now - self._heading_at <= self.hold:
            heading = math.remainder(self.registers.heading.data, math.tau)
            backwards = abs(heading) > math.pi / 2
            error = math.remainder(heading - math.pi, math.tau) if backwards else heading
            command.angular.z = max(-self.max_rate, min(self.max_rate, self.gain * error))
            command.linear.x = (-1.0 if backwards else 1.0) * self.speed * math.cos(error) ** 2
        self.cmd_vel.publish(command)
