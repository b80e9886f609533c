"""The robot's own levels in ``operator_demo.yaml``: one module that keeps the robot cruising.

It stands for a patrol robot's lower levels (which would drive towards patrol goals), so the operator
terminal's suppressor and inhibitor can be seen taking the motor line over and handing it back.
"""
from __future__ import annotations

from geometry_msgs.msg import Twist

from subsumption import Module, Output, Param


class Cruise(Module):
    """Sends a constant forward motor command every `period` s: the robot's own idea of where to go."""

    cmd_vel = Output(Twist, "motor command of the robot's own levels")
    period = Param(0.1, "seconds between commands")
    speed = Param(0.2, "forward speed, m/s")

    def setup(self) -> None:
        def send() -> None:
            command = Twist()
            command.linear.x = self.speed
            self.cmd_vel.publish(command)

        self.every(self.period, send)
