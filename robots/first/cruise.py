"""The README's first robot: a module that drives ahead and turns away from what the laser sees in front."""
from __future__ import annotations

import math

from geometry_msgs.msg import Twist, Vector3
from sensor_msgs.msg import LaserScan

from subsumption import Input, Module, Output, Param


class Cruise(Module):
    """Drives ahead at `speed`; while anything is nearer than `clearance` within `cone` of straight ahead, turns
    on the spot instead (to the left), until the way ahead is clear."""

    scan = Input(LaserScan, "the laser scan, robot frame")
    cmd_vel = Output(Twist, "velocity command for the base")
    speed = Param(0.3, "forward speed when the way is clear, m/s", min=0.0)
    clearance = Param(0.7, "distance ahead that counts as blocked, m", min=0.0)
    cone = Param(0.5, "half-width of the 'ahead' cone, rad", min=0.0, max=math.pi)

    def on_scan(self, msg: LaserScan) -> None:
        """One command per scan: ahead when the cone is clear, else a turn on the spot."""
        ahead = [r for i, r in enumerate(msg.ranges) if abs(msg.angle_min + i * msg.angle_increment) < self.cone]
        blocked = min(ahead, default=math.inf) < self.clearance
        self.cmd_vel.publish(Twist(linear=Vector3(0.0 if blocked else self.speed, 0.0, 0.0),
                                   angular=Vector3(0.0, 0.0, 1.0 if blocked else 0.0)))
