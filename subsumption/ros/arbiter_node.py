"""The generic inhibitor, suppressor and defaulter ROS nodes, for any message type.

They subscribe ``upper`` and ``lower`` as ``rospy.AnyMsg`` and relay the serialized bytes untouched,
publishing ``output`` with the type, md5sum and definition read from the first incoming connection, so no
message code is generated or even imported. Usage::

    rosrun subsumption suppressor upper:=/avoid/heading lower:=/runaway/heading \\
        output:=/turn/heading _time_constant:=2.0

``~time_constant`` (seconds of ROS time, > 0) is required. A suppressor or defaulter forwards both lines,
so their types must agree: a mismatch is logged as an error naming both topics and types, shown on
``~status``, and the offending line is dropped. ``~status`` (diagnostic_msgs/DiagnosticStatus) says which
line is in control and how many messages each line passed and lost, on change and once a second.
"""
from __future__ import annotations

import sys
import threading

import rospy
from diagnostic_msgs.msg import DiagnosticStatus

from ..arbiter import STATUS_PERIOD, status_message
from ..arbitration import ArbiterKind, ArbiterRule


class ParameterError(ValueError):
    """A bad or missing ~parameter; the message names it."""


def _relay_class(header: dict[str, str]) -> type:
    """A publishable class for the type described by a connection header (bytes are passed through)."""
    return type("Relayed_" + header["type"].replace("/", "_"), (rospy.AnyMsg,),
                {"_type": header["type"], "_md5sum": header["md5sum"],
                 "_full_text": header.get("message_definition", "")})


class ArbiterNode:
    def __init__(self, kind: ArbiterKind, time_constant: float) -> None:
        self.kind = kind
        self.rule = ArbiterRule(kind, time_constant)
        self.name = rospy.get_name()
        self._lock = threading.Lock()
        self._publisher: rospy.Publisher | None = None
        self._output_type: str | None = None
        self._line_types: dict[str, str] = {}
        self._error = ""
        self._upper_in_control = False
        self._topics = {line: rospy.resolve_name(line) for line in ("upper", "lower", "output")}
        self._status = rospy.Publisher("~status", DiagnosticStatus, queue_size=10, latch=True)
        rospy.Subscriber("upper", rospy.AnyMsg, self._on_upper, queue_size=100, tcp_nodelay=True)
        rospy.Subscriber("lower", rospy.AnyMsg, self._on_lower, queue_size=100, tcp_nodelay=True)
        rospy.Timer(rospy.Duration.from_sec(STATUS_PERIOD), lambda _e: self.publish_status())
        rospy.loginfo("%s: %s, T = %.3f s, %s + %s -> %s", self.name, kind.value, time_constant,
                      self._topics["upper"], self._topics["lower"], self._topics["output"])

    def _on_upper(self, msg: rospy.AnyMsg) -> None:
        with self._lock:
            forward = self.rule.on_upper(rospy.get_time())
            if forward and self._accepts("upper", msg):
                self._publish(msg)
            changed = self._changed()
        if changed:
            self.publish_status()

    def _on_lower(self, msg: rospy.AnyMsg) -> None:
        with self._lock:
            forward = self.rule.on_lower(rospy.get_time())
            if forward and self._accepts("lower", msg):
                self._publish(msg)
            changed = self._changed()
        if changed:
            self.publish_status()

    def _accepts(self, line: str, msg: rospy.AnyMsg) -> bool:
        """Types are learnt from each line's first message; a line whose type differs from the output's is refused."""
        msg_type = self._line_types.get(line)
        if msg_type is None:
            msg_type = self._line_types[line] = msg._connection_header["type"]
            if self._output_type is None:
                self._output_type = msg_type
                self._publisher = rospy.Publisher("output", _relay_class(msg._connection_header),
                                                  queue_size=100, tcp_nodelay=True)
            elif msg_type != self._output_type:
                other = "lower" if line == "upper" else "upper"
                self._error = (f"type mismatch: {line} {self._topics[line]} carries {msg_type} but "
                               f"{other} {self._topics[other]} carries {self._output_type}; "
                               f"dropping {self._topics[line]}")
                rospy.logerr("%s: %s", self.name, self._error)
                self.publish_status()
        return msg_type == self._output_type

    def _publish(self, msg: rospy.AnyMsg) -> None:
        assert self._publisher is not None
        self._publisher.publish(msg)

    def _changed(self) -> bool:
        return self.rule.upper_in_control(rospy.get_time()) != self._upper_in_control

    def publish_status(self) -> None:
        now = rospy.get_time()
        self._upper_in_control = self.rule.upper_in_control(now)
        self._status.publish(status_message(self.name, self.rule, now, self._error))


def read_time_constant() -> float:
    """~time_constant, checked: it is required, a number, and > 0."""
    if not rospy.has_param("~time_constant"):
        raise ParameterError(f"{rospy.resolve_name('~time_constant')} is required (seconds of ROS time, > 0)")
    value = rospy.get_param("~time_constant")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ParameterError(f"{rospy.resolve_name('~time_constant')} must be a number of seconds > 0, "
                             f"got {value!r}")
    return float(value)


def main(kind: str, argv: list[str] | None = None) -> int:
    arbiter_kind = ArbiterKind(kind)
    rospy.init_node(arbiter_kind.value, argv=argv if argv is not None else sys.argv)
    try:
        node = ArbiterNode(arbiter_kind, read_time_constant())
    except ParameterError as error:
        rospy.logfatal("%s: %s", rospy.get_name(), error)
        print(f"{rospy.get_name()}: error: {error}", file=sys.stderr)
        return 2
    node.publish_status()
    rospy.spin()
    return 0
