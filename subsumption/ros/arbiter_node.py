"""The generic inhibitor, suppressor and defaulter ROS nodes, for any message type.

They subscribe ``upper`` and ``lower`` as ``rospy.AnyMsg`` and relay the serialized bytes untouched, so no
message code is generated or even imported. Usage::

    rosrun subsumption suppressor upper:=/avoid/heading lower:=/runaway/heading \\
        output:=/turn/heading _time_constant:=2.0 _type:=std_msgs/Float64

``~time_constant`` (seconds of ROS time, > 0) is required. ``~type`` (optional; ``subsumption launch`` always
sets it) is the message type of the lower line and the output: the output is then advertised at start-up,
and a line carrying anything else is refused. Without it the type is the lower line's, learnt from the
master or from the lower line's first message, never from the upper line (a suppressor whose upper line
spoke first must not make a wrong type its output's). A refused message is neither forwarded nor given
control: a mis-typed upper line is a broken level, and the lower levels go on as if it were absent.
Every refusal is logged with both topics and types and shown on ``~status``.

``~status`` (diagnostic_msgs/DiagnosticStatus) says which line holds the output, until when, and how many
messages each line passed and lost (``*_queue_dropped``: lost in the input queue under overload, which
rospy alone would discard without a word), on change and once a second. ``~queue_size`` (default 0:
synchronous) is the output publisher's queue; see docs/arbiters.md. ``~motor_hold`` (written by ``subsumption
launch`` for the last arbiter on a motor line of a network with a ``critical: true`` module) holds the output while
such a module is dead: one zero command, then nothing (subsumption.ros.motor_hold).
"""
from __future__ import annotations

import sys
import threading
import time
import warnings
from typing import Any

import rospy
import rospy.topics
from diagnostic_msgs.msg import DiagnosticStatus

from ..arbiter import EXPIRY_CHECK_PERIOD, STATUS_PERIOD, status_message
from ..arbitration import ArbiterKind, ArbiterRule
from .clock_timers import process_timers
from .motor_hold import MotorHold, MotorHoldError, read_motor_hold
from .runtime import start_node

INPUT_QUEUE = 100  # messages of one line kept from one read of its socket (rospy's queue_size, counted here)
TYPE_LOOKUP_PERIOD = 0.5  # s of wall clock between asks to the master for the lower line's type


class ParameterError(ValueError):
    """A bad or missing ~parameter; the message names it."""


def _relay_class(msg_type: str, md5sum: str, definition: str) -> type:
    """A publishable class for a message type known only by name, md5sum and definition (bytes pass through)."""
    return type("Relayed_" + msg_type.replace("/", "_"), (rospy.AnyMsg,),
                {"_type": msg_type, "_md5sum": md5sum, "_full_text": definition})


def _install_batch_delivery() -> None:
    """Let a subscription take each read of its socket as one batch.

    rospy reads a connection in chunks (up to ``buff_size`` bytes) and, with a ``queue_size``, keeps only the
    last ``queue_size`` messages of a chunk, silently. The arbiter subscribes without rospy's limit and applies
    the same limit itself, counting what it discards; taking the batch in one call also spares a Python call
    and a try-block per message on the hot path. A subscription opts in by setting ``_batch_handler`` on its
    ``_SubscriberImpl``; every other subscription of the process keeps rospy's own delivery.
    """
    impl_class = rospy.topics._SubscriberImpl
    if getattr(impl_class, "_batch_delivery", False):
        return
    original = impl_class.receive_callback

    def receive_callback(self: Any, msgs: list, connection: Any) -> None:
        handler = getattr(self, "_batch_handler", None)
        if handler is None:
            original(self, msgs, connection)
        else:
            handler(msgs)

    impl_class.receive_callback = receive_callback
    impl_class._batch_delivery = True


class ArbiterNode:
    """One arbiter in this process's ROS node; batches of both lines are serialised by one lock."""

    def __init__(self, kind: ArbiterKind, time_constant: float, queue_size: int | None = None,
                 msg_type: str | None = None, hold: MotorHold | None = None) -> None:
        """queue_size None publishes `output` synchronously (see :func:`read_queue_size`); msg_type is ~type;
        `hold` holds the output while a critical: true node is dead, when the output is one of its lines."""
        self.kind = kind
        self.queue_size = queue_size
        self.rule = ArbiterRule(kind, time_constant)
        self.name = rospy.get_name()
        self._lock = threading.Lock()
        self._publisher: rospy.Publisher | None = None
        self._type = msg_type            # the output's type once known
        self._md5sum: str | None = None  # ... and its md5sum, once a class or a matching connection gave it
        # connection headers checked, by identity (rospy gives every message of a connection the same dict)
        self._accepted: dict[str, dict[int, dict]] = {"upper": {}, "lower": {}}
        self._refused: dict[str, dict[int, dict]] = {"upper": {}, "lower": {}}
        self._next_lookup = 0.0
        self._held_back = False  # the upper line spoke before the output's type was known (warned once)
        self._error = ""
        self._upper_in_control = False
        self._status_due = False  # an error to report at once
        self._queue_drops_told = 0  # messages lost in the input queue as last reported on ~status ...
        self._dropping = ""         # ... what the last loss was, said (WARN) ...
        self._dropping_until = 0.0  # ... until this ROS time (two status periods after the last loss)
        self._topics = {line: rospy.resolve_name(line) for line in ("upper", "lower", "output")}
        self._hold = hold if hold is not None and hold.holds_line(self._topics["output"]) else None
        if self._hold is not None:
            self._hold.on_stop(self._send_zero)
        self._status = rospy.Publisher("~status", DiagnosticStatus, queue_size=10, latch=True)
        self.cpu_s = 0.0  # CPU time the batches took (their thread's), reported on /diagnostics as a module's is
        if msg_type is not None:
            self._advertise_known_type(msg_type)
        _install_batch_delivery()
        for line in ("upper", "lower"):
            # queue_size None: rospy keeps every message it reads; _on_batch applies and counts the limit.
            subscriber = rospy.Subscriber(line, rospy.AnyMsg, lambda msg, ln=line: self._on_batch(ln, [msg]),
                                          queue_size=None, tcp_nodelay=True)
            subscriber.impl._batch_handler = lambda msgs, ln=line: self._on_batch(ln, msgs)
        # on the process's one timer thread, which survives ROS time moving backwards (a restarted simulation)
        timers = process_timers()
        timers.add(STATUS_PERIOD, self.publish_status)
        # A window that runs out with no message is reported within EXPIRY_CHECK_PERIOD by this one timer
        # (a timer per window would cost the hot path), so listeners hear who holds the output from here.
        timers.add(EXPIRY_CHECK_PERIOD, self._status_on_expiry)
        rospy.loginfo("%s: %s, T = %.3f s, %s + %s -> %s%s", self.name, kind.value, time_constant,
                      self._topics["upper"], self._topics["lower"], self._topics["output"],
                      f" ({msg_type})" if msg_type else "")

    def _advertise_known_type(self, msg_type: str) -> None:
        """With ~type given and its message code importable, advertise the output now (its subscribers then
        connect before the first message, so none is lost); otherwise wait for a matching connection."""
        import roslib.message

        try:
            message_class = roslib.message.get_message_class(msg_type)
        except (ValueError, ImportError):
            message_class = None
        if message_class is not None:
            self._make_publisher(msg_type, message_class._md5sum, message_class._full_text)

    def _make_publisher(self, msg_type: str, md5sum: str, definition: str) -> None:
        self._type, self._md5sum = msg_type, md5sum
        with warnings.catch_warnings():  # rospy warns about queue_size=None: here it is chosen, not forgotten
            warnings.simplefilter("ignore", SyntaxWarning)
            self._publisher = rospy.Publisher("output", _relay_class(msg_type, md5sum, definition),
                                              queue_size=self.queue_size, tcp_nodelay=True)

    def _on_batch(self, line: str, msgs: list) -> None:
        """The hot path: one clock read per batch, one rule call and one publish per message.

        A batch is what one read of the line's socket brought: all of it arrived at the same moment. When the
        node fell behind, more than INPUT_QUEUE messages of the lower line may come at once; like rospy's
        queue, only the newest are kept, but here the others are counted (``lower_queue_dropped`` on ~status).
        The upper line is never cut: it is the higher level's say, already read into memory, and bench.arbiter_soak
        showed a loaded machine losing 6 % of an inhibitor's upper line to the cut. A message of a refused
        type is not forwarded and does not take control; it counts as dropped.
        """
        started = time.thread_time()
        lost = len(msgs) - INPUT_QUEUE if line == "lower" else 0
        if lost > 0:
            msgs = msgs[lost:]
        decide = self.rule.on_upper if line == "upper" else self.rule.on_lower
        accepted = self._accepted[line]
        if self._hold is not None:  # a motor line: nothing passes while a critical node is dead (hold.lock)
            with self._hold.lock:
                self._on_batch_locked(line, msgs, lost, decide, accepted, self._hold.holding, started)
            return
        self._on_batch_locked(line, msgs, lost, decide, accepted, False, started)

    def _on_batch_locked(self, line: str, msgs: list, lost: int, decide: Any, accepted: dict, held: bool,
                         started: float) -> None:
        """:meth:`_on_batch` past the queue cut; `held`: the rule runs (the status says who would drive) but
        nothing is published; `started`: the thread's CPU clock when the batch came, for ``cpu_s``."""
        with self._lock:
            if lost > 0:
                self.rule.lost_in_queue(line, lost)
                self._status_due = self._status_due or not self._dropping  # the first loss is told at once
            now = rospy.get_time()
            for msg in msgs:
                header = msg._connection_header
                if id(header) not in accepted and not self._check_type(line, header):
                    counts = self.rule.upper if line == "upper" else self.rule.lower
                    counts.dropped += 1
                    continue
                if decide(now) and not held:  # never true for an inhibitor's upper line
                    self._publisher.publish(msg)  # type: ignore[union-attr]
            changed = self._status_due or self.rule.upper_in_control(now) != self._upper_in_control
            self.cpu_s += time.thread_time() - started  # under the lock: each line has threads of its own
        if changed:
            self.publish_status()

    def _send_zero(self) -> None:
        """One zero command on the output (the hold begins; called under the hold's lock): the message type's
        defaults, a Twist of zeros."""
        import io

        import roslib.message

        message_class = roslib.message.get_message_class(self._type) if self._type else None
        if message_class is None or self._publisher is None:
            rospy.logerr("%s: motor hold: no zero command for type %s: the output is only silenced", self.name,
                         self._type)
            return
        buffer = io.BytesIO()
        message_class().serialize(buffer)
        zero = self._publisher.data_class()
        zero._buff = buffer.getvalue()
        self._publisher.publish(zero)

    def _check_type(self, line: str, header: dict) -> bool:
        """Whether messages of this connection may go on: the first message of each connection is looked at.

        An inhibitor's upper line is never forwarded, so its type does not matter. The type every forwarded
        line must carry is ~type, else the lower line's (asked of the master, or read from the lower line's
        first connection): an upper line never sets it. The output publisher is made from the first matching
        connection's header when no message class gave it at start-up.
        """
        if line == "upper" and not self.kind.needs_same_type:
            self._accepted[line][id(header)] = header
            return True
        if id(header) in self._refused[line]:
            return False
        msg_type, md5sum = header["type"], header.get("md5sum", "*")
        if self._type is None:
            if line == "lower":
                self._type = msg_type
            else:
                self._type = self._lower_type_from_master()
                if self._type is None:  # nobody publishes the lower line yet: hold the upper line back
                    if not self._held_back:
                        self._held_back = True
                        rospy.logwarn("%s: holding back upper %s: the type of lower %s is not known yet (no "
                                      "publisher); set ~type to forward it from the start", self.name,
                                      self._topics["upper"], self._topics["lower"])
                    return False
        if msg_type != self._type or (self._md5sum is not None and md5sum != self._md5sum):
            self._refuse(line, header, msg_type)
            return False
        if self._publisher is None:
            self._make_publisher(msg_type, md5sum, header.get("message_definition", ""))
        self._accepted[line][id(header)] = header
        return True

    def _lower_type_from_master(self) -> str | None:
        """The type the master knows for the lower topic (at most one ask per TYPE_LOOKUP_PERIOD)."""
        if time.monotonic() < self._next_lookup:  # wall clock: this paces calls to the master, not ROS logic
            return None
        self._next_lookup = time.monotonic() + TYPE_LOOKUP_PERIOD  # wall, as above
        try:
            topics = dict(rospy.get_published_topics())
        except Exception:  # the master is away: ask again later
            return None
        return topics.get(self._topics["lower"])

    def _refuse(self, line: str, header: dict, msg_type: str) -> None:
        self._refused[line][id(header)] = header
        publisher = header.get("callerid", "?")
        source = rospy.resolve_name("~type") if line == "lower" else f"lower {self._topics['lower']}"
        self._error = (f"type mismatch: {line} {self._topics[line]} (from {publisher}) carries {msg_type} but "
                       f"{source} is {self._type}; dropping {self._topics[line]} from {publisher}")
        rospy.logerr("%s: %s", self.name, self._error)
        print(f"{self.name}: error: {self._error}", file=sys.stderr, flush=True)
        self._status_due = True

    def _status_on_expiry(self) -> None:
        if self.rule.upper_in_control(rospy.get_time()) != self._upper_in_control:
            self.publish_status()

    def publish_status(self) -> None:
        """Publish who holds the arbiter now, the message counts and any type error on ``~status``."""
        now = rospy.get_time()
        self._upper_in_control = self.rule.upper_in_control(now)
        self._status_due = False
        self._status.publish(self._status_message(now))

    def _status_message(self, now: float) -> DiagnosticStatus:
        """The status, WARN while the input queue has lately dropped messages (rospy would lose them silently)."""
        lost = self.rule.upper.queue_dropped + self.rule.lower.queue_dropped
        if lost > self._queue_drops_told:
            self._dropping = (f"dropping: {lost - self._queue_drops_told} messages lost in the input queue "
                              f"({lost} in all; the node falls behind its lines)")
            self._queue_drops_told, self._dropping_until = lost, now + 2 * STATUS_PERIOD
        elif self._dropping and not now < self._dropping_until:
            self._dropping = ""
        return status_message(self.name, self.rule, now, self._error, self._dropping)

    # Health on /diagnostics and a changeable time constant (subsumption.ros.diagnostics, .reconfigure) ------
    def serve_health_and_tuning(self) -> Any:
        """The status on /diagnostics once a second (beside ~status), and ~time_constant on dynamic_reconfigure.
        Returns what must live as long as the node."""
        from .diagnostics import CpuShare, diagnostics_publisher, publish_array
        from .reconfigure import Knob, serve

        diagnostics, cpu = diagnostics_publisher(), CpuShare()

        def publish_health() -> None:
            status = status_message(self.name, self.rule, rospy.get_time(), self._error, self._dropping)
            status.values.extend(cpu.values(self.cpu_s))
            publish_array(diagnostics, status)

        process_timers().add(STATUS_PERIOD, publish_health)
        knob = Knob("time_constant", "double", self.rule.time_constant,
                    "T: seconds of ROS time a message of the upper line holds the output", 0.0, float("inf"))
        return serve([knob], {"time_constant": self.rule.time_constant}, self._set_time_constant, self._lock)

    def _set_time_constant(self, changes: dict[str, Any]) -> None:
        value = changes["time_constant"]
        if not 0 < value < float("inf"):
            raise ParameterError(f"{rospy.resolve_name('~time_constant')} must be a finite number of seconds > 0, "
                                 f"got {value!r}")
        self.rule.time_constant = float(value)
        rospy.loginfo("%s: time constant now %.3f s", self.name, value)


def read_time_constant() -> float:
    """~time_constant, checked: it is required, a finite number, and > 0."""
    if not rospy.has_param("~time_constant"):
        raise ParameterError(f"{rospy.resolve_name('~time_constant')} is required (seconds of ROS time, > 0)")
    value = rospy.get_param("~time_constant")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < float("inf"):
        raise ParameterError(f"{rospy.resolve_name('~time_constant')} must be a finite number of seconds > 0, "
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


def read_type() -> str | None:
    """~type, the lower line's and the output's message type as ``package/Message`` (optional)."""
    value = rospy.get_param("~type", None)
    if value is None or value == "":
        return None
    if not isinstance(value, str) or value.count("/") != 1 or not all(value.split("/")):
        raise ParameterError(f"{rospy.resolve_name('~type')} must be a message type such as "
                             f"geometry_msgs/Twist, got {value!r}")
    return value


def main(kind: str, argv: list[str] | None = None) -> int:
    """Run an inhibitor, suppressor or defaulter node (`kind`) until shutdown; exit status 2 on a bad parameter."""
    arbiter_kind = ArbiterKind(kind)
    start_node(arbiter_kind.value, argv=argv if argv is not None else sys.argv)
    try:
        node = ArbiterNode(arbiter_kind, read_time_constant(), read_queue_size(), read_type(), read_motor_hold())
    except (ParameterError, MotorHoldError) as error:
        rospy.logfatal("%s: %s", rospy.get_name(), error)
        print(f"{rospy.get_name()}: error: {error}", file=sys.stderr)
        return 2
    node.publish_status()
    keep = node.serve_health_and_tuning()
    rospy.spin()
    del keep
    return 0
