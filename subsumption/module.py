"""Modules: the boxes of a subsumption network.

A module declares its ports and parameters as class attributes, the way a ROS user reads a node's
interface at a glance::

    class Runaway(Module):
        '''Turns a significant repulsive force into a heading away from it.'''
        force = Input(Vector3Stamped)
        heading = Output(Float64)
        threshold = Param(0.5, "force magnitude that counts as significant")

        def on_force(self, msg):
            if math.hypot(msg.vector.x, msg.vector.y) > self.threshold:
                self.heading.publish(Float64(math.atan2(msg.vector.y, msg.vector.x)))

Inputs feed Brooks' *registers*: the latest message on each input is kept in ``self.registers.<input>``
(``None`` until the first one), then ``on_<input>(msg)`` is called if the class defines it. Several callbacks
can therefore share state through the registers (the paper's Fig. 2(b) style); :class:`~subsumption.afsm.AFSM`
builds Brooks' four kinds of state on the same registers.

Topic names: an input subscribes to its own name relative to the node (``force``), so a remap such as
``force:=/feelforce/force`` wires it; an output publishes privately (``~heading``, i.e. ``/runaway/heading``)
so that a module may have an input and an output of the same name, as Brooks' avoid does.
"""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, ClassVar, Generic, TypeVar

from .runtime import Message, MessageType, NodeHandle, Publisher, TimerHandle

T = TypeVar("T")


def type_name(msg_type: MessageType) -> str:
    """ROS name of a genpy message class, e.g. 'geometry_msgs/Twist'."""
    return getattr(msg_type, "_type", getattr(msg_type, "__name__", str(msg_type)))


class Port:
    """Common part of inputs and outputs: a name (set from the attribute) and a ROS message type."""

    def __init__(self, msg_type: MessageType, doc: str = "", name: str = "") -> None:
        self.msg_type = msg_type
        self.doc = doc
        self.name = name  # the port's name in wiring; defaults to the attribute's
        self.attr = ""

    def __set_name__(self, owner: type, attr: str) -> None:
        self.attr = attr
        self.name = self.name or attr

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name}: {type_name(self.msg_type)})"


class Input(Port):
    """A subscribed line. Its latest message is the module's register of the same name."""

    def topic(self) -> str:
        return self.name


class Output(Port):
    """A published line. In module code, ``self.<attribute>.publish(msg)``. Give ``name=`` when an output
    shares its name with an input (Brooks' avoid reads a heading and sends a heading)."""

    def __init__(self, msg_type: MessageType, doc: str = "", name: str = "", latch: bool = False) -> None:
        super().__init__(msg_type, doc, name)
        self.latch = latch

    def topic(self) -> str:
        return "~" + self.name

    def __get__(self, instance: "Module | None", owner: type) -> Any:
        if instance is None:
            return self
        return instance._publishers[self.name]


class Param(Generic[T]):
    """A private parameter with a default (``~name`` on the ROS parameter server)."""

    def __init__(self, default: T, doc: str = "") -> None:
        self.default = default
        self.doc = doc
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, instance: "Module | None", owner: type) -> Any:
        if instance is None:
            return self
        return instance._params[self.name]


@dataclass(frozen=True)
class Interface:
    """What a module class declares: used by the network checker, the graph and the launcher."""

    inputs: dict[str, Input]
    outputs: dict[str, Output]
    params: dict[str, Param]


class Module:
    """Base class of every subsumption module. Subclasses declare Input/Output/Param attributes."""

    interface: ClassVar[Interface]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        inputs: dict[str, Input] = {}
        outputs: dict[str, Output] = {}
        params: dict[str, Param] = {}
        for klass in reversed(cls.__mro__):
            for value in vars(klass).values():
                if isinstance(value, Input):
                    inputs[value.name] = value
                elif isinstance(value, Output):
                    outputs[value.name] = value
                elif isinstance(value, Param):
                    params[value.name] = value
        cls.interface = Interface(inputs, outputs, params)

    def __init__(self, node: NodeHandle) -> None:
        self.node = node
        self.name = node.name.rsplit("/", 1)[-1]
        self._params = {name: node.param(name, p.default) for name, p in self.interface.params.items()}
        self.registers = SimpleNamespace(**{name: None for name in self.interface.inputs})
        self._publishers: dict[str, Publisher] = {
            name: node.publisher(port.topic(), port.msg_type, latch=port.latch)
            for name, port in self.interface.outputs.items()
        }
        self.setup()
        for name, port in self.interface.inputs.items():
            node.subscribe(port.topic(), port.msg_type, self._receiver(name))

    def _receiver(self, name: str):
        handler = getattr(self, "on_" + name, None)

        def receive(msg: Message) -> None:
            setattr(self.registers, name, msg)
            if handler is not None:
                handler(msg)
            self.on_input(name, msg)

        return receive

    # Hooks for subclasses -------------------------------------------------------------------------
    def setup(self) -> None:
        """Called once, after parameters and outputs exist and before any message arrives."""

    def on_input(self, name: str, msg: Message) -> None:
        """Called after every input message (after ``on_<name>``); the AFSM uses it to dispatch events."""

    # Conveniences ---------------------------------------------------------------------------------
    def publisher(self, output: str) -> Publisher:
        """The publisher of the output port called `output` (its wiring name)."""
        return self._publishers[output]

    def now(self) -> float:
        return self.node.now()

    def every(self, period: float, callback) -> TimerHandle:
        return self.node.call_every(period, callback)

    def after(self, delay: float, callback) -> TimerHandle:
        return self.node.call_later(delay, callback)

    def log(self, text: str, level: str = "info") -> None:
        self.node.log(level, text)

    @classmethod
    def describe(cls) -> str:
        """A few lines a newcomer can read: the module's doc and ports, like `rosnode info` before it runs."""
        summary = " ".join((cls.__doc__ or "").strip().split("\n\n")[0].split())  # the first paragraph
        lines = [f"{cls.__module__}:{cls.__qualname__}", "  " + summary if summary else ""]
        for title, ports in (("inputs", cls.interface.inputs), ("outputs", cls.interface.outputs)):
            for name, port in ports.items():
                lines.append(f"  {title[:-1]:6} {name}: {type_name(port.msg_type)}  {port.doc}".rstrip())
        for name, param in cls.interface.params.items():
            lines.append(f"  param  {name} = {param.default!r}  {param.doc}".rstrip())
        return "\n".join(line for line in lines if line)
