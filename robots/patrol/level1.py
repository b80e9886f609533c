"""Level 1, wander: the wander robot's wander, avoid, turn and forward, fed by the depth camera's map; and on
the TurtleBot's bumper, ``bumpturn``: back off, then turn away from the side that was hit.

The depth camera cannot see a thing nearer than about 0.45 m, nor a table leg below its view, so the
wandering robot does touch things; the bumper says on which side (1 left, 2 centre, 4 right), and
``bumpturn``'s motor commands replace forward's through a suppressor while it backs off and turns.
"""
from __future__ import annotations

import math

from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Empty, Float64, UInt8

from subsumption import AFSM, ConditionalDispatch, EventDispatch, Input, Output, Param, SideEffect

from robots.wander.level0 import Collide as WanderCollide

from .level0 import BUMPER_CENTRE, BUMPER_LEFT, BUMPER_RIGHT, reverse_speed


class Collide(WanderCollide):
    """The wander robot's collide (halt when something is close ahead), which also halts while the camera's map
    is late: older than `max_age` by its stamp, or none for that long. forward drives on until told to halt, and
    a halt lasts 0.3 s: on a loaded ROS graph the depth pipeline fell seconds behind (the office, level 3 with
    move_base silent: a map 2.6 s old at a contact), no halt came, and forward drove the robot at 0.4 m/s into
    what the camera would have shown. Blind, it may still turn; it does not go ahead."""

    max_age = Param(1.0, "s: a map older than this (by its stamp, simulated time) is no sight: forward covers "
                         "0.4 m in it, less than `distance`. Lower halts the robot in a loaded graph's ordinary lag "
                         "(at --rate 3 a 0.3 s wall delay is 0.9 s simulated)", min=0.0)
    period = Param(0.1, "s between checks of the map's age")

    def setup(self) -> None:
        super().setup()
        self._stamp = -math.inf
        self.every(self.period, self._check_age)

    def on_map(self, scan: LaserScan) -> None:
        stamp = scan.header.stamp.to_sec()
        self._stamp = max(self._stamp, stamp if stamp > 0 else self.now())
        super().on_map(scan)

    def _check_age(self) -> None:
        if self.now() - self._stamp > self.max_age:
            self.halt.publish(Empty())


def turn_direction(bits: int, centre: float) -> float:
    """+1 (counter-clockwise, to the left) or -1 (to the right): away from the side the bumper bits name. A hit
    on the left turns right, on the right turns left; a centre hit (or both sides) turns `centre`'s way."""
    left, right = bool(bits & BUMPER_LEFT), bool(bits & BUMPER_RIGHT)
    if left and not right and not bits & BUMPER_CENTRE:
        return -1.0
    if right and not left and not bits & BUMPER_CENTRE:
        return 1.0
    return math.copysign(1.0, centre)


class Bumpturn(AFSM):
    """On a bumper hit: back off `backoff` seconds, then turn away from the side that was hit for `turn`
    seconds (`centre_turn` for a hit in front), sending motor commands every `period` while it does; silent
    otherwise, so the suppressor gives the line back. A new hit while turning (after the bumper was released)
    starts it over from that hit; a contact that goes on, and contacts while backing off, change nothing. It backs
    off blind, so no faster than blindspot's `behind` (the room it remembers behind) allows, as backaway does: a
    hit in a corner whose other wall is behind it turns it without backing into that wall."""

    bumper = Input(UInt8, "bumper bits: 1 left, 2 centre, 4 right; 0 released")
    behind = Input(Float64, "blindspot: m of room behind the rear rim as remembered (none yet: nothing known)")
    cmd_vel = Output(Twist, "velocity command while backing off and turning")
    backoff = Param(0.8, "s backing off")
    backoff_speed = Param(0.25, "m/s backing off")
    turn = Param(0.9, "s turning away after a hit on one side (at `rate`: about 60 degrees)")
    centre_turn = Param(1.8, "s turning after a hit in front (at `rate`: about 120 degrees)")
    centre = Param(1.0, "which way a hit in front turns: +1 left, -1 right")
    rate = Param(1.2, "rad/s while turning")
    period = Param(0.1, "s between commands")
    rear_margin = Param(0.1, "m short of a thing remembered behind where backing off stops", min=0.0)
    rear_time = Param(0.5, "s: backing off no faster than covers the room behind, less the margin, in this time",
                      min=0.01)

    states = [
        EventDispatch("idle", on={"bumper": "hit"}),
        SideEffect("hit", "note_hit", next="back"),
        EventDispatch("back", timeout="backoff", on_timeout="away"),
        SideEffect("away", "start_turn", next="central"),
        ConditionalDispatch("central", "hit_in_front", then="turning_round", otherwise="turning"),
        EventDispatch("turning", on={"bumper": "hit"}, timeout="turn", on_timeout="done"),
        EventDispatch("turning_round", on={"bumper": "hit"}, timeout="centre_turn", on_timeout="done"),
        SideEffect("done", "stop", next="idle"),
    ]

    def setup(self) -> None:
        super().setup()
        self._command: Twist | None = None
        self._bits = 0
        self._released = True
        self.every(self.period, self._send)

    def on_input(self, name: str, msg) -> None:
        if name == "behind":
            return  # a register read when backing off, no event
        if name == "bumper":
            if not msg.data & (BUMPER_LEFT | BUMPER_CENTRE | BUMPER_RIGHT):
                self._released = True  # a release is no event, but the next contact is a new hit
                return
            if self.state.name != "idle" and not self._released:
                return  # the same contact goes on (the bumper reports it at every physics step)
        super().on_input(name, msg)

    def note_hit(self) -> None:
        self._bits = self.registers.bumper.data
        self._released = False
        self._command = Twist()
        self._command.linear.x = -self.backoff_speed
        self.log(f"bumper {self._bits}: backing off")

    def start_turn(self) -> None:
        self._command = Twist()
        self._command.angular.z = turn_direction(self._bits, self.centre) * self.rate

    def hit_in_front(self) -> bool:
        both = BUMPER_LEFT | BUMPER_RIGHT
        return bool(self._bits & BUMPER_CENTRE) or self._bits & both == both

    def stop(self) -> None:
        self._command = None

    def _send(self) -> None:
        if self._command is None:
            return
        command = self._command
        if command.linear.x < 0:
            behind = self.registers.behind
            room = reverse_speed(-command.linear.x, math.inf if behind is None else behind.data, self.rear_margin,
                                 self.rear_time)
            command = Twist(linear=type(command.linear)(x=-room), angular=command.angular)
        self.cmd_vel.publish(command)
