"""Tiny modules around the paper's ``avoid`` so that a two-level network can run with no robot.

They stand in for sensors and motors in ``avoid_demo.yaml``: ``feelforce`` sends a constant repulsive force,
``runaway`` turns a significant force into a heading away from it (level 0 alone keeps the robot off
obstacles), ``wander`` wants a heading now and then, and ``turn`` makes a velocity command of a heading.
Level 1's ``avoid`` combines wander's heading with the force, and a suppressor lets its heading take over
``turn``'s input from runaway's (Brooks' Fig. 1).
"""
from __future__ import annotations

import math

from geometry_msgs.msg import Twist, Vector3, Vector3Stamped
from std_msgs.msg import Float64

from ..module import Input, Module, Output, Param


class FeelForce(Module):
    """Sends a constant repulsive force (robot frame, pointing away from obstacles) every `period` s."""

    force = Output(Vector3Stamped, "repulsive force, robot frame")
    period = Param(0.5, "seconds between force messages")
    x = Param(0.0, "force along the robot's heading")
    y = Param(1.0, "force to the robot's left")

    def setup(self) -> None:
        self.every(self.period, lambda: self.force.publish(Vector3Stamped(vector=Vector3(self.x, self.y, 0.0))))


class Runaway(Module):
    """Turns a significant repulsive force into a heading along it (away from the obstacle)."""

    force = Input(Vector3Stamped, "repulsive force, robot frame")
    heading = Output(Float64, "heading away from the force, rad relative to the robot")
    threshold = Param(0.5, "force magnitude that counts as significant")

    def on_force(self, msg: Vector3Stamped) -> None:
        """Send the heading along a significant force (away from the obstacle); a weak force sends nothing."""
        if math.hypot(msg.vector.x, msg.vector.y) > self.threshold:
            self.heading.publish(Float64(math.atan2(msg.vector.y, msg.vector.x)))


class Wander(Module):
    """Wants to go in direction `heading` (rad, relative), saying so every `period` s."""

    heading = Output(Float64, "wanted heading, rad relative to the robot")
    period = Param(1.0, "seconds between headings")
    direction = Param(0.0, "the wanted heading, rad")

    def setup(self) -> None:
        self.every(self.period, lambda: self.heading.publish(Float64(self.direction)))


class Turn(Module):
    """Turns toward a heading: a velocity command with angular speed `gain` x heading, forward `speed`."""

    heading = Input(Float64, "heading to take, rad relative to the robot")
    cmd_vel = Output(Twist, "velocity command")
    gain = Param(1.0, "angular speed (rad/s) per radian of heading")
    speed = Param(0.2, "forward speed, m/s")

    def on_heading(self, msg: Float64) -> None:
        """Turn a heading into a velocity command: forward at `speed`, turning at `gain` times the heading."""
        command = Twist()
        command.linear.x = self.speed
        command.angular.z = self.gain * msg.data
        self.cmd_vel.publish(command)
