"""The generic inhibitor, suppressor and defaulter ROS nodes, for any message type.

They subscribe ``upper`` and ``lower`` as ``rospy.AnyMsg`` and relay the serialized bytes untouched,
publishing ``output`` with the type, md5sum and definition read from the first incoming connection, so no
message code is generated or even imported. Usage::

    rosrun subsumption suppressor upper:=/avoid/heading lower:=/runaway/heading \\
        output:=/turn/heading _time_constant:=2.0

``~time_constant`` (seconds of ROS time, > 0) is required. A suppressor or defaulter forwards both lines,
so their types must agree: a mismatch is logged as an error naming both topics and types, shown on
``~status``, and the offending line is never relayed (its messages count as dropped). ``~status``
(diagnostic_msgs/DiagnosticStatus) says which line is in control and how many messages each line passed and
lost, on change and once a second. ``~queue_size`` (default 0: synchronous) is the output publisher's queue;
see docs/arbiters.md for why synchronous is the default.
"""
from __future__ import annotations

import sys
import threading
import warnings
from typing import Callable

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
    """One arbiter in this process's ROS node; callbacks of both lines are serialised by one lock."""

    def __init__(self, kind: ArbiterKind, time_constant: float, queue_size: int | None = None) -> None:
        """queue_size None publishes `output` synchronously (see :func:`read_queue_size`)."""
        self.kind = kind
        self.queue_size = queue_size
        self.rule = ArbiterRule(kind, time_constant)
        self.name = rospy.get_name()
        self._lock = threading.Lock()
        self._publisher: rospy.Publisher | None = None
        self._output_type: str | None = None
        self._accepted: set[str] = set()  # lines whose type is known to match the output's
        self._refused: set[str] = set()
        self._error = ""
        self._upper_in_control = False
        self._status_due = False  # an error to report at once
        self._topics = {line: rospy.resolve_name(line) for line in ("upper", "lower", "output")}
        self._status = rospy.Publisher("~status", DiagnosticStatus, queue_size=10, latch=True)
        rospy.Subscriber("upper", rospy.AnyMsg, self._on_upper, queue_size=100, tcp_nodelay=True)
        rospy.Subscriber("lower", rospy.AnyMsg, self._on_lower, queue_size=100, tcp_nodelay=True)
        # reset=True: without it rospy's Timer thread dies when ROS time moves backwards (a restarted
        # simulation), and ~status would fall silent for good.
        rospy.Timer(rospy.Duration.from_sec(STATUS_PERIOD), lambda _e: self.publish_status(), reset=True)
        rospy.loginfo("%s: %s, T = %.3f s, %s + %s -> %s", self.name, kind.value, time_constant,
                      self._topics["upper"], self._topics["lower"], self._topics["output"])

    def _on_upper(self, msg: rospy.AnyMsg) -> None:
        self._relay("upper", self.rule.on_upper, msg)

    def _on_lower(self, msg: rospy.AnyMsg) -> None:
        self._relay("lower", self.rule.on_lower, msg)

    def _relay(self, line: str, decide: Callable[[float], bool], msg: rospy.AnyMsg) -> None:
        """The hot path: one clock read, one rule call, one publish; the type is looked at only until known.

        The rule sees every message, even one of a refused type (a mis-typed suppressing line still takes
        the output away from the lower line: silence is the safer failure), but a refused message is
        never published and is counted as dropped.
        """
        with self._lock:
            accepted = line in self._accepted or self._check_type(line, msg)
            now = rospy.get_time()
            if decide(now):
                if accepted:
                    self._publisher.publish(msg)  # type: ignore[union-attr]
                else:
                    counts = self.rule.upper if line == "upper" else self.rule.lower
                    counts.passed -= 1
                    counts.dropped += 1
            changed = self._status_due or self.rule.upper_in_control(now) != self._upper_in_control
        if changed:
            self.publish_status()

    def _check_type(self, line: str, msg: rospy.AnyMsg) -> bool:
        """Learn a line's type from its first message; a line whose type differs from the output's is refused.

        An inhibitor's upper line is never forwarded, so its type does not matter. The output publisher is
        made from the first forwarded line's connection header (type, md5sum, definition), which is why no
        message code is needed.
        """
        if line == "upper" and not self.kind.needs_same_type:
            self._accepted.add(line)
            return True
        if line in self._refused:
            return False
        header = msg._connection_header
        msg_type = header["type"]
        if self._output_type is None:
            self._output_type = msg_type
            with warnings.catch_warnings():  # rospy warns about queue_size=None: here it is chosen, not forgotten
                warnings.simplefilter("ignore", SyntaxWarning)
                self._publisher = rospy.Publisher("output", _relay_class(header), queue_size=self.queue_size,
                                                  tcp_nodelay=True)
        if msg_type == self._output_type:
            self._accepted.add(line)
            return True
        self._refused.add(line)
        other = "lower" if line == "upper" else "upper"
        self._error = (f"type mismatch: {line} {self._topics[line]} carries {msg_type} but "
                       f"{other} {self._topics[other]} carries {self._output_type}; "
                       f"dropping {self._topics[line]}")
        rospy.logerr("%s: %s", self.name, self._error)
        print(f"{self.name}: error: {self._error}", file=sys.stderr, flush=True)
        self._status_due = True
        return False

    def publish_status(self) -> None:
        now = rospy.get_time()
        self._upper_in_control = self.rule.upper_in_control(now)
        self._status_due = False
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


def read_queue_size() -> int | None:
    """~queue_size of the output publisher; 0 (the default) publishes synchronously from the receiving thread.

    rospy's queued publishing hands every message to a writer thread per connection; on a relay that hand-off
    was the biggest cost we measured (bench/arbiter_latency), so by default the bytes go straight out.
    A positive size decouples a slow subscriber from the input lines at the price of that latency.
    """
    value = rospy.get_param("~queue_size", 0)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ParameterError(f"{rospy.resolve_name('~queue_size')} must be an integer >= 0, got {value!r}")
    return value or None


def main(kind: str, argv: list[str] | None = None) -> int:
    arbiter_kind = ArbiterKind(kind)
    rospy.init_node(arbiter_kind.value, argv=argv if argv is not None else sys.argv)
    try:
        node = ArbiterNode(arbiter_kind, read_time_constant(), read_queue_size())
    except ParameterError as error:
        rospy.logfatal("%s: %s", rospy.get_name(), error)
        print(f"{rospy.get_name()}: error: {error}", file=sys.stderr)
        return 2
    node.publish_status()
    rospy.spin()
    return 0
