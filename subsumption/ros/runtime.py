"""A :class:`~subsumption.runtime.NodeHandle` on rospy: one module, one ROS node.

Time is ``rospy.get_time()`` and timers run on ROS time (the process's one timer thread,
:mod:`subsumption.ros.clock_timers`), so ``/use_sim_time`` and a simulator's ``/clock`` drive modules exactly as
the wall clock would. rospy runs each subscription on a thread of its own; one lock per node serialises them and
the timers so that module code, like Brooks' AFSMs, never runs two callbacks at once.

The handle also keeps what diagnostics report (:mod:`subsumption.ros.diagnostics`): messages received and
published per topic, and callback errors. An exception in a callback is logged with its traceback and
counted, and the node carries on: a timer keeps firing.

Subscriptions are made as ``rospy.AnyMsg`` and the handle deserializes each message itself, after checking the
connection's type and md5sum against the input's class. A publisher of the wrong type on an input's topic
(a String where a Float64 belongs) is thus refused per connection, counted (``refused``) and logged once
per publisher and type, and the node goes on with its other publishers; with rospy's typed subscription the
connection would be refused silently or, with a matching md5sum, decoded as garbage. ``rostopic info`` lists
such subscribers with type ``*``.
"""
from __future__ import annotations

import threading
import time
import traceback
from abc import abstractmethod
from collections import Counter
from typing import Any, Callable

import rospy

from ..runtime import Callback, Message, MessageType, NodeHandle, Publisher, TimerHandle
from .clock_timers import process_timers
from .memory import return_freed_memory

# bytes a `latest` input reads from its socket at once: several 640x480 frames, so that the queue of one drops
# the older ones (with rospy's 64 KiB a frame takes many reads and nothing is ever dropped)
LATEST_BUFFER = 1 << 24


class _Newest:
    """Hands a `latest` input's messages to its callback on a thread of its own, the newest only.

    rospy calls a subscription's callback on the thread that reads its socket: while a slow callback runs
    (a face scan, 0.1-0.5 s on a loaded machine) nothing is read, the publisher's per-connection queue (100
    frames in the simulator, 4 s of camera) fills, and each read then brings frames seconds old -- measured:
    detect's frames up to 10 s old at --rate 1, its alarm 4.5 s after its image. Here the reading thread only
    keeps the newest message and wakes this one, as roscpp's network thread does for a queue of one: the
    socket is drained all the time and the callback always gets the newest frame there is."""

    def __init__(self, deliver: Callable[[Any], None], name: str) -> None:
        self._deliver = deliver
        self._ready = threading.Condition()
        self._message: Any = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def put(self, message: Any) -> None:
        with self._ready:
            self._message = message  # an older one not yet taken is dropped
            self._ready.notify()

    def _run(self) -> None:
        while not rospy.is_shutdown():
            with self._ready:
                if self._message is None:
                    self._ready.wait(0.5)
                message, self._message = self._message, None
            if message is not None:
                self._deliver(message)


class _RosPublisher(Publisher):
    def __init__(self, publisher: rospy.Publisher, counts: Counter) -> None:
        self._publisher = publisher
        self._counts = counts
        self._topic = publisher.resolved_name

    def publish(self, msg: Message) -> None:
        self._publisher.publish(msg)
        self._counts[self._topic] += 1

    def has_subscribers(self) -> bool:
        return self._publisher.get_num_connections() > 0


class _HeldPublisher(_RosPublisher):
    """A motor line this node publishes, held while a critical: true node is dead (subsumption.ros.motor_hold):
    what the module publishes meanwhile is dropped; one zero command marks the hold's start."""

    def __init__(self, publisher: rospy.Publisher, counts: Counter, hold: Any, msg_type: MessageType) -> None:
        super().__init__(publisher, counts)
        self._hold = hold
        self._zero = msg_type
        hold.on_stop(lambda: self._publisher.publish(self._zero()))

    def publish(self, msg: Message) -> None:
        with self._hold.lock:
            if not self._hold.holding:
                super().publish(msg)


class RosTimers(NodeHandle):
    """The timer calls every ROS node handle shares (a node of its own, or a member of a group): checked here,
    started by the handle's ``_timer`` on ROS time."""

    def call_every(self, period: float, callback: Callable[[], None]) -> TimerHandle:
        """Call ``callback`` every ``period`` s of ROS time; a period that is not > 0 is a ValueError."""
        if not period > 0:
            raise ValueError(f"{self.name}: timer period must be > 0, got {period!r}")
        return self._timer(period, callback, oneshot=False)

    def call_later(self, delay: float, callback: Callable[[], None]) -> TimerHandle:
        """Call ``callback`` once, ``delay`` s of ROS time from now."""
        return self._timer(max(delay, 1e-9), callback, oneshot=True)

    @abstractmethod
    def _timer(self, period: float, callback: Callable[[], None], oneshot: bool) -> TimerHandle:
        """Start a timer on ROS time for this handle (the process's one timer thread, subsumption.ros.clock_timers)."""


class RosNodeHandle(RosTimers):
    """NodeHandle for the (single) rospy node of this process. Create it with :func:`init_node`.

    `queue_size` applies to every publisher and subscription: bursts are normal here (a simulator publishes
    a whole sonar sweep at once), so the default is deeper than rospy examples use."""

    def __init__(self, queue_size: int = 100) -> None:
        self.name = rospy.get_name()
        self.queue_size = queue_size
        self.lock = threading.RLock()
        self._keep: list[Any] = []  # subscribers and services live as long as the node
        self.received: Counter = Counter()   # resolved topic -> messages handled
        self.published: Counter = Counter()  # resolved topic -> messages sent
        self.errors = 0                      # callbacks that raised
        self.busy: tuple[str, float] | None = None  # the callback running now and since when (wall clock)
        self.cpu_s = 0.0                     # CPU time the callbacks took (their thread's), for diagnostics
        self.last_error = ""
        self.refused: Counter = Counter()    # resolved topic -> messages of a wrong type (or undecodable)
        self.last_refusal = ""
        self._refusals_logged: set[tuple[str, str, str]] = set()  # (topic, publisher, type) logged once
        self.hold: Any = None  # a MotorHold (subsumption.ros.motor_hold) when this node publishes a motor line

    def now(self) -> float:
        return rospy.get_time()

    def resolve(self, topic: str) -> str:
        return rospy.resolve_name(topic)

    def publisher(self, topic: str, msg_type: MessageType, latch: bool = False, latest: bool = False) -> Publisher:
        # latest: rospy queues up to queue_size messages per connection that its writer thread has not sent yet;
        # for a camera on a loaded machine (the simulator starved of CPU) that was 100 frames, 4 s, behind the
        # newest (measured: detect's frames 5-8 s old at --rate 1 even with its socket drained). One, as a
        # camera driver's, and the writer sends the newest it has.
        queue = 1 if latest else self.queue_size
        publisher = rospy.Publisher(topic, msg_type, queue_size=queue, latch=latch)
        if self.hold is not None and self.hold.holds_line(publisher.resolved_name):
            return _HeldPublisher(publisher, self.published, self.hold, msg_type)
        return _RosPublisher(publisher, self.published)

    def subscribe(self, topic: str, msg_type: MessageType, callback: Callback, latest: bool = False) -> None:
        resolved = self.resolve(topic)
        receive = self._serialised(callback, f"input {resolved}", resolved)
        wanted_type, wanted_md5 = getattr(msg_type, "_type", None), getattr(msg_type, "_md5sum", None)

        def on_raw(raw: Any) -> None:
            if rospy.is_shutdown():
                return
            if not isinstance(raw, rospy.AnyMsg):  # this process subscribed the topic with a class before us
                if isinstance(raw, msg_type):
                    receive(raw)
                else:
                    self._refuse(resolved, getattr(raw, "_connection_header", {}) or {}, wanted_type,
                                 getattr(raw, "_type", type(raw).__name__))
                return
            header = getattr(raw, "_connection_header", None) or {}
            got_type, got_md5 = header.get("type", "?"), header.get("md5sum", "*")
            if got_type != wanted_type or got_md5 not in (wanted_md5, "*"):
                self._refuse(resolved, header, wanted_type, got_type)
                return
            msg = msg_type()
            try:
                msg.deserialize(raw._buff)
            except Exception as error:  # the bytes do not decode as the type they claim to be
                self._refuse(resolved, header, wanted_type, got_type, f" that does not decode ({error})")
                return
            receive(msg)

        if latest:  # a queue of one, fed by large reads and drained all the time (_Newest): a slow callback gets
            # the newest message, not a backlog
            newest = _Newest(on_raw, f"latest {resolved}")
            self._keep.append(newest)
            self._keep.append(rospy.Subscriber(topic, rospy.AnyMsg, newest.put, queue_size=1,
                                               buff_size=LATEST_BUFFER))
        else:
            self._keep.append(rospy.Subscriber(topic, rospy.AnyMsg, on_raw, queue_size=self.queue_size))

    def _refuse(self, topic: str, header: dict, wanted: str | None, got: str, detail: str = "") -> None:
        """A message of the wrong type on `topic`: counted, and logged once per publisher and type."""
        publisher = header.get("callerid", "?")
        with self.lock:
            self.refused[topic] += 1
            self.last_refusal = (f"wrong type on {topic}: {publisher} publishes {got}{detail}, the input takes "
                                 f"{wanted}; its messages are dropped")
            first = (topic, publisher, got) not in self._refusals_logged
            self._refusals_logged.add((topic, publisher, got))
        if first:
            rospy.logerr("%s: %s (logged once; counted in diagnostics)", self.name, self.last_refusal)

    def param(self, name: str, default: Any) -> Any:
        return rospy.get_param("~" + name, default)

    def set_param(self, name: str, value: Any) -> None:
        rospy.set_param("~" + name, value)

    def log(self, level: str, text: str) -> None:
        {"debug": rospy.logdebug, "info": rospy.loginfo, "warn": rospy.logwarn,
         "error": rospy.logerr}[level](text)

    def service(self, name: str, srv_type: type, handler: Callable[[Any], Any]) -> None:
        """A rospy service, its handler run under the node's lock (as every callback is). A handler that raises
        answers the call with an error (rospy's ServiceException), logged, and the node carries on."""
        def answer(request: Any) -> Any:
            with self.lock:
                try:
                    return handler(request)
                except Exception as error:
                    rospy.logerr("%s: service %s: %s: %s", self.name, rospy.resolve_name(name),
                                 type(error).__name__, error)
                    raise rospy.ServiceException(f"{type(error).__name__}: {error}") from None

        self._keep.append(rospy.Service(name, srv_type, answer))

    def _timer(self, period: float, callback: Callable[[], None], oneshot: bool) -> TimerHandle:
        # on the process's one timer thread (its callbacks hold this node's lock, as every callback does)
        return process_timers().add(
            period, self._serialised(callback, f"timer {getattr(callback, '__qualname__', callback)}"), oneshot)

    def _serialised(self, callback: Callable[..., None], what: str, topic: str = "") -> Callable[..., None]:
        """``callback`` run under this node's lock, its errors logged and counted, its CPU time added to cpu_s;
        its arguments (a message, or none for a timer) passed through."""
        def run(*args: Any) -> None:
            if rospy.is_shutdown():
                return
            with self.lock:
                if topic:
                    self.received[topic] += 1
                # wall clock: how long the callback has run, for a status sent while it holds the node (a hang)
                self.busy = (what, time.monotonic())  # wall: see the line above
                started = time.thread_time()
                try:
                    callback(*args)
                except Exception as error:  # module code failed: report it, keep the node (and its timers) alive
                    self.errors += 1
                    self.last_error = f"{what}: {type(error).__name__}: {error}"
                    rospy.logerr("%s: %s\n%s", self.name, self.last_error, traceback.format_exc())
                finally:
                    self.busy = None
                    self.cpu_s += time.thread_time() - started

        return run


def start_node(name: str, **init_node_args) -> None:
    """``rospy.init_node`` for a long-running node process of this package (module, group, arbiter, monitor,
    simulator, terminal): first the process is set to return the memory it frees to the system every few seconds
    (subsumption.ros.memory; before rospy's threads start, which one arena needs)."""
    return_freed_memory()
    rospy.init_node(name, **init_node_args)


def init_node(name: str, anonymous: bool = False, argv: list[str] | None = None,
              queue_size: int = 100) -> RosNodeHandle:
    """Start this process's ROS node (command-line remappings and `_param:=value` apply, see start_node) and return
    its handle."""
    start_node(name, anonymous=anonymous, argv=argv)
    return RosNodeHandle(queue_size)
