"""``subsumption check``: every problem of a network file, each as ``FILE:LINE: what``.

The checker adds to the loader's structural errors and the wiring's reference and type errors the
problems that are about the network as a whole: names given twice, outputs nobody reads, inputs nobody
writes, message types that do not exist, externals written by two modules at once, a ``critical: true`` that cannot stop the motors.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from rosgraph.names import is_legal_base_name, is_legal_name

from .loader import read_file
from .ports import Ports, message_type_exists, resolve_ports
from .groups import group_wiring
from .motors import motor_errors
from .spec import Network, NetworkError, NetworkInvalid
from .wiring import End, Wiring, build_wiring


@dataclass
class CheckResult:
    network: Network | None
    errors: list[NetworkError]
    wiring: Wiring | None = None

    @property
    def ok(self) -> bool:
        """True when the network file has no error."""
        return not self.errors

    def summary(self) -> str:
        """One line for a network that passed."""
        assert self.network is not None and self.wiring is not None
        network, wiring = self.network, self.wiring
        return (f"{network.file}: OK: network {network.name}, levels 0..{wiring.level} (of 0.."
                f"{network.top_level}), {len(wiring.modules)} modules, {len(wiring.arbiters)} arbiters, "
                f"{len(wiring.topics())} topics")


def check_file(path: str | Path, level: int | None = None) -> CheckResult:
    """Check the network file at `path` running levels 0..`level` (all by default); never raises for the file's
    own problems: they are all in the result, sorted by line."""
    network, errors = read_file(path)
    if network is None:
        return CheckResult(None, errors)
    result = check(network, level)
    result.errors = sorted(errors + result.errors, key=lambda e: (e.where.line, e.message))
    return result


def check(network: Network, level: int | None = None) -> CheckResult:
    """The problems of an already loaded network (see :func:`check_file`)."""
    errors: list[NetworkError] = []
    ports: dict[str, Ports] = {}
    for module in network.modules(level):
        ports[module.name], port_errors = resolve_ports(module)
        errors.extend(port_errors)
    wiring, wiring_errors = build_wiring(network, level, ports)
    errors.extend(wiring_errors)
    errors.extend(_names(network))
    errors.extend(_externals(network, wiring))
    errors.extend(_unread_outputs(network, wiring))
    errors.extend(_unwritten_inputs(wiring))
    errors.extend(_groups(wiring))
    errors.extend(motor_errors(wiring))
    return CheckResult(network, sorted(errors, key=lambda e: (e.where.line, e.message)), wiring)


def _names(network: Network) -> list[NetworkError]:
    """Module and arbiter names are node names: legal, and unique across the whole file."""
    errors = []
    seen: dict[str, str] = {}
    nodes = [("module", m.name, m.where) for m in network.modules()] + \
            [("arbiter", a.name, a.where) for a in network.arbiters()]
    for kind, name, where in nodes:
        if not is_legal_base_name(name):
            errors.append(NetworkError(where, f"{kind} {name}: not a legal ROS node name"))
        if name in seen:
            errors.append(NetworkError(where, f"duplicate name: {kind} {name} (already {seen[name]}); "
                                              f"give one a different name"))
        else:
            seen[name] = f"a {kind} at line {where.line}"
    return errors


def _externals(network: Network, wiring: Wiring) -> list[NetworkError]:
    errors = []
    for external in network.external.values():
        if not is_legal_name(external.name) or "." in external.name:
            errors.append(NetworkError(external.where, f"external topic {external.name}: not a legal ROS name"))
        if not message_type_exists(external.type):
            errors.append(NetworkError(external.where, f"external topic {external.name}: unknown message type "
                                                       f"{external.type!r}"))
    writers = Counter(w.target.name for w in wiring.wires if w.target.kind == "external")
    for topic, count in writers.items():
        if count > 1:
            names = ", ".join(w.source.name for w in wiring.wires if w.target == End("external", topic))
            errors.append(NetworkError(network.external[topic].where,
                                       f"external topic {topic} is written by {count} lines ({names}): "
                                       f"join them with an arbiter"))
    return errors


def _unread_outputs(network: Network, wiring: Wiring) -> list[NetworkError]:
    """An output that nothing in the whole file reads (no input, no arbiter's upper, no external topic)."""
    read = {m.inputs[i].source for m in network.modules() for i in m.inputs}
    read |= {a.upper for a in network.arbiters()}
    errors = []
    for module in wiring.modules:
        for name in module.ports.outputs:
            spec = module.spec.outputs.get(name)
            if f"{module.name}.{name}" not in read and not (spec and spec.deliver):
                errors.append(NetworkError(spec.where if spec else module.spec.where,
                                           f"module {module.name}: output {name} has no reader (no input, "
                                           f"arbiter or external topic reads {module.name}.{name})"))
    return errors


def _unwritten_inputs(wiring: Wiring) -> list[NetworkError]:
    errors = []
    for module in wiring.modules:
        for name in module.ports.inputs:
            if name not in module.spec.inputs:
                errors.append(NetworkError(module.spec.where,
                                           f"module {module.name}: input {name} has no writer (give inputs: "
                                           f"{{{name}: module.output or an external topic}})"))
    return errors


def _groups(wiring: Wiring) -> list[NetworkError]:
    """A group named like a module or arbiter (both would be one ROS node name)."""
    try:
        group_wiring(wiring, "file")
    except NetworkInvalid as invalid:
        return invalid.errors
    return []
