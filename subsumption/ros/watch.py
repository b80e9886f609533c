"""``subsumption watch``: a running network at a glance, in the terminal.

What a ROS user would otherwise piece together from ``rostopic echo /diagnostics``, one ``~status`` per
arbiter and ``rostopic hz`` per wire, on one screen that refreshes every second:

- each module: its health and its callbacks' CPU (``cpu_percent``) from ``/diagnostics`` and, for an AFSM, its
  state (from ``~afsm``, as it changes);
- each arbiter: its CPU (``cpu_percent`` on ``/diagnostics``), which line holds its output, named as in the
  network file, and messages passed/dropped;
- each wire of the network: its topic and how many messages a second of ROS time go through it.

The network file says what to expect, so a node that is missing shows as missing rather than being left out.
"""
from __future__ import annotations

import sys
import time
from collections import deque
from dataclasses import dataclass, field

import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph.names import ns_join

from ..network.wiring import Wiring
from .launch import monitor_name

RATE_WINDOW = 2.0  # s of ROS time over which a wire's rate is measured
LEVEL_WORDS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}


@dataclass
class WireCounter:
    """Arrival times (ROS time) of the messages on one topic, for a rate over the last RATE_WINDOW s."""

    topic: str
    times: deque = field(default_factory=lambda: deque(maxlen=10000))
    total: int = 0

    def arrived(self, _msg: rospy.AnyMsg) -> None:
        """Count a message on the wire at the current ROS time."""
        self.times.append(rospy.get_time())
        self.total += 1

    def rate(self, now: float) -> float:
        """Messages per second of ROS time over the last window before `now`."""
        while self.times and (self.times[0] < now - RATE_WINDOW or self.times[0] > now):
            self.times.popleft()  # old, or from before time jumped back
        return len(self.times) / RATE_WINDOW


class NetworkView:
    """Collects what the view shows; :meth:`render` turns it into text."""

    def __init__(self, wiring: Wiring, namespace: str = "/") -> None:
        self.wiring = wiring
        self.namespace = rosgraph.names.make_global_ns(namespace or "/")
        self.statuses: dict[str, DiagnosticStatus] = {}      # node name -> latest /diagnostics status
        self.machines: dict[str, DiagnosticStatus] = {}      # module name -> latest ~afsm
        self.arbiters: dict[str, DiagnosticStatus] = {}      # arbiter name -> latest ~status
        self.counters: dict[str, WireCounter] = {}
        self._keep = [rospy.Subscriber("/diagnostics", DiagnosticArray, self._on_diagnostics, queue_size=50)]
        for module in wiring.modules:
            self._keep.append(rospy.Subscriber(self.topic(f"{module.name}/afsm"), DiagnosticStatus,
                                               lambda msg, name=module.name: self.machines.__setitem__(name, msg)))
        for arbiter in wiring.arbiters:
            self._keep.append(rospy.Subscriber(self.topic(f"{arbiter.name}/status"), DiagnosticStatus,
                                               lambda msg, name=arbiter.name: self.arbiters.__setitem__(name, msg)))
        for wire in wiring.wires:
            topic = self.topic(wire.topic)
            if topic not in self.counters:
                counter = self.counters[topic] = WireCounter(topic)
                self._keep.append(rospy.Subscriber(topic, rospy.AnyMsg, counter.arrived, queue_size=1000))

    def topic(self, name: str) -> str:
        """`name` in the watched network's namespace."""
        return ns_join(self.namespace, name)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self.statuses[status.name] = status

    def render(self) -> str:
        """The view as text: every module's health and AFSM state, every arbiter's holder, every wire's rate."""
        now = rospy.get_time()
        network = self.wiring.network
        lines = [f"network {network.name} ({network.file}), levels 0..{self.wiring.level}, namespace "
                 f"{self.namespace}, ROS time {now:.1f} s"]
        monitor = self.statuses.get(self.topic(monitor_name(network)))
        lines.append("" if monitor else f"(no status from {self.topic(monitor_name(network))} yet)")
        width = max([len("MODULE")] + [len(m.name) for m in self.wiring.modules])
        lines.append(f"{'MODULE':<{width}} {'HEALTH':<6} {'CPU %':>5} STATE")
        for module in self.wiring.modules:
            status = self.statuses.get(self.topic(module.name))
            machine = self.machines.get(module.name)
            health = LEVEL_WORDS.get(status.level, str(status.level)) if status else "-"
            if machine is not None:
                state = f"AFSM {machine.message}"
            elif status is not None:
                state = status.message
            else:
                state = "no status yet (not running?)"
            if status is not None and status.level >= DiagnosticStatus.WARN:
                state += f"  [{status.message}]"
            lines.append(f"{module.name:<{width}} {health:<6} {_cpu(status):>5} {state}")
        width = max([len("ARBITER")] + [len(a.name) for a in self.wiring.arbiters])
        if self.wiring.arbiters:
            lines.append("")
            lines.append(f"{'ARBITER':<{width}} {'CPU %':>5} {'HOLDER':<28} PASSED/DROPPED (upper; lower)")
        for arbiter in self.wiring.arbiters:
            status = self.arbiters.get(arbiter.name)
            cpu = _cpu(self.statuses.get(self.topic(arbiter.name)))  # /diagnostics, as a module's
            if status is None:
                lines.append(f"{arbiter.name:<{width}} {cpu:>5} no status yet (not running?)")
                continue
            values = {kv.key: kv.value for kv in status.values}
            holder = values.get("in_control", "?")
            line = f"{holder} {arbiter.spec.upper if holder == 'upper' else arbiter.spec.lower}"
            counts = (f"{values.get('upper_passed', '?')}/{values.get('upper_dropped', '?')}; "
                      f"{values.get('lower_passed', '?')}/{values.get('lower_dropped', '?')}")
            error = f"  [{status.message}]" if status.level >= DiagnosticStatus.WARN else ""
            lines.append(f"{arbiter.name:<{width}} {cpu:>5} {line:<28} {counts}{error}")
        lines.append("")
        wires = [(f"{_end(w.source)} -> {_end(w.target)}", self.topic(w.topic)) for w in self.wiring.wires]
        width = max([len("WIRE")] + [len(name) for name, _ in wires])
        topic_width = max([len("TOPIC")] + [len(topic) for _, topic in wires])
        lines.append(f"{'WIRE':<{width}} {'TOPIC':<{topic_width}} {'MSG/S':>7}")
        for name, topic in wires:
            lines.append(f"{name:<{width}} {topic:<{topic_width}} {self.counters[topic].rate(now):>7.1f}")
        return "\n".join(lines)


def _cpu(status: DiagnosticStatus | None) -> str:
    """A module's or arbiter's CPU (its callbacks', percent of a core over the last second, from its status on
    /diagnostics); "-" before its first status."""
    return next((kv.value for kv in status.values if kv.key == "cpu_percent"), "-") if status is not None else "-"


def _end(end) -> str:
    return f"{end.name}.{end.port}" if end.port else end.name


def watch(wiring: Wiring | None, namespace: str = "/", once: float | None = None, period: float = 1.0) -> int:
    """Show the view every `period` wall seconds until Ctrl-C; with `once`, print it once after `once` seconds."""
    master = rosgraph.Master("/subsumption_watch")
    if not _master_answers(master):
        print(f"subsumption watch: no ROS master at {rosgraph.get_master_uri()} (start the network first, or set "
              f"ROS_MASTER_URI)", file=sys.stderr)
        return 1
    rospy.init_node("subsumption_watch", anonymous=True, disable_rosout=True)
    assert wiring is not None, "a network to watch (None only checks for the master)"
    view = NetworkView(wiring, namespace)
    if once is not None:
        time.sleep(once)  # wall clock on purpose: how long a person (or a script) watches
        print(view.render(), flush=True)
        return 0
    live = sys.stdout.isatty()
    while not rospy.is_shutdown():
        text = view.render()
        print(("\x1b[H\x1b[2J" + text) if live else text + "\n", flush=True)
        time.sleep(period)
    return 0


class NoMonitor(LookupError):
    """No network monitor (or more than one) runs where `subsumption watch` looks; the text says what to do."""


def running_network(namespace: str = "/") -> tuple[str, int, str]:
    """The network file, levels and namespace of the network whose monitor runs on the master under `namespace`,
    read from the monitor's ``~network_file`` and ``~level`` (written by subsumption.ros.launch). Raises
    :class:`NoMonitor` when no monitor runs there, or several do (which one is then the caller's to say)."""
    master = rosgraph.Master("/subsumption_watch")
    prefix = "/" + namespace.strip("/") + "/" if namespace.strip("/") else "/"
    found = sorted(name.removesuffix("/network_file") for name in master.getParamNames()
                   if name.startswith(prefix) and name.endswith("_monitor/network_file"))
    if not found:
        raise NoMonitor(f"subsumption watch: no network monitor runs on the master at {rosgraph.get_master_uri()}"
                        f"{' in ' + prefix if prefix != '/' else ''}: give the network file "
                        f"(subsumption watch FILE)")
    if len(found) > 1:
        raise NoMonitor(f"subsumption watch: {len(found)} network monitors run ({', '.join(found)}): give the "
                        f"network file and --namespace")
    monitor = found[0]
    file = master.getParam(monitor + "/network_file")
    level = master.getParam(monitor + "/level")
    return str(file), int(level), monitor.rsplit("/", 1)[0] or "/"


def master_answers() -> bool:
    """Whether the ROS master of ROS_MASTER_URI answers."""
    return _master_answers(rosgraph.Master("/subsumption_watch"))


def _master_answers(master: rosgraph.Master) -> bool:
    try:
        master.getPid()
        return True
    except Exception:  # socket errors, refused connections: no master
        return False
