"""Liveness of every node of a network: the monitor's second job, beside which line drives each arbiter.

A security robot that stops patrolling without a word is the failure this answers. Two signs of life are watched
for each node the network file runs (``~nodes``, written by ``subsumption launch``):

- **its process**: every PROBE_PERIOD s of wall clock the monitor asks the node its pid (``getPid``, the call
  ``rosnode ping`` makes) at the address the master gave, asking the master again when that fails. A refused
  connection is a process that is gone (SIGKILL, a crash: it never unregistered); a node the master no longer knows ended and unregistered; a new
  pid under the same name is a respawn (roslaunch started it again). Wall clock because processes live in it:
  a death must be seen even while the simulated clock stands still.
- **its voice**: a module node and an arbiter publish their status on /diagnostics once a second of ROS time;
  one silent for LATE s (of ROS time and of wall clock both) is reported late (a WARN on /rosout and
  /diagnostics), and dead (hung: a callback that never returns) after HUNG s. Two thresholds because a busy node on a loaded machine (detect scanning frames
  on a shared core) was measured 3-4 s late now and then while working: "camera lost" raised for it would be a
  false alarm, and an alarm that cries wolf is switched off.

Each death is reported at once, within a probe period: an ERROR on /rosout naming the node, the modules it runs
and how it died; an ERROR status under the node's own name on /diagnostics (until it is back); and an event on
``~liveness`` (``diagnostic_msgs/DiagnosticStatus``: ERROR for a death, OK for a return; keys ``event``
``death``/``respawn``/``back``, ``how``, ``modules``, ``critical``, ``at``, ``pid``), which a run's recorder
keeps in metrics.json and a robot's own modules may read: a node the network file marks ``critical: WHAT``
makes the event say what the robot lost (``navigation``), and the robot decides what to do about it.

A node marked ``critical: true`` (``stops_motors`` in ``~nodes``) is one the robot cannot drive without: from its
death until it is back and speaking again, the latched ``~motors`` status (``diagnostic_msgs/DiagnosticStatus``:
ERROR and ``held=true`` naming the dead nodes, else OK and ``held=false``) says the motors are held, and the node
that publishes each motor line holds it (subsumption.ros.motor_hold); the death's reports say "critical: motors
stopped" and its event carries ``stops_motors=true``.

The record is per ROS node with the names of the modules it hosts, so a node that runs several modules reports
all of them in one event.
"""
from __future__ import annotations

import socket
import threading
import time
import xmlrpc.client
from dataclasses import dataclass, field
from typing import Any, Callable

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

PROBE_PERIOD = 1.0    # s of wall clock between asks of every node's process (one getPid each: cheap enough)
PROBE_TIMEOUT = 1.0   # s of wall clock a node's XML-RPC server may take to answer getPid
LATE = 3.0            # s without a /diagnostics status (sent once a second), of ROS time and of wall clock: late (WARN)
HUNG = 10.0           # s without one (both clocks), or of wall clock without an answer to getPid: reported dead
LIVENESS_TOPIC = "~liveness"
MOTORS_TOPIC = "~motors"  # latched: whether a critical: true node is dead, so the motor lines are held
NODE_KEYS = ("name", "modules", "critical", "respawn", "reports")  # and stops_motors (optional, false)


class NodesParamError(ValueError):
    """~nodes is not a list of {name, modules, critical, respawn, reports}; the message says what is wrong."""


@dataclass
class WatchedNode:
    """What the monitor knows of one node's life."""

    name: str                  # resolved ROS name, e.g. /move_base
    modules: list[str] = field(default_factory=list)
    critical: str = ""         # what the robot loses when it dies ("" : not critical)
    respawn: bool = False      # roslaunch starts it again when it dies
    reports: bool = True       # publishes on /diagnostics once a second
    stops_motors: bool = False  # critical: true: while it is dead (or back but not speaking) the motors are held
    state: str = "starting"    # starting (not seen yet), alive, dead, returning (process back, not speaking yet)
    pid: int | None = None
    how: str = ""              # how it died, while dead
    late: bool = False         # its status on /diagnostics is LATE s overdue
    unanswered_since: float | None = None  # wall clock of the first of a run of probes that timed out
    uri: str | None = None     # its XML-RPC server, as the master last said
    dead_pid: int | None = None  # the pid it died with
    heard: float | None = None  # ROS time of its last /diagnostics status
    heard_wall: float = 0.0     # wall clock (monotonic) of the same
    deaths: int = 0

    def describe(self) -> str:
        """The node's name, with the modules it runs when it hosts a group."""
        hosts = f" (runs {', '.join(self.modules)})" if self.modules and self.modules != [self.name.lstrip("/")] \
            else ""
        return f"{self.name}{hosts}"

    def loss(self, separator: str) -> str:
        """What its death costs, for a report: "critical: motors stopped, NAME lost" for critical: true,
        "critical: navigation lost" for a named critical (each after `separator`), "" for neither."""
        if self.stops_motors:
            return f"{separator}critical: motors stopped" + (f", {self.critical} lost" if self.critical else "")
        return f"{separator}critical: {self.critical} lost" if self.critical else ""

    @property
    def holds_motors(self) -> bool:
        """Whether the motors are held for this node now: critical: true and dead, or back but not speaking."""
        return self.stops_motors and self.state in ("dead", "returning")


def parse_nodes(given: Any, where: str) -> list[WatchedNode]:
    """The ``~nodes`` parameter as WatchedNodes, names resolved in the monitor's namespace; NodesParamError names
    the parameter and the entry when it is not a list of {name, modules, critical, respawn, reports}."""
    if not isinstance(given, list):
        raise NodesParamError(f"{where} must be a list of {{{', '.join(NODE_KEYS)}}} mappings, got {given!r}")
    nodes = []
    for index, entry in enumerate(given):
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) or not entry["name"] \
                or not isinstance(entry.get("modules", []), list):
            raise NodesParamError(f"{where}[{index}] must be a mapping with a name and a list of modules, got "
                                  f"{entry!r}")
        nodes.append(WatchedNode(rospy.resolve_name(entry["name"]), [str(m) for m in entry.get("modules", [])],
                                 str(entry.get("critical") or ""), bool(entry.get("respawn", False)),
                                 bool(entry.get("reports", True)), bool(entry.get("stops_motors", False))))
    return nodes


def _busy_s(status: DiagnosticStatus) -> float:
    """How long the node has been in one callback, as its status says (0 when it says nothing of it)."""
    for kv in status.values:
        if kv.key == "busy_s":
            try:
                return float(kv.value)
            except ValueError:
                return 0.0
    return 0.0


class _TimeoutTransport(xmlrpc.client.Transport):
    """An XML-RPC transport that gives up after PROBE_TIMEOUT (a hung host must not hang the probe)."""

    def make_connection(self, host: Any) -> Any:
        connection = super().make_connection(host)
        connection.timeout = PROBE_TIMEOUT
        return connection


def probe(master: Any, name: str, caller: str, uri: str | None = None) -> tuple[str, int | None, str, str | None]:
    """('alive', pid, '', uri) or ('gone' / 'slow', None, how, uri) or ('unknown', None, why, None) for the node
    `name`; `uri`, where it answered last time, spares asking the master (a respawned node has a new one: a
    failure there asks the master again before it counts)."""
    if uri is not None:
        answer = _ask_pid(uri, caller)
        if answer[0] in ("alive", "slow"):  # a slow one is not asked twice: the other nodes' probes wait
            return (*answer, uri)
    try:
        uri = master.lookupNode(name)
    except Exception as error:  # rosgraph.MasterError: not registered; socket errors: master away
        if "unknown node" in str(error).lower() or "not registered" in str(error).lower():
            return "gone", None, "exited (unregistered from the master)", None
        return "unknown", None, f"master: {error}", None
    return (*_ask_pid(uri, caller), uri)


def _ask_pid(uri: str, caller: str) -> tuple[str, int | None, str]:
    try:
        code, _, pid = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport()).getPid(caller)
    except (ConnectionRefusedError, ConnectionResetError, ConnectionAbortedError, BrokenPipeError):
        return "gone", None, "killed (its process is gone: it never unregistered)"
    except (socket.timeout, TimeoutError):
        return "slow", None, f"not answering at {uri} (hung or gone)"
    except OSError as error:
        return "gone", None, f"unreachable at {uri}: {error}"
    except Exception as error:  # an XML-RPC fault: a process at that port, but not that node
        return "gone", None, f"no node at {uri}: {error}"
    return ("alive", int(pid), "") if code == 1 else ("gone", None, "answered getPid with an error")


class LivenessWatch:
    """Watches `nodes`; reports deaths and returns on /rosout, on ``~liveness`` and through `on_change` (the
    monitor then republishes its /diagnostics). Probing begins with :meth:`start`, once the owner can take
    `on_change` calls."""

    def __init__(self, nodes: list[WatchedNode], on_change: Callable[[], None] = lambda: None) -> None:
        import rosgraph

        self.nodes = {node.name: node for node in nodes}
        self._on_change = on_change
        self._lock = threading.Lock()
        self._caller = rospy.get_name()
        self._master = rosgraph.Master(self._caller)
        self._events = rospy.Publisher(LIVENESS_TOPIC, DiagnosticStatus, queue_size=100)
        self._motors = rospy.Publisher(MOTORS_TOPIC, DiagnosticStatus, queue_size=10, latch=True)
        self._holding: list[str] | None = None  # the nodes the motors are held for, as last published
        with self._lock:
            self._publish_motors()
        self._thread = threading.Thread(target=self._probe_loop, name="liveness-probe", daemon=True)

    def start(self) -> "LivenessWatch":
        """Begin listening to /diagnostics and probing the processes (on_change may be called from now on)."""
        rospy.Subscriber("/diagnostics", DiagnosticArray, self._on_diagnostics, queue_size=50)
        self._thread.start()
        return self

    # the process ---------------------------------------------------------------------------------------------
    def _probe_loop(self) -> None:
        while not rospy.is_shutdown():
            started = time.monotonic()  # wall clock: processes are probed in real time (see the module's doc)
            for node in list(self.nodes.values()):
                if rospy.is_shutdown():
                    return
                state, pid, how, node.uri = probe(self._master, node.name, self._caller, node.uri)
                self.check_process(node, state, pid, how)
            time.sleep(max(0.0, PROBE_PERIOD - (time.monotonic() - started)))  # wall, as above

    def check_process(self, node: WatchedNode, state: str, pid: int | None, how: str) -> None:
        """One probe's answer for `node`: a death, a return or a respawn is reported."""
        if state == "unknown" or rospy.is_shutdown():
            return
        with self._lock:
            if state == "slow":  # a busy process may answer late: dead only when it stays silent HUNG s
                now = time.monotonic()  # wall clock, as the probes
                node.unanswered_since = node.unanswered_since or now
                if node.state == "alive" and now - node.unanswered_since > HUNG:
                    self._died(node, f"{how} for {HUNG:g} s")
                return
            node.unanswered_since = None
            if state == "alive":
                if node.state == "alive" and node.pid is not None and pid != node.pid:
                    # died and came back between two probes: both are reported
                    self._died(node, "killed and started again between two probes (new pid)")
                if node.state == "dead" and node.reports:
                    # its process is back; it counts as back once it speaks: its module is built (a respawned
                    # amcl answered 9 s before it had read its map and could localize)
                    node.state, node.pid, node.heard = "returning", pid, None
                elif node.state in ("starting", "dead"):
                    returned = node.state == "dead"
                    event = "respawn" if node.pid is not None and pid != node.pid else "back"
                    node.state, node.pid, node.how = "alive", pid, ""
                    node.heard = None  # its voice is timed afresh
                    if returned:
                        self._returned(node, event)
                node.pid = pid
            elif node.state == "alive":
                self._died(node, how)
            elif node.state == "returning":  # died again before it spoke: still dead, no new report
                node.state = "dead"
        self._on_change()

    # the voice -----------------------------------------------------------------------------------------------
    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = rospy.get_time()
        header = getattr(msg, "_connection_header", None) or {}
        if header.get("callerid") == self._caller:
            return  # the monitor's own array (its reports of dead nodes)
        with self._lock:
            for status in msg.status:
                node = self.nodes.get(status.name)
                if node is None or _busy_s(status) > HUNG:
                    continue  # not ours; or alive but stuck in one callback for longer than a hang: not a voice
                node.heard, node.heard_wall = now, time.monotonic()  # wall: see check_silence
                if node.state == "returning":  # respawned and built: back
                    node.state, node.how = "alive", ""
                    self._returned(node, "respawn" if node.pid != node.dead_pid else "back")
                if node.late:
                    node.late = False
                    rospy.loginfo("%s: node %s speaks again", self._caller, node.name)
                if node.state == "dead" and node.how.startswith("hung"):
                    node.state, node.how = "alive", ""  # a hung node speaks again: back, same pid
                    self._returned(node, "back")

    def check_silence(self) -> None:
        """Called every period of ROS time: a reporting node silent for LATE s is late, for HUNG s hung.

        Silence counts on both clocks, the smaller wins. ROS time alone, a simulation run faster than real time
        would call a busy node hung after a third of the wall time (a level's group process working through
        amcl and move_base at 3x on a loaded machine); wall time alone, every node would fall silent whenever
        the simulated clock stands still (their status timers run on it)."""
        now, wall = rospy.get_time(), time.monotonic()  # wall: see above
        with self._lock:
            for node in self.nodes.values():
                if not (node.reports and node.state == "alive" and node.heard is not None):
                    continue
                silent = min(now - node.heard, wall - node.heard_wall)
                if silent > HUNG:
                    node.late = False
                    self._died(node, f"hung: no status on /diagnostics for {HUNG:g} s")
                elif silent > LATE and not node.late:
                    node.late = True
                    rospy.logwarn("%s: node %s late: no status on /diagnostics for %g s (busy or hung)",
                                  self._caller, node.describe(), LATE)

    # the reports ---------------------------------------------------------------------------------------------
    def _died(self, node: WatchedNode, how: str) -> None:
        node.state, node.how, node.dead_pid = "dead", how, node.pid
        node.deaths += 1
        respawn = "; roslaunch respawns it" if node.respawn else "; not respawned"
        rospy.logerr("%s: node %s died: %s%s%s", self._caller, node.describe(), how, node.loss("; "), respawn)
        loss = node.loss(": ") if node.stops_motors else (f": {node.critical} lost" if node.critical else "")
        self._publish_event(node, "death", DiagnosticStatus.ERROR, f"{node.name} died: {how}{loss}")
        self._publish_motors()

    def _returned(self, node: WatchedNode, event: str) -> None:
        what = "respawned" if event == "respawn" else "back"
        rospy.logwarn("%s: node %s %s (pid %s)", self._caller, node.describe(), what, node.pid)
        self._publish_event(node, event, DiagnosticStatus.OK, f"{node.name} {what}")
        self._publish_motors()

    def _publish_event(self, node: WatchedNode, event: str, level: int, message: str) -> None:
        values = [KeyValue("event", event), KeyValue("how", node.how), KeyValue("modules", ",".join(node.modules)),
                  KeyValue("critical", node.critical), KeyValue("at", f"{rospy.get_time():.3f}"),
                  KeyValue("pid", str(node.pid or "")), KeyValue("stops_motors", str(node.stops_motors).lower())]
        self._events.publish(DiagnosticStatus(level, node.name, message, "subsumption", values))

    def _publish_motors(self) -> None:
        """The latched ``~motors`` status, when the set of nodes the motors are held for has changed (and once at
        start, so that a motor line's publisher, started or respawned at any time, learns the state at once).
        Called with the lock held."""
        holding = sorted(node.name for node in self.nodes.values() if node.holds_motors)
        previous = self._holding
        if holding == previous or rospy.is_shutdown():
            return
        self._holding = holding
        if holding:
            status = DiagnosticStatus(DiagnosticStatus.ERROR, self._caller,
                                      f"motors stopped: {', '.join(holding)} dead (critical: true)", "subsumption",
                                      [KeyValue("held", "true"), KeyValue("nodes", ",".join(holding))])
            rospy.logerr("%s: motors stopped: %s dead (critical: true)", self._caller, ", ".join(holding))
        else:
            status = DiagnosticStatus(DiagnosticStatus.OK, self._caller, "motors free: no critical: true node dead",
                                      "subsumption", [KeyValue("held", "false"), KeyValue("nodes", "")])
            if previous:
                rospy.logwarn("%s: motors free: every critical: true node is back", self._caller)
        self._motors.publish(status)

    def statuses(self) -> list[DiagnosticStatus]:
        """An ERROR status under each dead node's own name, a WARN under each late one's, for /diagnostics (its
        own is silent)."""
        with self._lock:
            return [DiagnosticStatus(DiagnosticStatus.ERROR if node.state in ("dead", "returning") else
                                     DiagnosticStatus.WARN, node.name,
                                     f"dead: {node.how}{node.loss('; ') if node.stops_motors else ''}" if node.state in ("dead", "returning") else
                                     f"late: no status on /diagnostics for {LATE:g} s (busy or hung)",
                                     "subsumption", [KeyValue("modules", ",".join(node.modules)),
                                                     KeyValue("critical", node.critical),
                                                     KeyValue("respawn", str(node.respawn).lower())])
                    for node in self.nodes.values() if node.state in ("dead", "returning") or node.late]

    def summary(self) -> str:
        """One line: the dead nodes and how they died, or how many of the watched nodes are alive."""
        with self._lock:
            dead = [f"{n.name} dead ({n.how}){'; motors stopped' if n.stops_motors else ''}"
                    for n in self.nodes.values() if n.state in ("dead", "returning")]
            alive = sum(n.state == "alive" for n in self.nodes.values())
        return "; ".join(dead) if dead else f"{alive}/{len(self.nodes)} nodes alive"

    def any_dead(self) -> bool:
        """True when a watched node has died."""
        with self._lock:
            return any(n.state in ("dead", "returning") for n in self.nodes.values())
