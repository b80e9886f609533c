"""Where every line of a network goes when it runs up to a given level: the one place that decides it.

The checker, the graph, the in-process builder and the roslaunch writer all read a :class:`Wiring`, so they
cannot disagree about which arbiter sits where or which topic a module reads.

Rules (see docs/networks.md):

- levels 0..N run; a lower line with no active arbiter is wired directly;
- module ``m``'s output ``o`` is published on ``m/o`` (relative, so a namespace moves the whole robot);
- an arbiter splits a line in two, A→X and X→B: the old source feeds its ``lower``, its ``output``
  (``<arbiter>/output``) feeds the old reader(s). On an input line it affects that one reader, on an output line
  every reader; arbiters are applied level by level, in listed order, so later ones sit nearer the readers;
- an output delivered to an external topic reaches it after the arbiters on its line (the last piece of the
  line is named by the external topic).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .ports import Port, Ports, resolve_ports
from .spec import ArbiterSpec, ModuleSpec, Network, NetworkError, NetworkInvalid, split_ref


@dataclass(frozen=True)
class End:
    """One end of a wire: a module port, an arbiter's upper/lower/output, or an external topic."""

    kind: str  # "module" | "arbiter" | "external"
    name: str
    port: str = ""


@dataclass(frozen=True)
class Wire:
    """A piece of line from one end to another, carried by `topic` (relative to the robot's namespace)."""

    source: End
    target: End
    topic: str
    type: str | None
    label: str


@dataclass
class ModuleWiring:
    spec: ModuleSpec
    ports: Ports
    remaps: dict[str, str] = field(default_factory=dict)  # the node's own name -> topic
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """The module's name in the network file (its node's name)."""
        return self.spec.name


@dataclass
class ArbiterWiring:
    spec: ArbiterSpec
    line: str                 # "input" or "output": the kind of lower line it sits on
    line_type: str | None     # message type of the lower line (and of the output)
    upper_type: str | None
    upper: str = ""           # topics
    lower: str = ""
    output: str = ""
    time_constant: float | None = None  # seconds

    @property
    def name(self) -> str:
        """The arbiter's node name."""
        return self.spec.name

    @property
    def kind(self) -> str:
        """``inhibitor``, ``suppressor`` or ``defaulter``."""
        return self.spec.kind


@dataclass
class Wiring:
    network: Network
    level: int
    modules: list[ModuleWiring]
    arbiters: list[ArbiterWiring]
    wires: list[Wire]

    def module(self, name: str) -> ModuleWiring:
        """The wiring of the module called `name` (StopIteration if there is none)."""
        return next(m for m in self.modules if m.name == name)

    def arbiter(self, name: str) -> ArbiterWiring:
        """The wiring of the arbiter called `name`."""
        return next(a for a in self.arbiters if a.name == name)

    def topics(self) -> dict[str, str | None]:
        """Every topic the running network uses, with its message type."""
        return {wire.topic: wire.type for wire in self.wires}


def wire(network: Network, level: int | None = None,
         ports: dict[str, Ports] | None = None) -> Wiring:
    """The wiring of `network` running levels 0..`level` (all by default). Raises NetworkInvalid when a
    reference cannot be resolved or a port cannot be found (``subsumption check`` says everything)."""
    wiring, errors = build_wiring(network, level, ports)
    if errors:
        raise NetworkInvalid(errors)
    return wiring


def build_wiring(network: Network, level: int | None = None, ports: dict[str, Ports] | None = None
                 ) -> tuple[Wiring, list[NetworkError]]:
    """:func:`wire` that returns what it could wire together with the problems, for the checker."""
    level = network.top_level if level is None else level
    errors: list[NetworkError] = []
    if not 0 <= level <= network.top_level:
        errors.append(NetworkError(network.where, f"network {network.name}: no level {level} "
                                                  f"(levels 0..{network.top_level})"))
        level = max(0, min(level, network.top_level))
    if ports is None:
        ports = {}
        for module in network.modules(level):
            ports[module.name], port_errors = resolve_ports(module)
            errors.extend(port_errors)
    builder = _Builder(network, level, ports, errors)
    return builder.build(), errors


class _Builder:
    def __init__(self, network: Network, level: int, ports: dict[str, Ports], errors: list[NetworkError]) -> None:
        self.network = network
        self.level = level
        self.ports = ports
        self.errors = errors
        self.active = {m.name: m for m in network.modules(level)}
        self.every = {m.name: m for m in network.modules()}
        self.modules = {name: ModuleWiring(m, ports.get(name, Ports(known=False)), params=dict(m.params))
                        for name, m in self.active.items()}
        self.arbiters: list[ArbiterWiring] = []
        self.output_chains: dict[tuple[str, str], list[ArbiterWiring]] = {}
        self.input_chains: dict[tuple[str, str], list[ArbiterWiring]] = {}
        self.wires: list[Wire] = []

    def build(self) -> Wiring:
        for arbiter in self.network.arbiters(self.level):
            self._place(arbiter)
        self._lay_output_lines()
        for module in self.active.values():
            for port in module.inputs.values():
                self._lay_input_line(module, port.name, port.source)
        for arbiter in self.arbiters:
            self._lay_upper(arbiter)
        for module in self.modules.values():
            module.remaps.update(module.spec.remap)
        return Wiring(self.network, self.level, list(self.modules.values()), self.arbiters, self.wires)

    # Resolving references --------------------------------------------------------------------------
    def _port(self, ref: str, who: str, where, wanted: str, reader_level: int) -> tuple[str, Port | None] | None:
        """(module, port) that `ref` names; None (and an error) when it names nothing active."""
        parts = split_ref(ref)
        if parts is None:
            return None
        module_name, port_name = parts
        module = self.every.get(module_name)
        if module is None:
            self.errors.append(NetworkError(where, f"{who}: unknown module {module_name!r} in {ref!r}"))
            return None
        if module.level > reader_level:
            self.errors.append(NetworkError(where, f"{who}: {ref} belongs to level {module.level}, above level "
                                                   f"{reader_level}: a level may use only its own and lower levels"))
            return None
        ports = self.ports.get(module_name)
        if ports is None or not ports.known:
            return module_name, None  # the class did not load: already reported
        found = ports.outputs.get(port_name) if wanted == "output" else ports.line(port_name)
        found = found[1] if isinstance(found, tuple) else found
        if found is None:
            names = ports.outputs if wanted == "output" else [*ports.inputs, *ports.outputs]
            self.errors.append(NetworkError(where, f"{who}: module {module_name} has no {wanted} {port_name!r} "
                                                   f"({', '.join(names) or 'none'})"))
            return None
        return module_name, found

    def _external(self, topic: str, who: str, where) -> bool:
        if topic not in self.network.external:
            self.errors.append(NetworkError(where, f"{who}: unknown topic {topic!r} (not a module.port and not "
                                                   f"declared under external)"))
            return False
        return True

    # Arbiters --------------------------------------------------------------------------------------
    def _place(self, spec: ArbiterSpec) -> None:
        who = f"arbiter {spec.name}"
        upper = self._port(spec.upper, who + ": upper", spec.where, "output", spec.level)
        if upper is None and split_ref(spec.upper) is None and spec.upper:
            self.errors.append(NetworkError(spec.where, f"{who}: upper must be a module output (module.output), "
                                                        f"got {spec.upper!r}"))
        lower = self._port(spec.lower, who + ": lower", spec.where, "line", spec.level)
        if lower is None and split_ref(spec.lower) is None and spec.lower:
            self.errors.append(NetworkError(spec.where, f"{who}: lower must name a line (module.input or "
                                                        f"module.output), got {spec.lower!r}"))
        if upper is None or lower is None or lower[1] is None:
            return
        module_name, port = lower
        line = "input" if port.name in self.ports[module_name].inputs else "output"
        seconds = None if spec.time_constant is None else spec.time_constant * self.network.time_unit
        arbiter = ArbiterWiring(spec, line, port.type, upper[1].type if upper[1] else None, time_constant=seconds)
        chains = self.input_chains if line == "input" else self.output_chains
        chains.setdefault((module_name, port.name), []).append(arbiter)
        self.arbiters.append(arbiter)

    # Lines -----------------------------------------------------------------------------------------
    def _lay_output_lines(self) -> None:
        """Each output line: module → its arbiters, in order; remember the last end and topic for readers."""
        self.finals: dict[tuple[str, str], tuple[End, str]] = {}
        for name, module in self.modules.items():
            for port in module.ports.outputs.values():
                spec = module.spec.outputs.get(port.name)
                deliver = spec.deliver if spec else None
                if deliver is not None and not self._external(deliver, f"module {name}: output {port.name}",
                                                               spec.where):
                    deliver = None
                chain = self.output_chains.get((name, port.name), [])
                own = deliver if deliver and not chain else f"{name}/{port.name}"  # what the module publishes
                if module.spec.is_node or own != f"{name}/{port.name}":
                    module.remaps[port.own_topic] = own
                end, topic = End("module", name, port.name), own
                for index, arbiter in enumerate(chain):
                    arbiter.lower = topic
                    self._wire(end, End("arbiter", arbiter.name, "lower"), topic, port.type, port.name)
                    last = index == len(chain) - 1
                    end, topic = End("arbiter", arbiter.name, "output"), \
                        (deliver if last and deliver else f"{arbiter.name}/output")
                    arbiter.output = topic
                if deliver:
                    self._same_type(port.type, self.network.external[deliver].type, spec.where,
                                    f"module {name}: output {port.name} carries {{0}} but external topic "
                                    f"{deliver} is {{1}}")
                    self._wire(end, End("external", deliver), topic, port.type, port.name)
                self.finals[(name, port.name)] = (end, topic)

    def _source(self, ref: str, who: str, where, reader_level: int) -> tuple[End, str, str | None] | None:
        """The end and topic a reader of `ref` gets, after any arbiters on that output line, and its type."""
        found = self._port(ref, who, where, "output", reader_level)
        if found is not None:
            module_name, port = found
            if port is None or (module_name, port.name) not in self.finals:
                return None
            end, topic = self.finals[(module_name, port.name)]
            return end, topic, port.type
        if split_ref(ref) is None and self._external(ref, who, where):
            return End("external", ref), ref, self.network.external[ref].type
        return None

    def _lay_input_line(self, spec: ModuleSpec, port_name: str, source: str) -> None:
        module = self.modules[spec.name]
        who = f"module {spec.name}: input {port_name}"
        where = spec.inputs[port_name].where
        port = module.ports.inputs.get(port_name)
        found = self._source(source, who, where, spec.level)
        if port is None or found is None:
            return
        end, topic, source_type = found
        self._same_type(source_type, port.type, where, f"{who}: {source} carries {{0}} but the input is {{1}}")
        label = source.partition(".")[2] or source
        if label != port_name:
            label = f"{label}→{port_name}" if split_ref(source) else port_name
        for arbiter in self.input_chains.get((spec.name, port_name), []):
            arbiter.lower = topic
            self._wire(end, End("arbiter", arbiter.name, "lower"), topic, source_type, label)
            end, topic = End("arbiter", arbiter.name, "output"), f"{arbiter.name}/output"
            arbiter.output = topic
        self._wire(end, End("module", spec.name, port_name), topic, source_type, label)
        module.remaps[port.own_topic] = topic

    def _lay_upper(self, arbiter: ArbiterWiring) -> None:
        found = self._source(arbiter.spec.upper, f"arbiter {arbiter.name}: upper", arbiter.spec.where,
                             arbiter.spec.level)
        if found is None:
            return
        end, topic, msg_type = found
        arbiter.upper = topic
        if arbiter.spec.kind != "inhibitor":
            self._same_type(msg_type, arbiter.line_type, arbiter.spec.where,
                            f"arbiter {arbiter.name}: a {arbiter.kind} forwards its upper line, so upper "
                            f"{arbiter.spec.upper} ({{0}}) and lower {arbiter.spec.lower} ({{1}}) must have one type")
        self._wire(end, End("arbiter", arbiter.name, "upper"), topic, msg_type, arbiter.spec.upper.partition(".")[2])

    def _same_type(self, writer: str | None, reader: str | None, where, message: str) -> None:
        """A type mismatch across a wire or an arbiter; unknown types (already reported) are let pass."""
        if writer and reader and writer != reader:
            self.errors.append(NetworkError(where, message.format(writer, reader)))

    def _wire(self, source: End, target: End, topic: str, msg_type: str | None, label: str) -> None:
        self.wires.append(Wire(source, target, topic, msg_type, label))

