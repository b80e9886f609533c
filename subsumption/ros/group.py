"""A module group: several modules and arbiters in one ROS node process, the wires between them in-process.

ROS 1's nodelets and ROS 2's composition, for subsumption networks::

    rosrun subsumption group __name:=patrol_level0 _members:="[{name: avoid, class: ..., remap: {...}}, ...]"

(``subsumption launch`` writes it; see docs/ros.md, "Module groups"). Each member keeps its own name: its
``~param`` is ``/<ns>/<member>/param`` as for a node of its own, its remaps are its own, and it reports on
``/diagnostics`` under its own name. What changes is the transport:

- a message published by a member is handed to every reader in the group as **the same object**, without
  serialization (read-only by convention: a reader that changes it changes it for every other reader), and to
  ROS only when a subscriber outside the group is connected (rospy serializes nothing without connections);
- a topic the group reads is subscribed on ROS once for the whole group, whatever the number of its readers:
  each message is decoded once, when its first reader takes it (one decode per frame per process), and a
  message dropped by every reader's queue is never decoded at all;
- the group never connects to itself over TCP (:func:`_install_no_self_connection`): a message from a member
  reaches the group's other members in-process only, while messages from outside publishers on the same topic
  still arrive over ROS, as with roscpp's intra-process links.

The members' callbacks (messages and timers) run on the group's ``~workers`` threads (2 by default;
:mod:`subsumption.ros.workers`, nodelet's worker pool): callbacks of one module never run concurrently and run in
arrival order, a slow module (a face scan) holds up the others only when every worker is busy, a message one
member publishes to another costs no thread wake-up, and a publication only queues the message for its readers,
so that no cycle of wires can deadlock. Inputs marked ``latest`` keep the newest message only, as the one-node
runtime does. Each member's status on ``/diagnostics`` says how much CPU its callbacks take (``cpu_percent``,
``cpu_s``). Arbiters run as
:class:`~subsumption.arbiter.Arbiter` on the same handles, so their rule and time constants are those of the
arbiter node; the group publishes their status on ``~status`` and ``/diagnostics`` as the arbiter node does.

A member's motor line (``~motor_hold``, a network with a ``critical: true`` module) is held in :meth:`GroupHost.deliver`
while such a module is dead, whichever member publishes it (subsumption.ros.motor_hold).

The group is the fault boundary: it dies and respawns as one. Its own ``/diagnostics`` status (named after
the group) lists its members (``members``), and so does its ``~members`` parameter, so that liveness reports
can name the modules a dead group took with it.
"""
from __future__ import annotations

import sys
import threading
import traceback
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable

import rospy
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rosgraph.names import ns_join, resolve_name

from ..runtime import Callback, Message, MessageType, Publisher, TimerHandle
from .clock_timers import ClockTimer, process_timers
from .module_node import PACKAGE_DIR
from .runtime import LATEST_BUFFER, RosTimers, start_node
from .workers import WORKERS, Inbox, Slot, Workers, checked_count

QUEUE = 100  # messages kept per input of a member when it falls behind (the one-node runtime's queue_size)


class GroupError(ValueError):
    """A bad ~members entry or a member that cannot be built; the message names it."""


def _install_no_self_connection() -> None:
    """Never connect this process's subscribers to its own publishers: in a group, what a member publishes
    reaches the other members in-process already (rospy itself would loop it through a TCP socket and deliver
    it twice). Other publishers of the topic are connected as usual."""
    from rospy.impl import masterslave

    handler_class = masterslave.ROSHandler
    if getattr(handler_class, "_no_self_connection", False):
        return
    original = handler_class._connect_topic

    def _connect_topic(self: Any, topic: str, pub_uri: str) -> Any:
        if self.uri and pub_uri.rstrip("/") == self.uri.rstrip("/"):
            return 1, f"{topic}: delivered in-process in this group", 0
        return original(self, topic, pub_uri)

    handler_class._connect_topic = _connect_topic
    handler_class._no_self_connection = True


class _Encoded:
    """A message as it came off the wire, decoded once for all the group's readers (by the first that takes it)."""

    __slots__ = ("_raw", "_type", "_lock", "_message", "error")

    def __init__(self, raw: bytes, msg_type: MessageType) -> None:
        self._raw, self._type = raw, msg_type
        self._lock = threading.Lock()
        self._message: Any = None
        self.error: Exception | None = None

    def message(self) -> Any:
        with self._lock:
            if self._message is None and self.error is None:
                message = self._type()
                try:
                    message.deserialize(self._raw)
                    self._message = message
                except Exception as error:  # the bytes do not decode as the type they claim to be
                    self.error = error
                self._raw = b""
            return self._message


@dataclass
class _Topic:
    """A topic as the group uses it: its type, the members reading it in-process, its ROS ends."""

    name: str
    msg_type: MessageType
    first_user: str
    readers: list[tuple["GroupMember", Slot]] = field(default_factory=list)
    ros_publisher: rospy.Publisher | None = None
    ros_subscriber: rospy.Subscriber | None = None
    latched: Any = None
    decoded: int = 0  # messages from outside decoded (at most once each)


class _Timer(TimerHandle):
    def __init__(self, timer: ClockTimer, slot: Slot) -> None:
        self._timer, self._slot = timer, slot

    def cancel(self) -> None:
        self._slot.cancelled = True
        self._timer.cancel()


class _GroupPublisher(Publisher):
    def __init__(self, host: "GroupHost", member: "GroupMember", topic: _Topic, latch: bool) -> None:
        self._host, self._member, self._topic, self._latch = host, member, topic, latch

    def publish(self, msg: Message) -> None:
        self._member.published[self._topic.name] += 1
        self._host.deliver(self._topic, msg, self._latch)

    def has_subscribers(self) -> bool:
        publisher = self._topic.ros_publisher
        return bool(self._topic.readers) or (publisher is not None and publisher.get_num_connections() > 0)


class GroupMember(RosTimers):
    """The NodeHandle of one module or arbiter in a group: its own name, remaps, parameters and counts, the
    group's transport. Its attributes are those :class:`~subsumption.ros.runtime.RosNodeHandle` offers to
    diagnostics (received, published, errors, refused)."""

    def __init__(self, host: "GroupHost", name: str, remap: dict[str, str]) -> None:
        self.host = host
        self.name = name
        self._remap = {resolve_name(k, name): resolve_name(v, name) for k, v in remap.items()}
        self.lock = threading.RLock()
        self.inbox = Inbox(name, self.lock, host.workers)
        self.received: Counter = Counter()
        self.published: Counter = Counter()
        self.errors = 0
        self.last_error = ""
        self.refused: Counter = Counter()
        self.last_refusal = ""

    def now(self) -> float:
        return rospy.get_time()

    @property
    def cpu_s(self) -> float:
        """CPU time this member's callbacks have taken (on the group's workers)."""
        return self.inbox.cpu_s

    def resolve(self, topic: str) -> str:
        return resolve_name(topic, self.name, self._remap)

    def publisher(self, topic: str, msg_type: MessageType, latch: bool = False, latest: bool = False) -> Publisher:
        entry = self.host.topic(self.resolve(topic), msg_type, f"publisher {self.name}")
        self.host.advertise(entry, latch, latest)
        return _GroupPublisher(self.host, self, entry, latch)

    def subscribe(self, topic: str, msg_type: MessageType, callback: Callback, latest: bool = False) -> None:
        entry = self.host.topic(self.resolve(topic), msg_type, f"subscriber {self.name}")
        slot = Slot(1 if latest else QUEUE, self._guarded(callback, f"input {entry.name}", entry.name))
        self.host.add_reader(entry, self, slot, latest)

    def param(self, name: str, default: Any) -> Any:
        return rospy.get_param(ns_join(self.name, name), default)

    def set_param(self, name: str, value: Any) -> None:
        rospy.set_param(ns_join(self.name, name), value)

    def log(self, level: str, text: str) -> None:
        {"debug": rospy.logdebug, "info": rospy.loginfo, "warn": rospy.logwarn,
         "error": rospy.logerr}[level]("%s: %s", self.name, text)

    def _timer(self, period: float, callback: Callable[[], None], oneshot: bool) -> TimerHandle:
        # a tick missed while the member was busy is not queued twice (a slot of one), as rospy's Timer skips;
        # the process's one timer thread only hands the tick to the group's workers
        slot = Slot(1, self._guarded(lambda _tick: callback(), f"timer {getattr(callback, '__qualname__', callback)}"))
        return _Timer(process_timers().add(period, lambda: self.inbox.put(slot, True), oneshot), slot)

    def _guarded(self, callback: Callable[[Any], None], what: str, topic: str = "") -> Callable[[Any], None]:
        """Run on a worker holding the member's lock: decode what came from outside (once per message for the
        whole group), count it, and keep the member alive when its code raises."""
        def run(item: Any) -> None:
            if rospy.is_shutdown():
                return
            if isinstance(item, _Encoded):
                message = item.message()
                if message is None:
                    self.host.refuse_undecodable(self, topic, item.error)
                    return
                item = message
            if topic:
                self.received[topic] += 1
            try:
                callback(item)
            except Exception as error:  # module code failed: report it, keep the member (and its timers) alive
                self.errors += 1
                self.last_error = f"{what}: {type(error).__name__}: {error}"
                rospy.logerr("%s: %s\n%s", self.name, self.last_error, traceback.format_exc())

        return run


class GroupHost:
    """This process's topics, members and the workers that run their callbacks. Build members with :meth:`member`:
    each runs as soon as it is built (its callbacks wait for its lock while its module is being set up)."""

    def __init__(self, workers: int = WORKERS) -> None:
        _install_no_self_connection()
        self.name = rospy.get_name()
        self.workers = Workers(workers, self.name)
        self.namespace = rospy.get_namespace()
        self.topics: dict[str, _Topic] = {}
        self.members: dict[str, GroupMember] = {}
        self._lock = threading.Lock()
        self._refusals_logged: set[tuple[str, str, str]] = set()
        self.hold: Any = None  # a MotorHold (subsumption.ros.motor_hold) when a member publishes a motor line

    def member(self, name: str, remap: dict[str, str]) -> GroupMember:
        """Add the module or arbiter `name` (with its remappings) to this process; a GroupError if it is listed
        twice."""
        full = ns_join(self.namespace, name)
        if full in self.members:
            raise GroupError(f"{rospy.resolve_name('~members')}: {name} is listed twice")
        member = GroupMember(self, full, remap)
        self.members[full] = member
        return member

    # Topics ---------------------------------------------------------------------------------------------
    def topic(self, name: str, msg_type: MessageType, who: str) -> _Topic:
        """The in-process topic `name` of `msg_type` (made on first use); a topic used with two types is refused, naming
        `who`."""
        with self._lock:
            entry = self.topics.get(name)
            if entry is None:
                entry = self.topics[name] = _Topic(name, msg_type, who)
            elif entry.msg_type is not msg_type and getattr(entry.msg_type, "_md5sum", 1) != getattr(
                    msg_type, "_md5sum", 2):
                raise GroupError(f"topic {name}: {who} uses {getattr(msg_type, '_type', msg_type)} but "
                                 f"{entry.first_user} uses {getattr(entry.msg_type, '_type', entry.msg_type)}")
            return entry

    def advertise(self, entry: _Topic, latch: bool, latest: bool) -> None:
        """The topic's ROS publisher, made once: it costs nothing while nobody outside the group subscribes."""
        with self._lock:
            if entry.ros_publisher is None:
                entry.ros_publisher = rospy.Publisher(entry.name, entry.msg_type, latch=latch,
                                                      queue_size=1 if latest else QUEUE)
                if self.hold is not None and self.hold.holds_line(entry.name):
                    self.hold.on_stop(lambda e=entry: self._send(e, e.msg_type(), False))

    def add_reader(self, entry: _Topic, member: GroupMember, slot: Slot, latest: bool) -> None:
        """An in-process reader of `entry`; the topic is subscribed on ROS too (once), for publishers outside."""
        with self._lock:
            entry.readers.append((member, slot))
            latched = entry.latched
            if entry.ros_subscriber is None:
                entry.ros_subscriber = rospy.Subscriber(
                    entry.name, rospy.AnyMsg, lambda raw, e=entry: self._from_outside(e, raw), queue_size=None,
                    buff_size=LATEST_BUFFER if latest else 65536, tcp_nodelay=True)
        if latched is not None:
            member.inbox.put(slot, latched)

    def deliver(self, entry: _Topic, msg: Message, latch: bool) -> None:
        """A member published `msg`: the same object to every reader in the group, and the bytes to ROS when a
        subscriber outside is connected. A motor line is dropped while the hold lasts (its lock orders the
        hold's zero after every command sent before it)."""
        if self.hold is not None and self.hold.holds_line(entry.name):
            with self.hold.lock:
                if not self.hold.holding:
                    self._send(entry, msg, latch)
            return
        self._send(entry, msg, latch)

    def _send(self, entry: _Topic, msg: Message, latch: bool) -> None:
        if latch:
            entry.latched = msg
        for member, slot in entry.readers:
            member.inbox.put(slot, msg)
        publisher = entry.ros_publisher
        if publisher is not None:
            publisher.publish(msg)  # rospy returns at once without connections (a latched message is kept)

    def _from_outside(self, entry: _Topic, raw: Any) -> None:
        """A message from a publisher outside the group (on rospy's reading thread): checked against the topic's
        type per connection, then queued, still encoded, for every reader."""
        if rospy.is_shutdown():
            return
        header = getattr(raw, "_connection_header", None) or {}
        got_type, got_md5 = header.get("type", "?"), header.get("md5sum", "*")
        wanted = getattr(entry.msg_type, "_type", None)
        if got_type != wanted or got_md5 not in (getattr(entry.msg_type, "_md5sum", None), "*"):
            self._refuse(entry, header.get("callerid", "?"), got_type)
            return
        encoded = _Encoded(raw._buff, entry.msg_type)
        for member, slot in entry.readers:
            member.inbox.put(slot, encoded)

    def _refuse(self, entry: _Topic, publisher: str, got: str, detail: str = "") -> None:
        wanted = getattr(entry.msg_type, "_type", entry.msg_type)
        text = (f"wrong type on {entry.name}: {publisher} publishes {got}{detail}, the input takes {wanted}; its "
                f"messages are dropped")
        for member, _slot in entry.readers:
            member.refused[entry.name] += 1
            member.last_refusal = text
        with self._lock:
            first = (entry.name, publisher, got) not in self._refusals_logged
            self._refusals_logged.add((entry.name, publisher, got))
        if first:
            rospy.logerr("%s: %s (logged once; counted in diagnostics)", self.name, text)

    def refuse_undecodable(self, member: GroupMember, topic: str, error: Exception | None) -> None:
        """Count and note a message on `topic` that `member` cannot decode (a publisher of the wrong type): dropped."""
        member.refused[topic] += 1
        member.last_refusal = f"wrong type on {topic}: a message that does not decode ({error}); dropped"


# The group node -------------------------------------------------------------------------------------------
MODULE_KEYS = {"name", "class", "remap"}
ARBITER_KEYS = {"name", "arbiter", "upper", "lower", "output", "time_constant", "type", "upper_type"}


@dataclass
class _Built:
    """A member once built: its handle, and the module or arbiter it runs."""

    handle: GroupMember
    module: Any = None        # a Module
    arbiter: Any = None       # an Arbiter
    class_path: str = ""
    diagnostics: Any = None   # ModuleDiagnostics (publishing nothing by itself)
    cpu: Any = None           # an arbiter's CpuShare (a module's is in its ModuleDiagnostics)
    keep: Any = None          # the dynamic_reconfigure server


def _text(entry: dict, key: str, where: str) -> str:
    value = entry.get(key)
    if not isinstance(value, str) or not value:
        raise GroupError(f"{where}: {key} must be a non-empty string, got {value!r}")
    return value


def _message_class(type_name: str, where: str) -> type:
    import roslib.message

    try:
        found = roslib.message.get_message_class(type_name)
    except (ValueError, ImportError):
        found = None
    if found is None:
        raise GroupError(f"{where}: unknown message type {type_name!r}")
    return found


def build_member(host: GroupHost, entry: Any, index: int) -> _Built:
    """One ~members entry built in `host`: a module ({name, class, remap}) or an arbiter ({name, arbiter: kind,
    upper, lower, output, time_constant, type, upper_type})."""
    from ..arbiter import Arbiter
    from ..loading import load_module_class
    from .diagnostics import CpuShare, ModuleDiagnostics
    from .module_node import serve_params

    where = f"{rospy.resolve_name('~members')}[{index}]"
    if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
        raise GroupError(f"{where}: expected a mapping with a name, got {entry!r}")
    where = f"{where} ({entry['name']})"
    if "arbiter" in entry:
        unknown = set(entry) - ARBITER_KEYS
        if unknown:
            raise GroupError(f"{where}: unknown keys {sorted(unknown)} (expected {sorted(ARBITER_KEYS)})")
        lines = {line: _text(entry, line, where) for line in ("upper", "lower", "output")}
        seconds = entry.get("time_constant")
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0 < seconds < float("inf"):
            raise GroupError(f"{where}: time_constant must be a finite number of seconds > 0, got {seconds!r}")
        line_class = _message_class(_text(entry, "type", where), where)
        upper_class = _message_class(entry["upper_type"], where) if entry.get("upper_type") else line_class
        handle = host.member(entry["name"], lines)
        with handle.lock:
            arbiter = Arbiter(handle, _text(entry, "arbiter", where), float(seconds), line_class, upper_class)
        return _Built(handle, arbiter=arbiter, keep=_serve_time_constant(handle, arbiter), cpu=CpuShare())
    unknown = set(entry) - MODULE_KEYS
    if unknown:
        raise GroupError(f"{where}: unknown keys {sorted(unknown)} (expected {sorted(MODULE_KEYS)})")
    remap = entry.get("remap") or {}
    if not isinstance(remap, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in remap.items()):
        raise GroupError(f"{where}: remap must map names to topics, got {remap!r}")
    class_path = _text(entry, "class", where)
    module_class = load_module_class(class_path)
    handle = host.member(entry["name"], remap)
    with handle.lock:  # no callback may run before the module is fully built
        module = module_class(handle)
    return _Built(handle, module=module, class_path=class_path,
                  diagnostics=ModuleDiagnostics(handle, module, class_path, timer=False),  # type: ignore[arg-type]
                  keep=serve_params(handle, module, namespace=handle.name))


def _serve_time_constant(handle: GroupMember, arbiter: Any) -> Any:
    """The arbiter's ~time_constant on dynamic_reconfigure, as the arbiter node serves it."""
    from .reconfigure import Knob, serve

    def apply(changes: dict[str, Any]) -> None:
        value = changes["time_constant"]
        if not 0 < value < float("inf"):
            raise ValueError(f"{handle.name}/time_constant must be a finite number of seconds > 0, got {value!r}")
        arbiter.rule.time_constant = float(value)

    knob = Knob("time_constant", "double", arbiter.rule.time_constant,
                "T: seconds of ROS time a message of the upper line holds the output", 0.0, float("inf"))
    return serve([knob], {"time_constant": arbiter.rule.time_constant}, apply, handle.lock, handle.name)


def _workers_param() -> int:
    """The group's ``~workers`` (threads running its members' callbacks); a GroupError naming it if it is not an
    integer >= 1."""
    try:
        return checked_count(rospy.get_param("~workers", WORKERS))
    except ValueError as error:
        raise GroupError(f"{rospy.resolve_name('~workers')}: {error}") from None


def group_status(host: GroupHost, built: list[_Built]) -> DiagnosticStatus:
    """The group's own status: which members it hosts (what dies with it), and its process id."""
    import os

    names = [b.handle.name for b in built]
    return DiagnosticStatus(DiagnosticStatus.OK, host.name, f"hosts {len(names)} members", "subsumption",
                            [KeyValue("members", ", ".join(names)), KeyValue("pid", str(os.getpid())),
                             KeyValue("topics", str(len(host.topics))),
                             KeyValue("workers", str(len(host.workers.threads))),
                             KeyValue("workers_woken", str(host.workers.woken))])


def main(argv: list[str] | None = None) -> int:
    """Run ``rosrun subsumption group _members:=...``: a group of modules and arbiters in one node process, wired in-
    process, until shutdown."""
    from ..arbiter import status_message
    from ..loading import ClassPathError
    from ..module import ParamError
    from .diagnostics import PERIOD, diagnostics_publisher, publish_array
    from .motor_hold import MotorHoldError, read_motor_hold

    start_node("group", argv=argv if argv is not None else sys.argv)  # the members' freed frame buffers go back
    entries = rospy.get_param("~members", None)
    built: list[_Built] = []
    try:
        host = GroupHost(_workers_param())
        host.hold = read_motor_hold()  # the motor lines its members publish (a network with critical: true)
        if not isinstance(entries, list) or not entries:
            raise GroupError(f"{rospy.resolve_name('~members')} is required: a list of modules and arbiters")
        for index, entry in enumerate(entries):
            built.append(build_member(host, entry, index))
    except (GroupError, ClassPathError, ParamError, TypeError, MotorHoldError) as error:
        rospy.logfatal("%s: %s", rospy.get_name(), error)
        print(f"{rospy.get_name()}: error: {error}", file=sys.stderr, flush=True)
        return 2
    rospy.set_param("~hosts", [b.handle.name for b in built])  # what liveness reports name when the group dies
    diagnostics = diagnostics_publisher()  # advertised once every member is built: readiness (launch.wait_for_nodes)

    def publish_diagnostics() -> None:
        if rospy.is_shutdown():
            return
        statuses = [group_status(host, built)]
        for member in built:
            with member.handle.lock:  # the counters and the module's state, as one callback would see them
                if member.diagnostics is not None:
                    statuses.append(member.diagnostics.status())
                else:  # as the arbiter node reports it: a refused line is an error, and stays on show
                    handle = member.handle
                    refused = sum(handle.refused.values())
                    status = status_message(handle.name, member.arbiter.rule, rospy.get_time(),
                                            handle.last_refusal if refused else "")
                    status.values.append(KeyValue("refused", str(refused)))
                    status.values.extend(member.cpu.values(handle.cpu_s))
                    statuses.append(status)
        publish_array(diagnostics, *statuses)

    timer = process_timers().add(PERIOD, publish_diagnostics)
    rospy.loginfo("%s: hosting %s (subsumption from %s)", host.name, ", ".join(b.handle.name for b in built),
                  PACKAGE_DIR)
    rospy.spin()
    del timer
    return 0
