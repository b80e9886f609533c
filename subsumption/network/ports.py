"""What each module of a network offers: its input and output ports with message types.

A module class declares its ports (:class:`~subsumption.module.Interface`); an existing ROS node cannot be
asked, so the network file declares its ports with their types. Both end up as :class:`Ports`, which is all
the wiring, the checker and the graph need to know about a module.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

from ..loading import ClassPathError, load_module_class
from ..module import Module, ParamError, type_name
from .spec import ModuleSpec, NetworkError


@dataclass(frozen=True)
class Port:
    """One port: its wiring name, message type name and the node's own topic name for it."""

    name: str
    type: str | None
    own_topic: str


@dataclass
class Ports:
    inputs: dict[str, Port] = field(default_factory=dict)
    outputs: dict[str, Port] = field(default_factory=dict)
    module_class: type[Module] | None = None
    known: bool = True  # False when the class could not be loaded: its ports are then unknown

    def line(self, port: str) -> tuple[str, Port] | None:
        """("input"|"output", port) for an arbiter's lower line: an input of that name first, else an output."""
        if port in self.inputs:
            return "input", self.inputs[port]
        if port in self.outputs:
            return "output", self.outputs[port]
        return None


@lru_cache(maxsize=None)
def message_type_exists(name: str) -> bool:
    """Whether `name` (package/Type) is a message type this Python can import."""
    from roslib.message import get_message_class  # roslib, not rospy: fine in the core
    try:
        return "/" in name and get_message_class(name) is not None
    except Exception:  # roslib raises assorted errors for malformed names
        return False


def node_executable_exists(package: str, node_type: str) -> str | None:
    """None if roslaunch can find `package/type`, else what is wrong (as roslaunch would find it)."""
    import rospkg
    from roslib.packages import find_node
    try:
        found = find_node(package, node_type)
    except rospkg.ResourceNotFound:
        return f"package {package!r} not found on ROS_PACKAGE_PATH"
    return None if found else f"package {package!r} has no executable {node_type!r}"


def resolve_ports(module: ModuleSpec) -> tuple[Ports, list[NetworkError]]:
    """The ports of `module` and the problems met finding them (class not importable, bad package/type,
    ports the file names that the class lacks, declared types that disagree or do not exist)."""
    errors: list[NetworkError] = []
    what = f"module {module.name}"
    if module.class_path is not None:
        ports = _class_ports(module, errors)
    else:
        ports = _node_ports(module, errors)
    for port in [*module.inputs.values(), *module.outputs.values()]:
        if port.type is not None and not message_type_exists(port.type):
            errors.append(NetworkError(port.where, f"{what}: port {port.name}: unknown message type {port.type!r}"))
    return ports, errors


def _class_ports(module: ModuleSpec, errors: list[NetworkError]) -> Ports:
    what = f"module {module.name}"
    try:
        module_class = load_module_class(module.class_path or "")
    except ClassPathError as error:
        errors.append(NetworkError(module.where, f"{what}: class {module.class_path}: {error}"))
        return Ports(known=False)
    interface = module_class.interface
    ports = Ports(
        inputs={name: Port(name, type_name(p.msg_type), p.topic()) for name, p in interface.inputs.items()},
        outputs={name: Port(name, type_name(p.msg_type), p.topic()) for name, p in interface.outputs.items()},
        module_class=module_class)
    for title, given, declared in (("input", module.inputs, ports.inputs),
                                   ("output", module.outputs, ports.outputs)):
        for name, spec in given.items():
            if name not in declared:
                errors.append(NetworkError(spec.where, f"{what}: {module.class_path} has no {title} {name!r} "
                                                       f"({title}s: {', '.join(declared) or 'none'})"))
            elif spec.type is not None and spec.type != declared[name].type:
                errors.append(NetworkError(spec.where, f"{what}: {title} {name} is {declared[name].type} in "
                                                       f"{module.class_path}, not {spec.type}"))
            if spec.topic is not None:
                errors.append(NetworkError(spec.where, f"{what}: {title} {name}: 'topic' is only for existing "
                                                       f"nodes (a module class names its own topics)"))
    for name, value in module.params.items():
        if name not in interface.params:
            errors.append(NetworkError(module.where, f"{what}: {module.class_path} has no param {name!r} "
                                                     f"(params: {', '.join(interface.params) or 'none'})"))
        else:
            try:
                interface.params[name].coerce(value, f"{what}: param {name}")
            except ParamError as error:
                errors.append(NetworkError(module.where, str(error)))
    return ports


def _node_ports(module: ModuleSpec, errors: list[NetworkError]) -> Ports:
    what = f"module {module.name}"
    package, node_type = module.package_type
    if not package or not node_type:
        errors.append(NetworkError(module.where, f"{what}: node {module.node!r} is not of the form package/type"))
    else:
        problem = node_executable_exists(package, node_type)
        if problem:
            errors.append(NetworkError(module.where, f"{what}: node {module.node}: {problem}"))
    ports = Ports()
    for title, given, declared in (("input", module.inputs, ports.inputs),
                                   ("output", module.outputs, ports.outputs)):
        for name, spec in given.items():
            if spec.type is None:
                errors.append(NetworkError(spec.where, f"{what}: {title} {name}: an existing node's ports need "
                                                       f"a 'type' (package/Type)"))
            declared[name] = Port(name, spec.type, spec.topic or name)
    return ports
