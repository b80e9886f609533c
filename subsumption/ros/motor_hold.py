"""Holding a network's motor lines while a ``critical: true`` node is dead: the stop the network file asks for.

The node that publishes a motor line (the last arbiter on a ``geometry_msgs/Twist`` line delivered to an
external topic such as ``cmd_vel``, or the module itself when no arbiter sits on it; subsumption.network.motors)
gets ``~motor_hold`` from ``subsumption launch``::

    ~motor_hold: {monitor: wander_monitor/motors, lines: [cmd_vel]}

It then listens to the network monitor's latched ``motors`` status (subsumption.ros.liveness). When the status
says held (a critical: true node died), the publisher sends **one zero command** on each of its motor lines at
once, then **nothing** from any level until the status says free (the node is back and speaking again). One
zero, then silence, because that is what stops a real base: a kobuki or TurtleBot driver keeps the last command
for a short timeout (0.5-0.6 s) and stops when nothing comes; the zero stops it at once instead of after that
timeout, and the silence keeps it stopped, as it would after any publisher's death (the simulator's bases do the
same). Other lines are never held: an alarm must still be heard.

A publisher with ``~motor_hold`` starts held, until the monitor's first status: a publisher respawned while a
critical node is still dead (a group that hosts both) must not forward the lower levels' commands in the moment
before it hears that. The monitor publishes its status at start, so a healthy start waits only for the first
connection.

Every writer publishes its held lines under :attr:`MotorHold.lock` and checks :attr:`MotorHold.holding` inside it;
the zero is sent under the same lock right after the flag turns, so no command from below can follow the zero.
"""
from __future__ import annotations

import threading
from typing import Any, Callable

import rospy
from diagnostic_msgs.msg import DiagnosticStatus

PARAM = "~motor_hold"


class MotorHoldError(ValueError):
    """A bad ``~motor_hold`` parameter; the message names it."""


class MotorHold:
    """Whether this node's motor lines are held now, from the monitor's ``motors`` status; zero senders run at
    the onset of each hold."""

    def __init__(self, monitor: str, lines: list[str]) -> None:
        self.topic = rospy.resolve_name(monitor)
        self.lines = frozenset(rospy.resolve_name(line) for line in lines)
        self.lock = threading.Lock()
        self.holding = True  # until the monitor speaks (see the module's doc)
        self.why = f"waiting for {self.topic}"
        self.holds = 0  # holds begun (a critical node died), for diagnostics and tests
        self._stops: list[Callable[[], None]] = []
        self._heard = False
        self._subscriber = rospy.Subscriber(self.topic, DiagnosticStatus, self._on_status, queue_size=10)
        rospy.loginfo("%s: motor lines %s held while a critical: true node is dead (%s)", rospy.get_name(),
                      ", ".join(sorted(self.lines)), self.topic)

    def holds_line(self, topic: str) -> bool:
        """Whether `topic` (resolved) is one of the motor lines this node holds."""
        return topic in self.lines

    def on_stop(self, stop: Callable[[], None]) -> None:
        """Call `stop` (it publishes one zero command; called under :attr:`lock`) whenever a hold begins."""
        with self.lock:
            self._stops.append(stop)

    def _on_status(self, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        held = values.get("held", "true" if msg.level != DiagnosticStatus.OK else "false") == "true"
        with self.lock:
            first, self._heard = not self._heard, True
            if held and (first or not self.holding):
                self.holding, self.why = True, msg.message
                self.holds += 1
                for stop in self._stops:
                    try:
                        stop()
                    except Exception as error:  # rospy shutting down; the hold itself stands
                        rospy.logerr("%s: motor hold: zero command failed: %s", rospy.get_name(), error)
                rospy.logwarn("%s: %s: holding %s (one zero command sent)", rospy.get_name(), msg.message,
                              ", ".join(sorted(self.lines)))
            elif not held and self.holding:
                self.holding, self.why = False, ""
                if not first:
                    rospy.logwarn("%s: %s: %s carry commands again", rospy.get_name(), msg.message,
                                  ", ".join(sorted(self.lines)))


def read_motor_hold() -> MotorHold | None:
    """This node's ``~motor_hold`` (None when it has none: it holds nothing); MotorHoldError when malformed."""
    given: Any = rospy.get_param(PARAM, None)
    if given is None:
        return None
    name = rospy.resolve_name(PARAM)
    if not isinstance(given, dict) or not isinstance(given.get("monitor"), str) or not given["monitor"] \
            or not isinstance(given.get("lines"), list) or not given["lines"] \
            or not all(isinstance(line, str) and line for line in given["lines"]):
        raise MotorHoldError(f"{name} must be {{monitor: TOPIC, lines: [TOPIC, ...]}}, got {given!r}")
    return MotorHold(given["monitor"], list(given["lines"]))
