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

import math

from collections import Counter
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, ClassVar, Generic, Mapping, TypeVar

from .finite import non_finite_field
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
    """A subscribed line. Its latest message is the module's register of the same name.

    ``finite`` (default True): a message with NaN or an infinity in a scalar float field (``data``,
    ``vector.x``, ``pose.position.x``; never arrays such as a scan's ranges) is dropped before any register or
    callback sees it, counted in the module's ``dropped`` (shown on ``/diagnostics``) and logged once per
    input: a NaN force must never become a motor command. REP 117's infinite ``sensor_msgs/Range.range`` is
    let through (:mod:`subsumption.finite`). Give ``finite=False`` for an input whose code handles such values
    itself.

    ``latest`` (default False): only the newest message matters, as with camera images. On ROS the input keeps
    a queue of one (and reads its socket in large chunks, as image_transport subscribers do), so a callback
    slower than the camera takes the newest frame each time instead of working through a backlog of old ones,
    seconds behind. In-process every message is delivered when sent, so there is nothing to drop."""

    def __init__(self, msg_type: MessageType, doc: str = "", name: str = "", finite: bool = True,
                 latest: bool = False) -> None:
        super().__init__(msg_type, doc, name)
        self.finite = finite
        self.latest = latest

    def topic(self) -> str:
        """The topic the input subscribes to before remapping: its own name (relative, as ROS nodes' inputs are)."""
        return self.name


class Output(Port):
    """A published line. In module code, ``self.<attribute>.publish(msg)``. Give ``name=`` when an output
    shares its name with an input (Brooks' avoid reads a heading and sends a heading)."""

    def __init__(self, msg_type: MessageType, doc: str = "", name: str = "", latch: bool = False) -> None:
        super().__init__(msg_type, doc, name)
        self.latch = latch

    def topic(self) -> str:
        """The topic the output publishes on before remapping: ``~name``, private to the module's node."""
        return "~" + self.name

    def __get__(self, instance: "Module | None", owner: type) -> Any:
        if instance is None:
            return self
        return instance._publishers[self.name]


class ParamError(ValueError):
    """A parameter value of the wrong type or out of range. The message names the parameter as the user wrote
    it (``/wander/interval`` on ROS, ``module wander: param interval`` in a network file)."""


PARAM_TYPES: dict[type, str] = {bool: "a boolean (true or false)", int: "an integer", float: "a number",
                                str: "a string", list: "a list", dict: "a mapping"}


class Param(Generic[T]):
    """A private parameter with a default (``~name`` on the ROS parameter server), typed and checked.

    Its type is `type` when given, else the type of `default` (``Param(5.0)`` is a float, ``Param(12)`` an
    int). A float parameter takes integers too (``_interval:=5``); an int takes only whole numbers; a bool only
    true/false. `min` and `max` (inclusive) bound numbers; they are also the limits rqt_reconfigure shows.
    A value that does not fit stops the module with a :class:`ParamError` naming the parameter, instead of
    failing later inside a callback (where, under ROS, a timer thread would die and the node stay up).

    `per_run` marks a value that belongs to one run rather than to the network (a map file, a goal file, a face
    model, a start pose): ``subsumption launch`` makes it an ``<arg>`` of the launch file it writes, unless the
    network file sets it; with `required` the arg has no default (the module cannot run without a value), so
    roslaunch names it before anything starts.

    `aliases` are other private names the value is also read from (when the parameter itself is not set) and
    written back to: the names ROS users know from the node a module stands in for (move_base's
    ``TrajectoryPlannerROS/max_vel_x`` for ``max_vel_x``)."""

    def __init__(self, default: T, doc: str = "", type: type | None = None, min: float | None = None,
                 max: float | None = None, per_run: bool = False, required: bool = False,
                 aliases: tuple[str, ...] = ()) -> None:
        self.type = type if type is not None else builtin_type_of(default)
        if self.type not in PARAM_TYPES:
            raise TypeError(f"Param type must be one of {', '.join(t.__name__ for t in PARAM_TYPES)}, "
                            f"got {self.type!r}")
        if (min is not None or max is not None) and self.type not in (int, float):
            raise TypeError(f"Param min/max only apply to numbers, not to {self.type.__name__}")
        self.min, self.max = min, max
        self.per_run, self.required = per_run or required, required
        self.aliases = tuple(aliases)
        self.doc = doc
        self.name = ""
        self.default: T = self.coerce(default, "default")

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, instance: "Module | None", owner: type) -> Any:
        if instance is None:
            return self
        return instance._params[self.name]

    @property
    def type_name(self) -> str:
        """The parameter's type as a word (``float``, ``int``, ``bool``, ...), for messages and tables."""
        return self.type.__name__

    def coerce(self, value: Any, where: str) -> T:
        """`value` as this parameter's type (an int for a float parameter becomes a float), or a ParamError
        whose text starts with `where`."""
        expected = self.type
        ok = isinstance(value, expected) and not (expected is not bool and isinstance(value, bool))
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            value, ok = float(value), True
        elif expected is int and isinstance(value, float) and value.is_integer():
            value, ok = int(value), True
        if not ok:
            raise ParamError(f"{where} must be {PARAM_TYPES[expected]}, got {value!r} "
                             f"({builtin_type_of(value).__name__})")
        if expected is float and math.isnan(value):  # NaN passes every min/max comparison below unnoticed
            raise ParamError(f"{where} must be a number, got nan")
        if self.min is not None and value < self.min:
            raise ParamError(f"{where} must be >= {self.min:g}, got {value!r}")
        if self.max is not None and value > self.max:
            raise ParamError(f"{where} must be <= {self.max:g}, got {value!r}")
        return value  # type: ignore[return-value]

    def __repr__(self) -> str:
        return f"Param({self.name}: {self.type_name} = {self.default!r})"


def builtin_type_of(value: Any) -> type:
    """The plain type a parameter value is, for messages (numpy scalars and the like count as what they hold)."""
    for kind in (bool, int, float, str, list, dict):
        if isinstance(value, kind):
            return kind
    return type(value)


def read_params(module_class: "type[Module]", node: NodeHandle) -> dict[str, Any]:
    """Every parameter of `module_class` as the node is given it (or its default), checked and typed, and
    written back to the node's parameter server so that ``rosparam list`` shows them all. A ParamError
    names the first bad one by its full name (``/wander/interval``)."""
    values = {}
    for name, param in module_class.interface.params.items():
        given, where = node.param(name, _UNSET), name
        for alias in param.aliases:  # the parameter's own name first, then its aliases in order
            if given is not _UNSET:
                break
            given, where = node.param(alias, _UNSET), alias
        values[name] = param.coerce(param.default if given is _UNSET else given, node.resolve("~" + where))
    for name, value in values.items():
        node.set_param(name, value)
        for alias in module_class.interface.params[name].aliases:
            node.set_param(alias, value)
    return values


_UNSET = object()  # a parameter the node was not given


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
        self._params = read_params(type(self), node)
        self.dropped: Counter[str] = Counter()  # input name -> messages dropped as unusable (NaN or inf)
        self.last_drop = ""  # what the last dropped message was, e.g. "input force: vector.x = nan"
        self.registers = SimpleNamespace(**{name: None for name in self.interface.inputs})
        self._publishers: dict[str, Publisher] = {
            name: node.publisher(port.topic(), port.msg_type, latch=port.latch)
            for name, port in self.interface.outputs.items()
        }
        self._run_setup()
        for name, port in self.interface.inputs.items():
            node.subscribe(port.topic(), port.msg_type, self._receiver(name), latest=getattr(port, "latest", False))

    def _receiver(self, name: str):
        handler = getattr(self, "on_" + name, None)
        finite = getattr(self.interface.inputs[name], "finite", True)

        def receive(msg: Message) -> None:
            if finite and (bad := non_finite_field(msg)) is not None:
                self._drop(name, bad)
                return
            setattr(self.registers, name, msg)
            if handler is not None:
                handler(msg)
            self.on_input(name, msg)

        return receive

    def _drop(self, name: str, what: str) -> None:
        """Count an unusable message on input `name`; the first on each input is logged (a flood must not flood
        the log), the count is on /diagnostics."""
        self.dropped[name] += 1
        self.last_drop = f"input {name} ({self.node.resolve(name)}): {what}"
        if self.dropped[name] == 1:
            self.log(f"dropping messages with NaN or inf on {self.last_drop} (logged once per input; counted "
                     f"in diagnostics)", "warn")

    # Hooks for subclasses -------------------------------------------------------------------------
    def setup(self) -> None:
        """Called once, after parameters and outputs exist and before any message arrives."""

    def on_input(self, name: str, msg: Message) -> None:
        """Called after every input message (after ``on_<name>``); the AFSM uses it to dispatch events."""

    def reconfigure(self, changes: Mapping[str, Any]) -> dict[str, Any]:
        """Change parameters of the running module (dynamic_reconfigure calls this under ROS).

        Every value is checked first (a ParamError names the first bad one and nothing changes); the new
        values are written to the runtime's parameter server, then :meth:`on_reconfigure` is told which
        changed. Returns the parameters that actually changed."""
        params = self.interface.params
        checked = {}
        for name, value in changes.items():
            if name not in params:
                raise ParamError(f"{self.node.resolve('~' + name)}: {type(self).__qualname__} has no param "
                                 f"{name!r} (params: {', '.join(params) or 'none'})")
            checked[name] = params[name].coerce(value, self.node.resolve("~" + name))
        changed = {name: value for name, value in checked.items() if value != self._params[name]}
        if not changed:
            return changed
        before = {name: self._params[name] for name in changed}
        self._params.update(changed)
        try:
            self.on_reconfigure(changed)
        except Exception as error:  # the module cannot run with these values: back to the ones it ran with
            self._params.update(before)
            self.on_reconfigure(before)
            names = ", ".join(self.node.resolve("~" + name) for name in changed)
            raise ParamError(f"{names}: refused, the module failed with the new values: "
                             f"{type(error).__name__}: {error}") from error
        for name, value in changed.items():
            self.node.set_param(name, value)
        return changed

    def on_reconfigure(self, changed: dict[str, Any]) -> None:
        """Called after parameters changed on the running module. The default runs :meth:`setup` again, after
        cancelling the timers setup started, so that parameters read only there (periods, sizes, seeds) take
        effect too; registers (and an AFSM's state) are kept. A module whose setup builds state it must not
        lose (a memory, a map) overrides this and applies only what it needs."""
        for timer in self._setup_timers:
            timer.cancel()
        self._run_setup()

    def _run_setup(self) -> None:
        self._setup_timers: list[TimerHandle] = []
        self._in_setup = True
        try:
            self.setup()
        finally:
            self._in_setup = False

    # Conveniences ---------------------------------------------------------------------------------
    def publisher(self, output: str) -> Publisher:
        """The publisher of the output port called `output` (its wiring name)."""
        return self._publishers[output]

    def now(self) -> float:
        """The current time in seconds: ROS time (simulated time on a simulated clock), never the wall clock."""
        return self.node.now()

    def every(self, period: float, callback) -> TimerHandle:
        """Call `callback` every `period` seconds of ROS time; a timer made in setup() lives as long as the module."""
        return self._keep_if_setup(self.node.call_every(period, callback))

    def after(self, delay: float, callback) -> TimerHandle:
        """Call `callback` once, `delay` seconds of ROS time from now."""
        return self._keep_if_setup(self.node.call_later(delay, callback))

    def _keep_if_setup(self, timer: TimerHandle) -> TimerHandle:
        if getattr(self, "_in_setup", False):
            self._setup_timers.append(timer)
        return timer

    def log(self, text: str, level: str = "info") -> None:
        """Log `text` at `level` (debug, info, warn, error) through the runtime (rosout on ROS)."""
        self.node.log(level, text)

    def log_every(self, key: str, period: float, text: str, level: str = "info") -> bool:
        """`log`, at most once per `period` s of the runtime's clock for each `key` (rospy's logwarn_throttle,
        in simulated time when the graph runs on it): a condition that lasts does not flood the log. Returns
        whether it logged."""
        last = getattr(self, "_logged_at", None)
        if last is None:
            last = self._logged_at = {}
        now = self.now()
        if now - last.get(key, -math.inf) < period:
            return False
        last[key] = now
        self.log(text, level)
        return True

    def log_once(self, key: str, text: str, level: str = "warn") -> bool:
        """`log` the first time only for each `key` (rospy's logwarn_once): a condition worth one line, such as
        a transform not there yet, is said once and not for every message. Returns whether it logged."""
        return self.log_every(key, math.inf, text, level)

    @classmethod
    def describe(cls) -> str:
        """A few lines a newcomer can read: the module's doc and ports, like `rosnode info` before it runs."""
        summary = " ".join((cls.__doc__ or "").strip().split("\n\n")[0].split())  # the first paragraph
        lines = [f"{cls.__module__}:{cls.__qualname__}", "  " + summary if summary else ""]
        for title, ports in (("inputs", cls.interface.inputs), ("outputs", cls.interface.outputs)):
            for name, port in ports.items():
                raw = " (NaN/inf passed)" if getattr(port, "finite", True) is False else ""
                lines.append(f"  {title[:-1]:6} {name}: {type_name(port.msg_type)}{raw}  {port.doc}".rstrip())
        for name, param in cls.interface.params.items():
            bounds = "".join(f", {word} {value:g}" for word, value in (("min", param.min), ("max", param.max))
                             if value is not None)
            lines.append(f"  param  {name} = {param.default!r} ({param.type_name}{bounds})  {param.doc}".rstrip())
        return "\n".join(line for line in lines if line)
