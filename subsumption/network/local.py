"""Running a network file in one process: the same wiring, on the :class:`~subsumption.local.LocalRuntime`.

Module classes become modules of the runtime with the wiring's remaps and parameters, and every active
arbiter an in-process :class:`~subsumption.arbiter.Arbiter` with the message types of the ports it joins, so
a network behaves in-process as it does under roslaunch, only faster and reproducibly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from rosgraph.names import ns_join

from ..arbiter import Arbiter
from ..local import LocalRuntime
from ..module import Module
from .spec import Network, NetworkError, NetworkInvalid
from .wiring import Wiring, wire


@dataclass
class LocalNetwork:
    """What build_local made: modules and arbiters by name, and the wiring they follow."""

    wiring: Wiring
    modules: dict[str, Module] = field(default_factory=dict)
    arbiters: dict[str, Arbiter] = field(default_factory=dict)


def build_local(network: Network, runtime: LocalRuntime, level: int | None = None,
                namespace: str = "/") -> LocalNetwork:
    """Instantiate levels 0..`level` of `network` in `runtime` under `namespace`. Existing ROS nodes cannot
    run in-process: that is a NetworkInvalid naming each such module and its line."""
    return build_wired(wire(network, level), runtime, namespace)


def build_wired(wiring: Wiring, runtime: LocalRuntime, namespace: str = "/") -> LocalNetwork:
    """:func:`build_local` for a wiring already made (and perhaps rewired, as replay's isolation does)."""
    foreign = [NetworkError(m.spec.where, f"module {m.name}: node {m.spec.node} is an existing ROS node and "
                                          f"cannot run in-process; run the network with `subsumption launch`")
               for m in wiring.modules if m.ports.module_class is None]
    if foreign:
        raise NetworkInvalid(foreign)
    built = LocalNetwork(wiring)
    for module in wiring.modules:
        assert module.ports.module_class is not None
        built.modules[module.name] = runtime.add_module(module.ports.module_class, ns_join(namespace, module.name),
                                                         module.remaps, module.params)
    for arbiter in wiring.arbiters:
        node = runtime.node(ns_join(namespace, arbiter.name),
                            {"upper": arbiter.upper, "lower": arbiter.lower, "output": arbiter.output})
        line_class = _port_class(wiring, arbiter.spec.lower)
        upper_class = _port_class(wiring, arbiter.spec.upper)
        built.arbiters[arbiter.name] = Arbiter(node, arbiter.kind, arbiter.time_constant, line_class, upper_class)
    return built


def _port_class(wiring: Wiring, ref: str) -> type:
    """The message class of port `module.port` (an input first, as for a lower line, else an output)."""
    module_name, _, port = ref.partition(".")
    interface = wiring.module(module_name).ports.module_class.interface  # type: ignore[union-attr]
    found = interface.inputs.get(port) or interface.outputs[port]
    return found.msg_type
