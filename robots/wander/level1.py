"""Level 1, wander: every few seconds a new random direction, followed (through the paper's avoid AFSM,
subsumption.examples.avoid.Avoid, which bends it away from obstacles) in place of runaway's heading.

Brooks (1986): "The wander module generates a new heading for the robot every 10 seconds or so." The heading is
drawn uniformly from the whole circle, so the robot wanders aimlessly: it goes nowhere in particular, which is
what level 2's explore improves on. A smaller `spread` turns it into a persistent walk that keeps roughly to
its direction."""
from __future__ import annotations

import math
import random

from nav_msgs.msg import Odometry
from std_msgs.msg import Float64

from subsumption import Input, Module, Output, Param
from subsumption.planar import wrap, yaw_of


class Wander(Module):
    """Picks a direction at random (uniform within +-spread of where the robot points; the default spread is the
    whole circle) every `interval` seconds, keeps it fixed in the odometry frame, and sends it as a relative
    heading at the sensor rate."""

    odom = Input(Odometry)
    heading = Output(Float64)
    interval = Param(5.0, "s between new directions")
    spread = Param(math.pi, "rad either side of the current direction (pi: any direction)")
    period = Param(0.1, "s between headings")
    seed = Param(0, "random seed (reproducible runs)")

    def setup(self) -> None:
        self._random = random.Random(self.seed)
        self._target: float | None = None
        self._picked_at = -math.inf
        self.every(self.period, self.send)

    def send(self) -> None:
        if self.registers.odom is None:
            return
        yaw = yaw_of(self.registers.odom.pose.pose.orientation)
        if self._target is None or self.now() - self._picked_at >= self.interval:
            self._target = wrap(yaw + self._random.uniform(-self.spread, self.spread))
            self._picked_at = self.now()
        self.heading.publish(Float64(wrap(self._target - yaw)))
