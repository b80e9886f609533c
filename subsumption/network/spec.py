"""The plain data a network file becomes, and the one error type every part of the toolkit reports with.

Every item remembers where it was written (:class:`Where`), so that the loader, the checker, the wiring and
the launcher can all say ``FILE:LINE: what`` about the thing the user has to fix, the way a compiler does.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Where:
    """A place in a network file: the file as the user named it and a 1-based line."""

    file: str
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}"


class NetworkError(Exception):
    """One problem in a network file; its text is ``FILE:LINE: what``, naming the thing to fix."""

    def __init__(self, where: Where, message: str) -> None:
        message = printable(message)
        super().__init__(f"{where}: {message}")
        self.where = where
        self.message = message


def printable(text: str) -> str:
    """``text`` with line breaks and other control characters escaped (``\\x1c``), so that a hostile name
    copied into an error message cannot split the one line each problem gets."""
    return "".join(char if char.isprintable() else repr(char)[1:-1] for char in text)


class NetworkInvalid(Exception):
    """Several NetworkErrors found together (a loader or checker reports all of them, not just the first)."""

    def __init__(self, errors: list[NetworkError]) -> None:
        super().__init__("\n".join(str(error) for error in errors))
        self.errors = errors


@dataclass
class InputSpec:
    """An input line of a module: where it reads from (``module.output`` or an external topic)."""

    name: str
    source: str
    where: Where
    type: str | None = None   # required for existing nodes; for module classes, a cross-check only
    topic: str | None = None  # an existing node's own name for it (default: the port name)


@dataclass
class OutputSpec:
    """An output line of a module, optionally also delivered to an external topic."""

    name: str
    where: Where
    deliver: str | None = None
    type: str | None = None
    topic: str | None = None


@dataclass
class ModuleSpec:
    """A box of the network: a Module subclass (``class``) or an existing ROS node (``node: package/type``)."""

    name: str
    level: int
    where: Where
    class_path: str | None = None
    node: str | None = None
    args: str = ""
    inputs: dict[str, InputSpec] = field(default_factory=dict)
    outputs: dict[str, OutputSpec] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    remap: dict[str, str] = field(default_factory=dict)
    respawn: bool = False       # roslaunch restarts the node when it dies ...
    respawn_delay: float = 0.0  # ... after this many seconds (wall clock, as roslaunch counts)
    critical: str = ""          # what the robot loses when the node dies ("navigation"); "" when not critical
    stops_motors: bool = False  # ``critical: true``: while the node is dead the network's motor lines are held
    group: str | None = None    # the process it runs in under ROS (its level's group when the level names one)

    @property
    def is_node(self) -> bool:
        """True for an existing ROS node (``node: package/type``) rather than a Module class."""
        return self.node is not None

    @property
    def package_type(self) -> tuple[str, str]:
        """An existing node's package and executable (``map_server/map_server`` -> ('map_server', 'map_server'))."""
        package, _, node_type = (self.node or "").partition("/")
        return package, node_type


@dataclass
class ArbiterSpec:
    """An inhibitor, suppressor or defaulter a level inserts on a lower line."""

    kind: str
    upper: str
    lower: str
    where: Where
    level: int
    time_constant: float | None = None  # in the network's time units
    given_name: str | None = None
    respawn: bool = False       # as for modules: roslaunch restarts the arbiter node when it dies
    respawn_delay: float = 0.0  # seconds
    group: str | None = None    # the process it runs in under ROS (default: its lower line's module's group)

    @property
    def name(self) -> str:
        """``<kind>_<module>_<port>`` unless the file names it."""
        return self.given_name or default_arbiter_name(self.kind, self.lower)


@dataclass
class LevelSpec:
    name: str
    index: int
    where: Where
    description: str = ""
    group: str | None = None  # the group of every module of the level that names none
    modules: list[ModuleSpec] = field(default_factory=list)
    arbiters: list[ArbiterSpec] = field(default_factory=list)


@dataclass
class ExternalSpec:
    """A topic the world outside the network reads or writes."""

    name: str
    type: str
    where: Where


@dataclass
class Network:
    name: str
    file: str
    where: Where
    description: str = ""
    time_unit: float = 1.0
    external: dict[str, ExternalSpec] = field(default_factory=dict)
    levels: list[LevelSpec] = field(default_factory=list)

    @property
    def top_level(self) -> int:
        """The index of the highest level."""
        return len(self.levels) - 1

    def modules(self, level: int | None = None) -> list[ModuleSpec]:
        """Modules of levels 0..level (all by default), in file order."""
        return [m for lv in self.levels[: self._upto(level)] for m in lv.modules]

    def arbiters(self, level: int | None = None) -> list[ArbiterSpec]:
        """Arbiters of levels 0..level in the order they are applied: by level, then as listed."""
        return [a for lv in self.levels[: self._upto(level)] for a in lv.arbiters]

    def module(self, name: str) -> ModuleSpec | None:
        """The module called `name`, or None."""
        return next((m for m in self.modules() if m.name == name), None)

    def _upto(self, level: int | None) -> int:
        return len(self.levels) if level is None else level + 1


def split_ref(text: str) -> tuple[str, str] | None:
    """``module.port`` as (module, port); None for a topic (ROS names contain no dots)."""
    if "." not in text:
        return None
    module, _, port = text.partition(".")
    return module, port


def default_arbiter_name(kind: str, lower: str) -> str:
    """``<kind>_<module>_<port>``: an arbiter's node name when the file gives none."""
    return f"{kind}_{lower.replace('.', '_')}"
