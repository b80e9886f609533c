"""Level 0, avoid contact: the robot keeps still in the open and moves away from whatever comes close.

sonar -> map -> {collide -> halt, feelforce -> force -> runaway -> heading} -> turn -> encoders -> forward -> cmd_vel

Headings are std_msgs/Float64, radians relative to where the robot points now (counter-clockwise positive);
they are sent at the sonar rate, so a module never needs to know how far the robot has turned since.
"""
from __future__ import annotations

import math
import re

from geometry_msgs.msg import Twist, Vector3Stamped
from sensor_msgs.msg import LaserScan, Range
from std_msgs.msg import Empty, Float64

from subsumption import Input, Module, Output, Param

_SONAR_INDEX = re.compile(r"(\d+)$")


class Sonar(Module):
    """Turns the ring of sonar readings into a robot-centred obstacle map: a 12-beam LaserScan whose beam i
    points at sonar i's angle. Readings closer than the minimum (REP 117: -inf) count as the minimum, so a
    blinded sonar means "very close"; +inf (nothing within range) stays +inf.

    A sweep ends with the last sonar of the ring (index count - 1), the order a ring fires in and the simulator
    sends in. Ending it there, rather than whenever twelve fresh readings have come, keeps a node that joined
    mid-sweep (a late subscriber, a bag that starts mid-burst) in step with one that saw every reading."""

    ranges = Input(Range, "every sonar on one topic; frame_id ends in the sonar's index")
    map = Output(LaserScan, "one range per sonar, beam i at angle_min + i * angle_increment")
    count = Param(12, "number of sonars")
    first_angle = Param(0.0, "rad, direction of sonar 0 (straight ahead)")
    spacing = Param(math.radians(30.0), "rad between neighbouring sonars, counter-clockwise")

    def setup(self) -> None:
        self._ranges = [math.inf] * self.count
        self._heard: set[int] = set()  # sonars read at least once: no map until every one has been

    def on_ranges(self, msg: Range) -> None:
        match = _SONAR_INDEX.search(msg.header.frame_id)
        if match is None or int(match.group(1)) >= self.count:
            self.log(f"ignoring sonar reading from frame {msg.header.frame_id!r}", "warn")
            return
        index = int(match.group(1))
        self._ranges[index] = msg.min_range if msg.range == -math.inf or msg.range < msg.min_range else msg.range
        self._heard.add(index)
        self._range_limits = (msg.min_range, msg.max_range)
        if index == self.count - 1 and len(self._heard) == self.count:  # the sweep's end: publish it
            self.map.publish(self._scan(msg))

    def _scan(self, last: Range) -> LaserScan:
        scan = LaserScan()
        scan.header.stamp = last.header.stamp
        scan.header.frame_id = re.sub(r"sonar_?\d+$", "base_link", last.header.frame_id)
        scan.angle_min = self.first_angle
        scan.angle_increment = self.spacing
        scan.angle_max = self.first_angle + self.spacing * (self.count - 1)
        scan.range_min, scan.range_max = self._range_limits
        scan.ranges = list(self._ranges)
        return scan


def beams(scan: LaserScan):
    """(angle, range) of every beam of a scan."""
    return ((scan.angle_min + i * scan.angle_increment, r) for i, r in enumerate(scan.ranges))


class Collide(Module):
    """Sends halt when something is directly ahead and close (Brooks: collide -> halt -> forward)."""

    map = Input(LaserScan)
    halt = Output(Empty)
    distance = Param(0.4, "m from the sonar: closer than this, straight ahead, is a collision coming")
    half_angle = Param(math.radians(20.0), "rad either side of straight ahead that counts as ahead")

    def on_map(self, scan: LaserScan) -> None:
        for angle, rng in beams(scan):
            if abs(math.remainder(angle, math.tau)) <= self.half_angle and rng < self.distance:
                self.halt.publish(Empty())
                return


class Feelforce(Module):
    """Sums a repulsive force from every sonar reading: 1/r^2 along the beam, pointing away from the obstacle,
    in the robot's frame. Readings outside the sonars' range add nothing."""

    map = Input(LaserScan)
    force = Output(Vector3Stamped)

    def on_map(self, scan: LaserScan) -> None:
        fx = fy = 0.0
        for angle, rng in beams(scan):
            if math.isfinite(rng) and scan.range_min <= rng <= scan.range_max:
                fx -= math.cos(angle) / (rng * rng)
                fy -= math.sin(angle) / (rng * rng)
        msg = Vector3Stamped()
        msg.header = scan.header
        msg.vector.x, msg.vector.y = fx, fy
        self.force.publish(msg)


class Runaway(Module):
    """When the force is significant, sends the heading it points to: away from the obstacles."""

    force = Input(Vector3Stamped)
    heading = Output(Float64)
    threshold = Param(0.5, "force magnitude (sum of 1/m^2) that counts as significant")

    def on_force(self, msg: Vector3Stamped) -> None:
        if math.hypot(msg.vector.x, msg.vector.y) > self.threshold:
            self.heading.publish(Float64(math.atan2(msg.vector.y, msg.vector.x)))


class Turn(Module):
    """Turns towards a heading: sends forward a rotation rate, and how much of the forward speed may be used
    (cos^2 of the heading error, none when the heading is behind), as a Twist on `encoders`. A heading
    nearly behind the robot keeps the way it was already turning, so that noise around +-pi cannot make it
    dither left and right on the spot."""

    heading = Input(Float64)
    encoders = Output(Twist, "angular.z: rad/s to turn; linear.x: fraction of forward speed allowed (0..1)")
    max_rate = Param(1.0, "rad/s: fastest turn")
    gain = Param(2.0, "rad/s per rad of heading error")
    behind = Param(2.5, "rad: a heading error beyond this counts as behind")

    def setup(self) -> None:
        self._direction = 0.0

    def on_heading(self, msg: Float64) -> None:
        error = math.remainder(msg.data, math.tau)
        command = Twist()
        if abs(error) > self.behind and self._direction:
            command.angular.z = self._direction * self.max_rate
        else:
            command.angular.z = max(-self.max_rate, min(self.max_rate, self.gain * error))
        self._direction = math.copysign(1.0, command.angular.z) if command.angular.z else 0.0
        command.linear.x = max(0.0, math.cos(error)) ** 2
        self.encoders.publish(command)


class Forward(Module):
    """The motor module: drives the base at a steady rate from turn's last command, stops moving forward while
    collide says halt, and stands still when no command is fresh."""

    encoders = Input(Twist)
    halt = Input(Empty)
    cmd_vel = Output(Twist, "velocity command to the base")
    speed = Param(0.5, "m/s at full forward")
    period = Param(0.1, "s between commands")
    hold = Param(0.5, "s a turn command stays valid")
    halt_hold = Param(0.3, "s a halt lasts")

    def setup(self) -> None:
        self._last_command = -math.inf
        self._last_halt = -math.inf
        self.every(self.period, self.drive)

    def on_encoders(self, msg: Twist) -> None:
        self._last_command = self.now()

    def on_halt(self, msg: Empty) -> None:
        self._last_halt = self.now()

    def drive(self) -> None:
        now = self.now()
        command = Twist()
        if self.registers.encoders is not None and now - self._last_command <= self.hold:
            command.angular.z = self.registers.encoders.angular.z
            if now - self._last_halt > self.halt_hold:
                command.linear.x = self.speed * self.registers.encoders.linear.x
        self.cmd_vel.publish(command)
