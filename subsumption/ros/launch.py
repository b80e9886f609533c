"""A network file on ROS: the equivalent roslaunch XML, and roslaunch running it.

The XML is what a ROS user would have written by hand, so it can be kept, read and edited: module classes
run as ``<node pkg="subsumption" type="module">`` with ``<param name="class">``, existing nodes with their own
package, type and args, arbiters as the generic ``suppressor``/``inhibitor``/``defaulter`` nodes with
``upper``/``lower``/``output`` remapped and ``time_constant`` in seconds. Topics are relative, so
``namespace`` (a ``<group ns>``) moves the whole robot. Each external line the file uses is an
``<arg name="line_NAME">`` (:func:`line_arg`) whose default is the line's own relative name: an including launch
file points a line at another topic (a robot driver's ``/odom``) by passing the arg, which a surrounding
``<remap>`` cannot do (roslaunch keeps a node's own remapping of the same name).

:func:`launch` runs roslaunch on it (roslaunch starts a master when none answers) and returns a handle
whose ``stop()`` interrupts exactly that roslaunch, by pid, so that it shuts down its own children.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import yaml

from ..network.groups import Groups, group_wiring
from ..network.motors import motor_errors, motor_lines, stopping_modules
from ..network.spec import ArbiterSpec, ModuleSpec, Network, NetworkError, NetworkInvalid
from ..network.wiring import ModuleWiring, Wiring, wire
from .master import host_env, tied_to_parent

PACKAGE = "subsumption"
PACKAGE_ROOT = Path(__file__).resolve().parents[2]  # holds package.xml and nodes/


def launch_xml(wiring: Wiring, namespace: str = "", groups: str | Groups = "file") -> ET.ElementTree:
    """The roslaunch document for `wiring`, nodes inside ``<group ns=namespace>`` when one is given. `groups`
    (a mode of :func:`~subsumption.network.groups.group_wiring`, or its result) puts modules and arbiters into
    group nodes (:mod:`subsumption.ros.group`): one process each, their parameters on the server under their
    own names, as for nodes of their own. A network with a ``critical: true`` module gives each motor line's
    publisher ``~motor_hold`` (NetworkInvalid when one cannot hold it: subsumption.network.motors)."""
    root = ET.Element("launch")
    network = wiring.network
    grouping = group_wiring(wiring, groups) if isinstance(groups, str) else groups
    if errors := motor_errors(wiring):
        raise NetworkInvalid(errors)
    per_run = run_args(wiring)
    lines = LineArgs(network, {arg.name for arg in per_run})
    holds = {node: hold | {"lines": [lines.ref(line) for line in hold["lines"]]}
             for node, hold in motor_holds(wiring, grouping).items()}
    root.append(ET.Comment(f" network {network.name} from {network.file}, levels 0..{wiring.level}; "
                           f"written by `subsumption launch` "))
    for arg in per_run:
        ET.SubElement(root, "arg", arg.attributes())
    lines_at = len(root)  # the line args go here once the nodes have said which lines they use
    parent = ET.SubElement(root, "group", ns=namespace) if namespace.strip("/") else root
    for group, names in grouping.members.items():
        _hold_param(_group_node(parent, wiring, group, names, lines), holds.get(group))
        for arg in per_run:  # a grouped module's parameters sit beside it as <member>/<param>
            if arg.module in names:
                _param_from_arg(parent, arg, f"{arg.module}/{arg.param}")
    for module in wiring.modules:
        if grouping.group_of(module.name) is not None:
            continue
        node = _module_node(parent, module)
        for source, target in module.remaps.items():
            ET.SubElement(node, "remap", {"from": source, "to": lines.ref(target)})
        for name, value in module.params.items():
            _param(node, name, value)
        for arg in per_run:
            if arg.module == module.name:
                _param_from_arg(node, arg)
        _hold_param(node, holds.get(module.name))
    for arbiter in wiring.arbiters:
        if grouping.group_of(arbiter.name) is not None:
            continue
        node = ET.SubElement(parent, "node", pkg=PACKAGE, type=arbiter.kind, name=arbiter.name, output="screen",
                             **_respawn(arbiter.spec))
        for line in ("upper", "lower", "output"):
            ET.SubElement(node, "remap", {"from": line, "to": lines.ref(getattr(arbiter, line))})
        _param(node, "time_constant", float(arbiter.time_constant or 0.0))
        if arbiter.line_type:  # the node then advertises its output at once and refuses any other type
            _param(node, "type", arbiter.line_type)
        _hold_param(node, holds.get(arbiter.name))
    _monitor_node(parent, wiring, grouping)
    for offset, topic in enumerate(t for t in network.external if t in lines.used):  # in the file's order
        root.insert(lines_at + offset, ET.Element("arg", lines.attributes(topic)))
    ET.indent(root, "  ")
    return ET.ElementTree(root)


def line_arg(topic: str) -> str:
    """The launch file's argument for external line `topic`: ``line_`` and the name with every character that is
    not a letter, digit or underscore as ``_`` (``camera/rgb/image_raw`` -> ``line_camera_rgb_image_raw``). The
    prefix keeps it apart from the per-run MODULE_PARAM args and from an including file's own args (patrol.launch
    passes all of its args down, ``odom`` and ``cmd_vel`` among them)."""
    return "line_" + re.sub(r"[^A-Za-z0-9_]", "_", topic.strip("/"))


class LineArgs:
    """The external lines of `network` that a launch file's nodes use, each written as ``$(arg line_NAME)``;
    NetworkInvalid when two lines would share an argument, or one a per-run argument's name (`taken`)."""

    def __init__(self, network: Network, taken: set[str]) -> None:
        self.network = network
        self.used: set[str] = set()
        by_arg: dict[str, str] = {}
        errors = []
        for topic, spec in network.external.items():
            name = line_arg(topic)
            if name in by_arg or name in taken:
                other = f"external line {by_arg[name]}" if name in by_arg else "a module's per-run parameter"
                errors.append(NetworkError(spec.where, f"external line {topic}: its launch argument {name} is also "
                                                       f"{other}'s: rename one of them"))
            by_arg[name] = topic
        if errors:
            raise NetworkInvalid(errors)

    def ref(self, topic: str) -> str:
        """`topic` as the launch file writes it: ``$(arg line_NAME)`` for an external line, else as it is."""
        if topic not in self.network.external:
            return topic
        self.used.add(topic)
        return f"$(arg {line_arg(topic)})"

    def attributes(self, topic: str) -> dict[str, str]:
        """The line's ``<arg>``: its default the line's own name (relative: in the network's namespace)."""
        return {"name": line_arg(topic), "default": topic,
                "doc": f"external line {topic} ({self.network.external[topic].type}): the topic the network uses "
                       f"for it"}


@dataclass(frozen=True)
class RunArg:
    """A module parameter that belongs to one run (``Param(per_run=True)``) and that the network file leaves
    unset: an ``<arg name="MODULE_PARAM">`` of the launch file, so that ``roslaunch FILE MODULE_PARAM:=VALUE``
    (or an including launch file) gives it. A required one has no default: roslaunch names it if it is missing."""

    module: str
    param: str
    type: type
    default: Any
    required: bool
    doc: str

    @property
    def name(self) -> str:
        """The launch file's argument name: MODULE_PARAM."""
        return f"{self.module}_{self.param}"

    def attributes(self) -> dict[str, str]:
        """The `<arg>` element's attributes: its name, and its default unless the argument is required."""
        attributes = {"name": self.name}
        if not self.required:
            attributes["default"] = (yaml.safe_dump(self.default, default_flow_style=True).strip()
                                     if isinstance(self.default, (list, dict)) else _text(self.default))
        attributes["doc"] = f"{self.module}'s ~{self.param}: {self.doc}"
        return attributes


def run_args(wiring: Wiring) -> list[RunArg]:
    """The per-run parameters of the wired modules that the network file does not set, in module order."""
    from ..loading import load_module_class

    found = []
    for module in wiring.modules:
        if module.spec.is_node or not module.spec.class_path:
            continue
        for name, param in load_module_class(module.spec.class_path).interface.params.items():
            if param.per_run and name not in module.params:
                found.append(RunArg(module.name, name, param.type, param.default, param.required, param.doc))
    return found


def _param_from_arg(node: ET.Element, arg: RunArg, name: str = "") -> None:
    name = name or arg.param
    if arg.type in (list, dict):  # YAML text: rosparam reads it, with the arg substituted first
        ET.SubElement(node, "rosparam", param=name, subst_value="true").text = f"$(arg {arg.name})"
        return
    kind = {bool: "bool", int: "int", float: "double", str: "str"}[arg.type]
    ET.SubElement(node, "param", name=name, type=kind, value=f"$(arg {arg.name})")


def motor_holds(wiring: Wiring, groups: str | Groups = "file") -> dict[str, dict[str, Any]]:
    """``~motor_hold`` of each node (by ROS node name: a group's, or the writer's own) that publishes a motor line
    of a network with a ``critical: true`` module: the monitor's motors topic and the lines it holds. Empty when
    no wired module is critical: true (nothing is held, and the launch file is as before)."""
    if not stopping_modules(wiring):
        return {}
    grouping = group_wiring(wiring, groups) if isinstance(groups, str) else groups
    holds: dict[str, dict[str, Any]] = {}
    for line in motor_lines(wiring):
        node = grouping.group_of(line.writer) or line.writer
        holds.setdefault(node, {"monitor": f"{monitor_name(wiring.network)}/motors", "lines": []})
        holds[node]["lines"].append(line.topic)
    return holds


def _hold_param(node: ET.Element, hold: dict[str, Any] | None) -> None:
    if hold is not None:
        _param(node, "motor_hold", hold)


def _group_node(parent: ET.Element, wiring: Wiring, group: str, names: list[str],
                lines: LineArgs | None = None) -> ET.Element:
    """One group node hosting `names`: ``~members`` lists each module (class, remaps) and arbiter (kind, topics,
    time constant in seconds, types); each module's parameters are set beside it as ``<member>/<param>``, the
    names its ``~param`` has in a node of its own. The group respawns (as one) when any member asks to."""
    modules = {m.name: m for m in wiring.modules}
    arbiters = {a.name: a for a in wiring.arbiters}
    specs = [modules[n].spec if n in modules else arbiters[n].spec for n in names]
    ref = lines.ref if lines is not None else (lambda topic: topic)
    respawning = [spec for spec in specs if spec.respawn]
    attributes = {"respawn": "true", "respawn_delay": repr(max(float(spec.respawn_delay) for spec in respawning))
                  } if respawning else {}
    node = ET.SubElement(parent, "node", pkg=PACKAGE, type="group", name=group, output="screen", **attributes)
    members: list[dict[str, Any]] = []
    for name in names:
        if name in modules:
            module = modules[name]
            members.append({"name": name, "class": module.spec.class_path or "",
                            "remap": {source: ref(target) for source, target in module.remaps.items()}})
            for param, value in module.params.items():
                _param(parent, f"{name}/{param}", value)
        else:
            arbiter = arbiters[name]
            members.append({"name": name, "arbiter": arbiter.kind, "upper": ref(arbiter.upper),
                            "lower": ref(arbiter.lower), "output": ref(arbiter.output),
                            "time_constant": float(arbiter.time_constant or 0.0),
                            "type": arbiter.line_type or "", "upper_type": arbiter.upper_type or ""})
    _param(node, "members", members)
    return node


def _module_node(parent: ET.Element, module: ModuleWiring) -> ET.Element:
    spec = module.spec
    if spec.is_node:
        package, node_type = spec.package_type
        attributes = {"pkg": package, "type": node_type, "name": spec.name, "output": "screen"}
        if spec.args:
            attributes["args"] = spec.args
        return ET.SubElement(parent, "node", attributes | _respawn(spec))
    node = ET.SubElement(parent, "node", pkg=PACKAGE, type="module", name=spec.name, output="screen",
                         **_respawn(spec))
    _param(node, "class", spec.class_path or "")
    return node


def _respawn(spec: ModuleSpec | ArbiterSpec) -> dict[str, str]:
    """roslaunch's respawn attributes for a module or arbiter the network file marks ``respawn: true``: when
    the node's process ends, roslaunch starts it again after ``respawn_delay`` seconds."""
    if not spec.respawn:
        return {}
    return {"respawn": "true", "respawn_delay": repr(float(spec.respawn_delay))}


def monitor_name(network: Network) -> str:
    """The node that says which line drives each arbiter of `network` (see subsumption.ros.diagnostics)."""
    return f"{network.name}_monitor"


def network_file_ref(network: Network) -> str:
    """The network's file as the monitor's ``~network_file`` names it: through ``$(find subsumption)`` when the
    file is part of the package (the shipped launch files stay valid in any checkout and in the install space),
    else its absolute path."""
    path = Path(network.file).resolve()
    try:
        return f"$(find {PACKAGE})/{path.relative_to(PACKAGE_ROOT).as_posix()}"
    except ValueError:
        return str(path)


def _monitor_node(parent: ET.Element, wiring: Wiring, grouping: Groups | None = None) -> None:
    node = ET.SubElement(parent, "node", pkg=PACKAGE, type="monitor", name=monitor_name(wiring.network),
                         output="screen")
    _param(node, "network", wiring.network.name)
    # which file and levels run: `subsumption watch` without a file reads them here (subsumption.ros.watch)
    _param(node, "network_file", network_file_ref(wiring.network))
    _param(node, "level", wiring.level)
    _param(node, "arbiters", [{"name": a.name, "kind": a.kind, "upper": a.spec.upper, "lower": a.spec.lower}
                              for a in wiring.arbiters])
    _param(node, "nodes", watched_nodes(wiring, grouping))


def watched_nodes(wiring: Wiring, groups: str | Groups = "file") -> list[dict[str, Any]]:
    """What the monitor watches for liveness: every ROS node of the network, with the modules (and arbiters) it
    hosts (a group node hosts several: they die together), what the robot loses when it dies (its members'
    ``critical``, comma-separated), whether roslaunch respawns it, and whether it reports on /diagnostics once a
    second under its own name (module, arbiter and group nodes of ours do; an existing ROS node wired in may
    not, so only its process is watched); ``stops_motors: true`` when it hosts a ``critical: true`` module (the
    key is left out otherwise, so files without one are as before)."""
    grouping = group_wiring(wiring, groups) if isinstance(groups, str) else groups
    specs = {m.name: m.spec for m in wiring.modules} | {a.name: a.spec for a in wiring.arbiters}
    nodes = []
    for group, names in grouping.members.items():
        lost = [getattr(specs[n], "critical", "") for n in names]
        nodes.append({"name": group, "modules": list(names),
                      "critical": ",".join(dict.fromkeys(what for what in lost if what)),
                      "respawn": any(specs[n].respawn for n in names), "reports": True}
                     | _stops(any(getattr(specs[n], "stops_motors", False) for n in names)))
    nodes += [{"name": m.name, "modules": [m.name], "critical": m.spec.critical, "respawn": m.spec.respawn,
               "reports": not m.spec.is_node} | _stops(m.spec.stops_motors)
              for m in wiring.modules if grouping.group_of(m.name) is None]
    nodes += [{"name": a.name, "modules": [], "critical": "", "respawn": a.spec.respawn, "reports": True}
              for a in wiring.arbiters if grouping.group_of(a.name) is None]
    return nodes


def _stops(stops_motors: bool) -> dict[str, bool]:
    return {"stops_motors": True} if stops_motors else {}


def _param(node: ET.Element, name: str, value: Any) -> None:
    """A private parameter: ``<param>`` with an explicit type for scalars, ``<rosparam>`` for lists and dicts
    (roslaunch's own split: <param> cannot hold structured values)."""
    if isinstance(value, (list, dict)):
        text = yaml.safe_dump(value, default_flow_style=True).strip()
        subst = "$(arg " in text  # a line's $(arg line_NAME) (LineArgs): roslaunch substitutes it before the YAML
        if subst:  # on one line each: a substitution broken across lines is not one
            text = yaml.safe_dump(value, default_flow_style=True, width=float("inf")).strip()
        element = ET.SubElement(node, "rosparam", param=name, **({"subst_value": "true"} if subst else {}))
        element.text = text
        return
    kind = {bool: "bool", int: "int", float: "double", str: "str"}.get(type(value), "str")
    ET.SubElement(node, "param", name=name, type=kind, value=_text(value))


def _text(value: Any) -> str:
    """A scalar as a launch file writes it (booleans lower case, floats with their point)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


def write_launch(network: Network, level: int | None, path: str | Path, namespace: str = "",
                 groups: str = "file") -> Path:
    """Write the roslaunch file for levels 0..`level` of `network` to `path`, grouped as `groups` says
    (file, level or none); returns the path."""
    path = Path(path)
    launch_xml(wire(network, level), namespace, groups).write(path, encoding="unicode", xml_declaration=True)
    return path


def launch_env(base: dict[str, str] | None = None, ros_ip: str | None = None) -> dict[str, str]:
    """The environment roslaunch needs for this package: this interpreter's folder first on PATH (the nodes'
    ``#!/usr/bin/env python3`` must find rospy), this package on ROS_PACKAGE_PATH, and ROS_IP/ROS_HOSTNAME
    on loopback unless `ros_ip` says where other hosts reach this one (see :func:`master.host_env`)."""
    env = host_env(dict(os.environ if base is None else base), ros_ip)
    python_dir = str(Path(sys.executable).parent)
    if env.get("PATH", "").split(os.pathsep)[0] != python_dir:
        env["PATH"] = python_dir + os.pathsep + env.get("PATH", "")
    return with_own_package(env)


def with_own_package(env: dict[str, str]) -> dict[str, str]:
    """`env` with this checkout's package (the folder holding package.xml and nodes/) on ROS_PACKAGE_PATH, and
    the system's packages when the variable was unset: what ``source setup.bash`` exports. The CLI applies it
    to its own environment at start, so it finds ``subsumption/terminal`` and its nodes without setup.bash."""
    package_path = env.get("ROS_PACKAGE_PATH", "")
    if (PACKAGE_ROOT / "package.xml").exists() and str(PACKAGE_ROOT) not in package_path.split(os.pathsep):
        env["ROS_PACKAGE_PATH"] = os.pathsep.join(p for p in (str(PACKAGE_ROOT), package_path or "/usr/share") if p)
    return env


@dataclass
class Launched:
    """A running roslaunch. stop() sends it SIGINT (it then stops its nodes and any master it started)."""

    process: subprocess.Popen
    path: Path
    temporary: bool = False  # the launch file was written for this run only: stop() removes it

    @property
    def pid(self) -> int:
        """The process id of roslaunch."""
        return self.process.pid

    def running(self) -> bool:
        """True while roslaunch runs."""
        return self.process.poll() is None

    def wait(self, timeout: float | None = None) -> int:
        """Wait for roslaunch to end (at most `timeout` seconds) and return its exit status."""
        return self.process.wait(timeout)

    def stop(self, timeout: float = 20.0) -> int:
        """Interrupt roslaunch like Ctrl-C and wait; escalate to SIGTERM, then SIGKILL, of that pid only."""
        for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
            if self.process.poll() is not None:
                break
            self.process.send_signal(sig)
            try:
                self.process.wait(wait)
            except subprocess.TimeoutExpired:
                continue
        if self.temporary:
            self.path.unlink(missing_ok=True)
        return self.process.wait()


def launch(network: Network, level: int | None = None, namespace: str = "", xml: str | Path | None = None,
           env: dict[str, str] | None = None, ros_ip: str | None = None, groups: str = "file",
           **popen: Any) -> Launched:
    """Write the launch file (to `xml`, or a temporary file removed by stop()) and start ``roslaunch`` on it in
    a session of its own, so that only :meth:`Launched.stop` (or its pid) ends it, and tied to this process:
    if this process dies, roslaunch is interrupted and stops its nodes. Nodes listen on `ros_ip` (default
    loopback only). Extra keyword arguments go to Popen."""
    temporary = xml is None
    if xml is None:
        handle, name = tempfile.mkstemp(prefix=f"{network.name}_", suffix=".launch")
        os.close(handle)
        xml = name
    path = write_launch(network, level, xml, namespace, groups)
    process = subprocess.Popen(tied_to_parent(["roslaunch", str(path)]), env=launch_env(env, ros_ip),
                               start_new_session=True, **popen)
    return Launched(process, path, temporary)


class NetworkNotReady(RuntimeError):
    """roslaunch exited, or nodes were not ready in time: the message says which."""


def network_nodes(wiring: Wiring, groups: str | Groups = "file") -> tuple[list[str], list[str]]:
    """The network's node names (modules and arbiters of their own, and groups), and those of them that are
    module or group nodes of ours (not existing ROS nodes wired in): the ones whose readiness
    :func:`wait_for_nodes` can see (a group advertises /diagnostics once all its members are built)."""
    grouping = group_wiring(wiring, groups) if isinstance(groups, str) else groups
    alone = [m for m in wiring.modules if grouping.group_of(m.name) is None]
    names = [m.name for m in alone] + [a.name for a in wiring.arbiters if grouping.group_of(a.name) is None]
    names += list(grouping.members)
    return names, [m.name for m in alone if not m.spec.is_node] + list(grouping.members)


def not_ready(master: Any, names: Iterable[str], built: Iterable[str] = ()) -> list[str]:
    """What of a launch is not ready yet, by `master`'s system state (a rosgraph.Master): the nodes of `names` not
    registered, then those of `built` (module and group nodes of ours) not yet advertising /diagnostics, which
    such a node does once its modules are built. Empty: ready."""
    from .diagnostics import DIAGNOSTICS_TOPIC

    publishers, subscribers, services = master.getSystemState()
    registered = {node for _, nodes in publishers + subscribers + services for node in nodes}
    wanted = {"/" + name.lstrip("/") for name in names}
    missing = sorted(wanted - registered)
    if missing:
        return missing
    reporting = next((set(nodes) for topic, nodes in publishers if topic == DIAGNOSTICS_TOPIC), set())
    return sorted(f"{name} (module not built yet)" for name in {"/" + n.lstrip("/") for n in built} - reporting)


def until_ready(master: Any, names: Iterable[str], built: Iterable[str], alive: Callable[[], bool], timeout: float,
                stop: Callable[[], bool] = lambda: False, poll: float = 0.25) -> list[str]:
    """Poll :func:`not_ready` until the launch is ready (then wait a moment more, for subscriptions to connect),
    `alive()` turns false (roslaunch exited), `stop()` says to give up, or `timeout` wall-clock seconds pass.
    Returns what is still missing: empty when ready."""
    names, built = list(names), list(built)
    deadline = time.monotonic() + timeout  # wall clock: processes starting up
    while time.monotonic() < deadline and not stop() and alive():  # wall clock on purpose: no ROS clock runs yet
        if not not_ready(master, names, built):
            time.sleep(1.0)
            return []
        time.sleep(poll)
    return not_ready(master, names, built)


def wait_for_nodes(names: list[str], launched: Any, timeout: float = 60.0,
                   stop: Callable[[], bool] = lambda: False, built: Iterable[str] = ()) -> None:
    """Until every node has registered and every module node in `built` has built its module (and a moment
    more, for subscriptions to connect), or until `stop()` says to give up (a run interrupted meanwhile).
    NetworkNotReady if roslaunch exits, or naming the nodes not ready at the timeout.

    A node registers at once, but its module's setup may take seconds more on a loaded machine (navigation
    warms its numba kernels, amcl reads its map): a run that started the simulation then would have the robot
    drive before move_base answers. A module node advertises /diagnostics once its module is built, so that
    is what readiness is."""
    import rosgraph

    missing = until_ready(rosgraph.Master("/subsumption_wait"), names, built, launched.running, timeout, stop)
    if stop():
        return
    if not launched.running():
        raise NetworkNotReady(f"roslaunch exited with status {launched.process.returncode}")
    if missing:
        raise NetworkNotReady(f"nodes not ready within {timeout:.0f} s: {missing}")
