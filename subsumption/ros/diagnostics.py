"""Health and state of a running network in one place: ``/diagnostics`` and a latched arbitration topic.

- Every module node publishes, once a second of ROS time, a ``diagnostic_msgs/DiagnosticArray`` on
  ``/diagnostics`` holding one status named after the node: its class, messages received and sent per port
  (with rates), callback errors, the CPU its callbacks take (``cpu_percent``, ``cpu_s``), and an AFSM's state.
  Arbiter nodes publish theirs there too (see :mod:`subsumption.ros.arbiter_node`). ``rqt_runtime_monitor`` reads
  ``/diagnostics`` as it is; ``rqt_robot_monitor`` reads ``/diagnostics_agg``, which ``diagnostic_aggregator`` makes
  from it.
- One monitor node per network (``<network>_monitor``, added by ``subsumption launch``) listens to every
  arbiter's ``~status`` and publishes, latched, on ``~arbitration`` which line drives each arbiter's output,
  named as in the network file (``upper avoid.heading``), whenever a holder changes: one message says who is
  in charge of the whole network, and a late subscriber gets it at once. An arbiter silent for SILENT seconds
  is reported ``gone`` there (and the monitor's diagnostics turn ERROR): its node died, and its line is cut.
  The monitor also watches the life of every node (``~nodes``): see :mod:`subsumption.ros.liveness`.

Levels follow REP 107's use: OK; WARN when a module has raised in a callback before, or dropped messages with
NaN or inf in the last period (the ``dropped`` key counts them, per input in the ``in`` keys); ERROR when it
raised in the last period (the traceback is in its log) or received a message of the wrong type on an input
(``refused``; WARN afterwards, while the count stays on show).
"""
from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from ..module import Module
from .clock_timers import process_timers
from .runtime import RosNodeHandle, start_node

PERIOD = 1.0  # s of ROS time between diagnostics
BUSY_WAIT = 0.5  # s of wall clock the status waits for the node's lock before it says the node is busy
SILENT = 3.0  # s of ROS time without an arbiter's ~status (it sends one a second) after which it counts as gone
DIAGNOSTICS_TOPIC = "/diagnostics"
ARBITRATION_TOPIC = "~arbitration"
HARDWARE_ID = "subsumption"


def diagnostics_publisher() -> rospy.Publisher:
    """A publisher on ``/diagnostics`` (diagnostic_msgs/DiagnosticArray), as ROS tools read it."""
    return rospy.Publisher(DIAGNOSTICS_TOPIC, DiagnosticArray, queue_size=10)


def publish_array(publisher: rospy.Publisher, *statuses: DiagnosticStatus) -> None:
    """Statuses as one DiagnosticArray stamped with ROS time, as diagnostic_updater sends them."""
    array = DiagnosticArray(status=list(statuses))
    array.header.stamp = rospy.Time.now()
    publisher.publish(array)


class CpuShare:
    """A module's or arbiter's CPU for its status: the CPU time its callbacks took in all (``cpu_s``) and, since
    the status before, in percent of a core of wall time (``cpu_percent``), as ``top`` counts it, with the ``pid``
    of the process that counts it (a respawned process counts ``cpu_s`` from zero again under a new pid). Work a
    module hands to threads of its own (OpenCV's) is not in it."""

    def __init__(self) -> None:
        self._last: tuple[float, float] | None = None

    def values(self, cpu_s: float) -> list[KeyValue]:
        """The status's CPU keys, given the callbacks' CPU time so far (`cpu_s`)."""
        now = time.monotonic()  # wall clock: a share of a core, whatever the ROS clock does
        then, before = self._last or (now, cpu_s)
        self._last = now, cpu_s
        percent = 100.0 * (cpu_s - before) / (now - then) if now > then else 0.0
        return [KeyValue("cpu_percent", f"{percent:.1f}"), KeyValue("cpu_s", f"{cpu_s:.3f}"),
                KeyValue("pid", str(os.getpid()))]


class ModuleDiagnostics:
    """Publishes a module node's status on /diagnostics every PERIOD seconds of ROS time."""

    def __init__(self, node: RosNodeHandle, module: Module, class_path: str, timer: bool = True) -> None:
        """timer False: publish nothing; whoever hosts the module (a group) publishes :meth:`status` itself."""
        self.node = node
        self.module = module
        self.class_path = class_path
        self.ports = [("in", name, node.resolve(port.topic())) for name, port in module.interface.inputs.items()]
        self.ports += [("out", name, node.resolve(port.topic())) for name, port in module.interface.outputs.items()]
        self._last_counts: dict[str, int] = {}
        self._last_time: float | None = None
        self._last_errors = 0
        self._last_refused = self._last_dropped = 0
        self._cpu = CpuShare()
        if timer:
            self._publisher = diagnostics_publisher()
            self._timer = process_timers().add(PERIOD, self.publish)

    def status(self) -> DiagnosticStatus:
        """The module node's health as one DiagnosticStatus: class, AFSM state, message rates, drops, errors."""
        node, now = self.node, rospy.get_time()
        elapsed = now - self._last_time if self._last_time is not None and now > self._last_time else 0.0
        values = [KeyValue("class", self.class_path)]
        state = getattr(self.module, "state", None)
        running = "running"
        if state is not None and hasattr(state, "kind"):  # an AFSM
            running = f"state {state.name}"
            values += [KeyValue("state", state.name), KeyValue("transitions", str(self.module.transitions))]
        counts = {}
        for direction, name, topic in self.ports:
            count = (node.received if direction == "in" else node.published)[topic]
            key = f"{direction} {name}"
            counts[key] = count
            rate = (count - self._last_counts.get(key, 0)) / elapsed if elapsed else 0.0
            text = f"{topic}: {count} msgs, {rate:.1f}/s"
            if direction == "in":
                text += "".join(f", {n} {what}" for n, what in ((self.module.dropped[name], "dropped (NaN/inf)"),
                                                                 (node.refused[topic], "refused (wrong type)")) if n)
            values.append(KeyValue(key, text))
        dropped, refused = sum(self.module.dropped.values()), sum(node.refused.values())
        values += [KeyValue("callback errors", str(node.errors)), KeyValue("dropped", str(dropped)),
                   KeyValue("refused", str(refused))] + self._cpu.values(node.cpu_s)
        fresh_errors = node.errors - self._last_errors
        if fresh_errors:
            level, message = DiagnosticStatus.ERROR, node.last_error
        elif refused - self._last_refused:
            level, message = DiagnosticStatus.ERROR, node.last_refusal
        elif dropped - self._last_dropped:
            level, message = DiagnosticStatus.WARN, f"dropped {dropped - self._last_dropped} unusable messages, " \
                                                    f"last: {self.module.last_drop}"
        elif node.errors:
            level, message = DiagnosticStatus.WARN, f"{node.errors} callback errors, last: {node.last_error}"
        elif refused:
            level, message = DiagnosticStatus.WARN, f"{refused} messages refused, last: {node.last_refusal}"
        else:
            level, message = DiagnosticStatus.OK, running
        self._last_refused, self._last_dropped = refused, dropped
        self._last_counts, self._last_time, self._last_errors = counts, now, node.errors
        return DiagnosticStatus(level, node.name, message, HARDWARE_ID, values)

    def publish(self) -> None:
        """Publish the module's status on ``/diagnostics`` (taken under the node's lock, as one callback sees it)."""
        if rospy.is_shutdown():
            return
        # the counters and the module's state, as one callback would see them; but a node whose callbacks follow
        # each other without a gap (track on a loaded machine) starved this timer of the lock for 10 s and more,
        # and the monitor took it for hung: after BUSY_WAIT a status says which callback runs, and for how long
        if self.node.lock.acquire(timeout=BUSY_WAIT):
            try:
                status = self.status()
            finally:
                self.node.lock.release()
        else:
            status = self.busy_status()
        publish_array(self._publisher, status)

    def busy_status(self) -> DiagnosticStatus:
        """WARN: the node is in a callback (``busy_s``: how long that one has run; the monitor counts a node
        busy in one callback for its hang time as hung)."""
        busy = self.node.busy
        # wall clock: how long the callback has held the node, whatever the ROS clock does meanwhile
        what, running = (busy[0], time.monotonic() - busy[1]) if busy else ("a callback", 0.0)  # wall
        return DiagnosticStatus(DiagnosticStatus.WARN, self.node.name, f"busy: {what} running for {running:.1f} s",
                                HARDWARE_ID, [KeyValue("class", self.class_path),
                                              KeyValue("busy_s", f"{running:.3f}")])


# The network monitor -------------------------------------------------------------------------------------
@dataclass
class WatchedArbiter:
    """What the monitor knows of one arbiter: its node name and the network's names of its two lines."""

    name: str
    kind: str
    upper: str   # e.g. "avoid.heading"
    lower: str   # e.g. "turn.heading"
    holder: str = "unknown"  # "upper", "lower", "unknown" (no status yet) or "gone" (status silent: dead?)
    heard: float | None = None  # ROS time of its last status

    def line(self) -> str:
        """Which line drives the output, e.g. ``upper avoid.heading``."""
        if self.holder == "unknown":
            return "unknown (no status yet)"
        if self.holder == "gone":
            return f"gone (no status for {SILENT:g} s: the node died or hangs; nothing passes it)"
        return f"{self.holder} {self.upper if self.holder == 'upper' else self.lower}"


class NetworkMonitor:
    """Listens to each arbiter's ``~status``; publishes the holders on ``~arbitration`` (latched) when one
    changes, and a summary of the network on /diagnostics every PERIOD."""

    def __init__(self, network: str, arbiters: list[WatchedArbiter], nodes: list | None = None) -> None:
        from .liveness import LivenessWatch

        self.network = network
        self.arbiters = {a.name: a for a in arbiters}
        self._arbitration = rospy.Publisher(ARBITRATION_TOPIC, DiagnosticStatus, queue_size=10, latch=True)
        self._diagnostics = diagnostics_publisher()
        # every node's life (subsumption.ros.liveness); a death or return republishes /diagnostics at once
        self._reported: set[tuple[str, int]] = set()
        self.liveness = LivenessWatch(nodes or [], on_change=self._liveness_changed)
        self.liveness.start()  # after the assignment: its first report may come at once (a node already dead)
        for arbiter in arbiters:
            rospy.Subscriber(f"{arbiter.name}/status", DiagnosticStatus,
                             lambda msg, a=arbiter: self._on_status(a, msg), queue_size=10)
        self.publish_arbitration()
        process_timers().add(PERIOD, self._publish_diagnostics)

    def _on_status(self, arbiter: WatchedArbiter, msg: DiagnosticStatus) -> None:
        arbiter.heard = rospy.get_time()
        holder = next((kv.value for kv in msg.values if kv.key == "in_control"), "unknown")
        if holder != arbiter.holder:
            arbiter.holder = holder
            self.publish_arbitration()

    def _check_silence(self) -> None:
        """An arbiter whose ~status has been silent for SILENT seconds is reported gone (its node died: the
        line it sat on is cut), and the arbitration topic says so at once."""
        now = rospy.get_time()
        changed = False
        for arbiter in self.arbiters.values():
            if arbiter.holder not in ("unknown", "gone") and arbiter.heard is not None and now - arbiter.heard > SILENT:
                arbiter.holder = "gone"
                changed = True
                rospy.logerr("%s: arbiter %s: no status for %g s: gone", rospy.get_name(), arbiter.name, SILENT)
        if changed:
            self.publish_arbitration()

    def status(self) -> DiagnosticStatus:
        """Who drives each arbiter of the network, as one DiagnosticStatus (ERROR when an arbiter is gone)."""
        values = [KeyValue(a.name, a.line()) for a in self.arbiters.values()]
        message = "; ".join(f"{a.name}: {a.line()}" for a in self.arbiters.values()) or "no arbiters"
        gone = any(a.holder == "gone" for a in self.arbiters.values())
        return DiagnosticStatus(DiagnosticStatus.ERROR if gone else DiagnosticStatus.OK, rospy.get_name(), message,
                                HARDWARE_ID, [KeyValue("network", self.network)] + values)

    def _liveness_changed(self) -> None:
        """A death or a return: /diagnostics says so now, not at the next period."""
        dead = {(status.name, status.level) for status in self.liveness.statuses()}
        if dead != self._reported:
            self._reported = dead
            self._publish_diagnostics(check=False)

    def publish_arbitration(self) -> None:
        """Publish the arbiters' holders on the latched ``arbitration`` topic."""
        self._arbitration.publish(self.status())

    def _publish_diagnostics(self, check: bool = True) -> None:
        if rospy.is_shutdown():
            return
        if check:
            self._check_silence()
            self.liveness.check_silence()
        own = self.status()
        lives = self.liveness.statuses()
        if self.liveness.any_dead():  # the network's summary turns ERROR too, naming the dead
            own.level = DiagnosticStatus.ERROR
            own.message = f"{self.liveness.summary()}; {own.message}"
        own.values.append(KeyValue("liveness", self.liveness.summary()))
        publish_array(self._diagnostics, own, *lives)


def monitor_main(argv: list[str] | None = None) -> int:
    """``rosrun subsumption monitor __name:=wander_monitor _network:=wander _arbiters:="[{name: ..., ...}]"``"""
    start_node("monitor", argv=argv if argv is not None else sys.argv)
    network = rospy.get_param("~network", "")
    given = rospy.get_param("~arbiters", [])
    keys = ("name", "kind", "upper", "lower")
    if not isinstance(given, list) or not all(isinstance(a, dict) and all(k in a for k in keys) for a in given):
        error = (f"{rospy.resolve_name('~arbiters')} must be a list of {{name, kind, upper, lower}} mappings, "
                 f"got {given!r}")
        rospy.logfatal("%s: %s", rospy.get_name(), error)
        print(f"{rospy.get_name()}: error: {error}", file=sys.stderr)
        return 2
    from .liveness import NodesParamError, parse_nodes

    try:
        nodes = parse_nodes(rospy.get_param("~nodes", []), rospy.resolve_name("~nodes"))
    except NodesParamError as error:
        rospy.logfatal("%s: %s", rospy.get_name(), error)
        print(f"{rospy.get_name()}: error: {error}", file=sys.stderr)
        return 2
    NetworkMonitor(str(network), [WatchedArbiter(*(str(a[k]) for k in keys)) for a in given], nodes)
    rospy.loginfo("%s: watching %d arbiters and the life of %d nodes of network %s", rospy.get_name(), len(given),
                  len(nodes), network)
    rospy.spin()
    return 0
