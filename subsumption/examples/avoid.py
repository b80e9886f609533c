"""The paper's worked example: Brooks' ``avoid`` module (Fig. 2), written both ways.

``avoid`` combines the heading the robot would like to take (from ``wander``) with the repulsive force
the sonars feel (from ``feelforce``) and puts out the heading to follow. Headings are std_msgs/Float64:
an angle in radians relative to the robot's current direction (counter-clockwise positive). The force is a
geometry_msgs/Vector3Stamped in the robot's frame, pointing away from obstacles.

- :class:`Avoid` is the AFSM of Fig. 2(a): ``nil`` (event dispatch) waits for a heading, ``plan`` (side
  effect) adds the force to the wanted direction, ``go`` (conditional dispatch) checks the result is a usable
  direction, ``start`` (output) sends it.
- :class:`AvoidCallbacks` is Fig. 2(b): two callbacks sharing a register: the force callback only updates
  it, the heading callback plans and publishes.
"""
from __future__ import annotations

import math

from geometry_msgs.msg import Vector3Stamped
from std_msgs.msg import Float64

from ..afsm import AFSM, ConditionalDispatch, EventDispatch, OutputState, SideEffect
from ..module import Input, Module, Output, Param


def combine(heading: float, force: Vector3Stamped | None, gain: float) -> tuple[float, float]:
    """Add `gain` x force to the unit vector of `heading`; return (angle, length) of the sum."""
    x, y = math.cos(heading), math.sin(heading)
    if force is not None:
        x += gain * force.vector.x
        y += gain * force.vector.y
    return math.atan2(y, x), math.hypot(x, y)


class AvoidInterface(Module):
    """avoid's lines and knobs, shared by both ways of writing its behaviour."""

    force = Input(Vector3Stamped, "repulsive force from feelforce, robot frame")
    heading = Input(Float64, "wanted heading from wander, rad relative to the robot")
    out = Output(Float64, "heading to follow, rad relative to the robot", name="heading")
    gain = Param(1.0, "weight of the force against the unit wanted direction")
    threshold = Param(0.1, "shortest combined vector still taken as a direction")


class Avoid(AFSM, AvoidInterface):
    """Combines the wanted heading with the sonar force (Brooks' avoid, the paper's Fig. 2(a))."""

    states = [
        EventDispatch("nil", on={"heading": "plan"}),
        SideEffect("plan", "plan", next="go"),
        ConditionalDispatch("go", "clear_direction", then="start", otherwise="nil"),
        OutputState("start", "heading", "result_message", next="nil"),
    ]

    def plan(self) -> None:
        """Side effect: add the force to the wanted heading (Brooks' 'plan' state), keeping the result and its
        length."""
        self.result, self.length = combine(self.registers.heading.data, self.registers.force, self.gain)

    def clear_direction(self) -> bool:
        """Whether the combined heading is long enough to act on (at least `threshold`)."""
        return self.length >= self.threshold

    def result_message(self) -> Float64:
        """The combined heading as the message the 'start' state sends."""
        return Float64(self.result)


class AvoidCallbacks(AvoidInterface):
    """The same behaviour as plain callbacks sharing a register (the paper's Fig. 2(b))."""

    # on_force is not needed: the register self.registers.force is the shared variable ('update' state).

    def on_heading(self, msg: Float64) -> None:
        """Fig. 2(b) as plain callbacks: combine the new heading with the latest force and send it when significant."""
        result, length = combine(msg.data, self.registers.force, self.gain)  # 'plan'
        if length >= self.threshold:
            self.out.publish(Float64(result))  # 'start'
