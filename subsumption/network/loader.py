"""Reading a network file into a :class:`~subsumption.network.spec.Network`, with a line for every item.

PyYAML's ``compose`` keeps the node graph with its marks; this module walks it, turning each mapping into a
spec dataclass and remembering the line each item (and each bad value) came from. Structural problems
(unknown keys, wrong kinds of value, missing names) are all collected and raised together as
:class:`~subsumption.network.spec.NetworkInvalid`; what needs imports or cross-references is the checker's job.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import yaml

from .. import yamlfile
from .spec import (ArbiterSpec, ExternalSpec, InputSpec, LevelSpec, ModuleSpec, Network, NetworkError,
                   NetworkInvalid, OutputSpec, Where, default_arbiter_name)

ARBITER_KINDS = ("inhibitor", "suppressor", "defaulter")

TOP_KEYS = {"name", "description", "time_unit", "external", "levels"}
LEVEL_KEYS = {"name", "description", "modules", "arbiters", "group"}
RESPAWN_KEYS = {"respawn", "respawn_delay"}
MODULE_KEYS = {"name", "class", "node", "args", "inputs", "outputs", "params", "remap", "critical", "group"} | RESPAWN_KEYS
INPUT_KEYS = {"from", "type", "topic"}
OUTPUT_KEYS = {"to", "type", "topic"}
ARBITER_KEYS = {"kind", "upper", "lower", "time_constant", "name", "group"} | RESPAWN_KEYS
GROUP_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")  # a ROS base name: the group's node is called so


class _Reader:
    """Walks composed YAML nodes of one file and collects every structural error it meets."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.errors: list[NetworkError] = []

    def where(self, node: yaml.Node) -> Where:
        return Where(self.file, node.start_mark.line + 1)

    def error(self, node: yaml.Node, message: str) -> None:
        self.errors.append(NetworkError(self.where(node), message))

    def value(self, node: yaml.Node) -> Any:
        """The plain Python value of a node (numbers, strings, lists, dicts) as yaml.safe_load gives it."""
        return yamlfile.construct(node, self.file)

    def mapping(self, node: yaml.Node, what: str, allowed: set[str]) -> dict[str, yaml.Node]:
        """A mapping's entries by key; unknown and repeated keys are errors naming `what`."""
        if not isinstance(node, yaml.MappingNode):
            self.error(node, f"{what}: expected a mapping, got {self._kind(node)}")
            return {}
        entries: dict[str, yaml.Node] = {}
        for key_node, value_node in node.value:
            key = str(self.value(key_node))
            if key in entries:
                self.error(key_node, f"{what}: key {yamlfile.brief(key)} given twice")
            elif allowed and key not in allowed:
                self.error(key_node, f"{what}: unknown key {yamlfile.brief(key)} (expected one of {', '.join(sorted(allowed))})")
            else:
                entries[key] = value_node
        return entries

    def pairs(self, node: yaml.Node, what: str) -> list[tuple[str, yaml.Node, yaml.Node]]:
        """(key, key node, value node) of a mapping whose keys are names chosen by the user."""
        if not isinstance(node, yaml.MappingNode):
            self.error(node, f"{what}: expected a mapping, got {self._kind(node)}")
            return []
        seen: set[str] = set()
        result = []
        for key_node, value_node in node.value:
            key = str(self.value(key_node))
            if key in seen:
                self.error(key_node, f"{what}: {yamlfile.brief(key)} given twice")
                continue
            seen.add(key)
            result.append((key, key_node, value_node))
        return result

    def sequence(self, node: yaml.Node, what: str) -> list[yaml.Node]:
        if isinstance(node, yaml.ScalarNode) and node.tag.endswith(":null"):
            return []
        if not isinstance(node, yaml.SequenceNode):
            self.error(node, f"{what}: expected a list, got {self._kind(node)}")
            return []
        return node.value

    def text(self, node: yaml.Node | None, what: str, default: str | None = None) -> str | None:
        if node is None:
            return default
        value = self.value(node) if isinstance(node, yaml.ScalarNode) else None
        if not isinstance(value, str) or not value:
            self.error(node, f"{what}: expected a non-empty string, got {self._describe(node)}")
            return default
        return value

    def number(self, node: yaml.Node | None, what: str) -> float | None:
        if node is None:
            return None
        value = self.value(node) if isinstance(node, yaml.ScalarNode) else None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.error(node, f"{what}: expected a finite number, got {self._describe(node)}")
            return None
        return float(value)

    def boolean(self, node: yaml.Node | None, what: str) -> bool:
        if node is None:
            return False
        value = self.value(node) if isinstance(node, yaml.ScalarNode) else None
        if not isinstance(value, bool):
            self.error(node, f"{what}: expected true or false, got {self._describe(node)}")
            return False
        return value

    def respawn(self, entries: dict[str, yaml.Node], what: str, item: ModuleSpec | ArbiterSpec) -> None:
        """``respawn`` (roslaunch restarts the node when it dies) and ``respawn_delay`` (seconds, >= 0)."""
        item.respawn = self.boolean(entries.get("respawn"), f"{what}: respawn")
        if "respawn_delay" in entries:
            delay = self.number(entries["respawn_delay"], f"{what}: respawn_delay")
            if delay is not None and delay < 0:
                self.error(entries["respawn_delay"], f"{what}: respawn_delay must be >= 0 seconds, got {delay:g}")
            elif delay is not None:
                item.respawn_delay = delay
            if not item.respawn:
                self.error(entries["respawn_delay"], f"{what}: respawn_delay without respawn: true")

    def critical(self, node: yaml.Node | None, what: str, name: str) -> tuple[str, bool]:
        """``critical``: (what the robot loses, whether its death stops the motors).

        ``true`` (a YAML boolean): the robot cannot move safely without the module; while its node is dead the
        network's motor lines are held (a zero command, then nothing: see docs/faults.md), and the robot loses
        the module itself ("NAME lost"). A few words name what the robot loses (``critical: navigation`` ->
        "navigation lost") and leave the motors to the robot's own modules. ``false``: not critical."""
        if node is None:
            return "", False
        value = self.value(node) if isinstance(node, yaml.ScalarNode) else None
        if isinstance(value, bool):
            return (name, True) if value else ("", False)
        if isinstance(value, str) and value.strip() and value.isprintable() and len(value) <= 40:
            return value.strip(), False
        self.error(node, f"{what}: critical: expected true (its death stops the motors), false or what the robot "
                         f"loses (e.g. navigation), got {self._describe(node)}")
        return "", False

    def group(self, entries: dict[str, yaml.Node], what: str) -> str | None:
        """``group``: the name of the process (one ROS node) the item runs in; a ROS base name."""
        node = entries.get("group")
        name = self.text(node, f"{what}: group")
        if node is not None and name is not None and not GROUP_NAME.match(name):
            self.error(node, f"{what}: group must be a ROS node name (a letter, then letters, digits or _), "
                             f"got {yamlfile.brief(name)}")
            return None
        return name

    def _describe(self, node: yaml.Node) -> str:
        return yamlfile.brief(self.value(node)) if isinstance(node, yaml.ScalarNode) else self._kind(node)

    def _kind(self, node: yaml.Node) -> str:
        return {yaml.MappingNode: "a mapping", yaml.SequenceNode: "a list"}.get(
            type(node)) or yamlfile.brief(self.value(node))

    # The file's items -----------------------------------------------------------------------------
    def network(self, root: yaml.Node) -> Network:
        top = self.mapping(root, "network", TOP_KEYS)
        name = self.text(top.get("name"), "network name", "") or ""
        if "name" not in top:
            self.error(root, "network: 'name' is required")
        network = Network(name=name, file=self.file, where=self.where(root),
                          description=self.text(top.get("description"), "description", "") or "")
        if "time_unit" in top:
            unit = self.number(top["time_unit"], "time_unit")
            if unit is not None and not unit > 0:
                self.error(top["time_unit"], f"time_unit must be > 0 seconds, got {unit:g}")
            elif unit is not None:
                network.time_unit = unit
        if "external" in top:
            for topic, key_node, value_node in self.pairs(top["external"], "external"):
                msg_type = self.text(value_node, f"external topic {topic}: type")
                if msg_type:
                    network.external[topic] = ExternalSpec(topic, msg_type, self.where(key_node))
        if "levels" not in top:
            self.error(root, f"network {name}: 'levels' is required (a list, level 0 first)")
        else:
            for index, level_node in enumerate(self.sequence(top["levels"], "levels")):
                network.levels.append(self.level(level_node, index))
        return network

    def level(self, node: yaml.Node, index: int) -> LevelSpec:
        entries = self.mapping(node, f"level {index}", LEVEL_KEYS)
        level = LevelSpec(name=self.text(entries.get("name"), f"level {index}: name", f"level {index}") or "",
                          index=index, where=self.where(node),
                          description=self.text(entries.get("description"), f"level {index}: description", "")
                          or "")
        level.group = self.group(entries, f"level {level.name}")
        for module_node in self.sequence(entries["modules"], f"level {level.name}: modules") \
                if "modules" in entries else []:
            module = self.module(module_node, index)
            if module is not None:
                level.modules.append(module)
        for arbiter_node in self.sequence(entries["arbiters"], f"level {level.name}: arbiters") \
                if "arbiters" in entries else []:
            arbiter = self.arbiter(arbiter_node, index)
            if arbiter is not None:
                level.arbiters.append(arbiter)
        return level

    @staticmethod
    def _peek(node: yaml.Node, key: str) -> str | None:
        """A mapping's scalar value at `key` before the mapping is checked, so that errors can name the item."""
        if isinstance(node, yaml.MappingNode):
            for key_node, value_node in node.value:
                if isinstance(key_node, yaml.ScalarNode) and key_node.value == key \
                        and isinstance(value_node, yaml.ScalarNode):
                    return value_node.value
        return None

    def module(self, node: yaml.Node, level: int) -> ModuleSpec | None:
        peeked = self._peek(node, "name")
        entries = self.mapping(node, f"module {peeked}" if peeked else f"module at level {level}", MODULE_KEYS)
        if not entries:
            return None
        name = self.text(entries.get("name"), "module name")
        if "name" not in entries:
            self.error(node, "module: 'name' is required")
        if not name:
            return None
        what = f"module {name}"
        module = ModuleSpec(name=name, level=level, where=self.where(node),
                            class_path=self.text(entries.get("class"), f"{what}: class"),
                            node=self.text(entries.get("node"), f"{what}: node"),
                            args=self.text(entries.get("args"), f"{what}: args", "") or "")
        if ("class" in entries) == ("node" in entries):
            self.error(node, f"{what}: give exactly one of 'class' (package.module:Class) or 'node' (package/type)")
        self.respawn(entries, what, module)
        module.critical, module.stops_motors = self.critical(entries.get("critical"), what, name)
        module.group = self.group(entries, what)
        if module.group is not None and "node" in entries:
            self.error(entries["group"], f"{what}: an existing ROS node (node: {module.node}) runs in a process of "
                                         f"its own and cannot join group {module.group}")
        if "params" in entries:
            module.params = {key: self.value(value) for key, _, value in self.pairs(entries["params"],
                                                                                      f"{what}: params")}
        if "remap" in entries:
            module.remap = {key: self.text(value, f"{what}: remap {key}") or ""
                            for key, _, value in self.pairs(entries["remap"], f"{what}: remap")}
        for port, key_node, value_node in self.pairs(entries.get("inputs", _EMPTY), f"{what}: inputs"):
            module.inputs[port] = self.input(value_node, key_node, f"{what}: input {port}", port)
        for port, key_node, value_node in self.pairs(entries.get("outputs", _EMPTY), f"{what}: outputs"):
            module.outputs[port] = self.output(value_node, key_node, f"{what}: output {port}", port)
        return module

    def input(self, node: yaml.Node, key_node: yaml.Node, what: str, port: str) -> InputSpec:
        if isinstance(node, yaml.MappingNode):
            entries = self.mapping(node, what, INPUT_KEYS)
            if "from" not in entries:
                self.error(node, f"{what}: 'from' is required (module.output or an external topic)")
            return InputSpec(port, self.text(entries.get("from"), f"{what}: from", "") or "", self.where(key_node),
                             type=self.text(entries.get("type"), f"{what}: type"),
                             topic=self.text(entries.get("topic"), f"{what}: topic"))
        return InputSpec(port, self.text(node, what, "") or "", self.where(key_node))

    def output(self, node: yaml.Node, key_node: yaml.Node, what: str, port: str) -> OutputSpec:
        if isinstance(node, yaml.MappingNode):
            entries = self.mapping(node, what, OUTPUT_KEYS)
            return OutputSpec(port, self.where(key_node), deliver=self.text(entries.get("to"), f"{what}: to"),
                              type=self.text(entries.get("type"), f"{what}: type"),
                              topic=self.text(entries.get("topic"), f"{what}: topic"))
        if isinstance(node, yaml.ScalarNode) and node.tag.endswith(":null"):
            return OutputSpec(port, self.where(key_node))
        return OutputSpec(port, self.where(key_node), deliver=self.text(node, what))

    def arbiter(self, node: yaml.Node, level: int) -> ArbiterSpec | None:
        lower = self._peek(node, "lower")
        peeked = self._peek(node, "name") or (default_arbiter_name(self._peek(node, "kind") or "arbiter", lower)
                                               if lower else None)
        entries = self.mapping(node, f"arbiter {peeked}" if peeked else f"arbiter at level {level}", ARBITER_KEYS)
        if not entries:
            return None
        kind = self.text(entries.get("kind"), "arbiter kind", "") or ""
        lower = self.text(entries.get("lower"), "arbiter lower", "") or ""
        arbiter = ArbiterSpec(kind=kind, upper="", lower=lower, where=self.where(node), level=level,
                              given_name=self.text(entries.get("name"), "arbiter name"))
        what = f"arbiter {arbiter.name}"
        if kind and kind not in ARBITER_KINDS:
            self.error(entries["kind"], f"{what}: kind must be one of {', '.join(ARBITER_KINDS)}, got {yamlfile.brief(kind)}")
        for key in ("kind", "upper", "lower"):
            if key not in entries:
                self.error(node, f"{what}: '{key}' is required")
        arbiter.upper = self.text(entries.get("upper"), f"{what}: upper", "") or ""
        self.respawn(entries, what, arbiter)
        arbiter.group = self.group(entries, what)
        if "time_constant" not in entries:
            self.error(node, f"{what}: time_constant is required (in time units of the file)")
        else:
            arbiter.time_constant = self.number(entries["time_constant"], f"{what}: time_constant")
            if arbiter.time_constant is not None and not arbiter.time_constant > 0:
                self.error(entries["time_constant"],
                           f"{what}: time_constant must be > 0, got {arbiter.time_constant:g}")
                arbiter.time_constant = None
        return arbiter


_EMPTY = yaml.MappingNode("tag:yaml.org,2002:map", [])


def read(text: str, file: str) -> tuple[Network | None, list[NetworkError]]:
    """The network described by `text` (the contents of `file`) as far as it could be read, and every structural
    problem met; the checker goes on with the partial network so that it can report all problems at once.
    A file that is not usable YAML at all (see :mod:`subsumption.yamlfile`) is one error naming its line."""
    try:
        root = yamlfile.compose(text, file)
        if root is None:
            return None, [NetworkError(Where(file, 1), "empty network file")]
        reader = _Reader(file)
        network = reader.network(root)
    except yamlfile.YamlFileError as error:
        return None, [NetworkError(Where(file, error.line or 1), error.problem)]
    return network, sorted(reader.errors, key=lambda error: error.where.line)


def read_file(path: str | Path) -> tuple[Network | None, list[NetworkError]]:
    """:func:`read` for the file at `path`; errors name the file as given (``FILE:LINE: ...``)."""
    file = str(path)
    try:
        text = yamlfile.read_text(path, "network file")
    except yamlfile.YamlFileError as error:
        return None, [NetworkError(Where(file, 0), error.problem)]
    return read(text, file)


def parse(text: str, file: str) -> Network:
    """The network described by `text`; raises NetworkInvalid listing every structural problem."""
    network, errors = read(text, file)
    if errors or network is None:
        raise NetworkInvalid(errors)
    return network


def load(path: str | Path) -> Network:
    """The network file at `path`; raises NetworkInvalid listing every structural problem, each as
    ``FILE:LINE: what`` with the file named as given."""
    network, errors = read_file(path)
    if errors or network is None:
        raise NetworkInvalid(errors)
    return network
