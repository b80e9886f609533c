"""Which process each module and arbiter runs in under ROS: module groups (ROS 1's nodelets, ROS 2's composition).

A group is one ROS node process hosting several modules and arbiters (:mod:`subsumption.ros.group`): wires
inside it are delivered in-process, wires leaving it are ROS topics. Where the grouping comes from (``mode``):

- ``file``: the network file's ``group:`` keys (a level's ``group`` is that of each module of the level that
  names none); everything else runs one process per module, as without groups;
- ``level``: one group per level, ``<network>_level<N>`` (the file's ``group:`` keys are ignored);
- ``none``: one process per module and arbiter, whatever the file says.

An arbiter runs with the line it sits on: in the group of the module whose line its ``lower`` names, unless it
names a group of its own. That is Brooks' fault boundary: level 4's suppressor on level 0's motor line lives in
level 0's process, so when level 4's process dies the suppressor's upper line only falls silent and levels 0-3
drive on through it (in level 4's process, the whole motor line would die with it). Existing ROS nodes
(``node:``) always run in a process of their own.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .spec import NetworkError, NetworkInvalid, split_ref
from .wiring import Wiring

MODES = ("file", "level", "none")


@dataclass
class Groups:
    """The grouping of one wiring: each member's group (None: a process of its own), and each group's members
    (modules first, in file order, then arbiters in the order they are applied)."""

    of: dict[str, str | None] = field(default_factory=dict)
    members: dict[str, list[str]] = field(default_factory=dict)

    def group_of(self, name: str) -> str | None:
        return self.of.get(name)


def level_group(network_name: str, level: int) -> str:
    """The group a level runs in with ``--groups level``."""
    return f"{network_name}_level{level}"


def group_wiring(wiring: Wiring, mode: str = "file") -> Groups:
    """The groups of `wiring` in `mode` (see the module's docstring). NetworkInvalid when a group has the name of
    a module or arbiter (both would be ROS nodes of one name)."""
    if mode not in MODES:
        raise ValueError(f"groups: expected one of {', '.join(MODES)}, got {mode!r}")
    network = wiring.network
    groups = Groups()
    for module in wiring.modules:
        spec = module.spec
        if mode == "none" or spec.is_node:
            group = None
        elif mode == "level":
            group = level_group(network.name, spec.level)
        else:
            group = spec.group or network.levels[spec.level].group
        groups.of[module.name] = group
    for arbiter in wiring.arbiters:
        spec = arbiter.spec
        lower = split_ref(spec.lower)
        line_group = groups.of.get(lower[0]) if lower else None
        if mode == "none":
            group = None
        elif mode == "file" and spec.group:
            group = spec.group
        else:
            group = line_group
        groups.of[arbiter.name] = group
    for name, group in groups.of.items():
        if group is not None:
            groups.members.setdefault(group, []).append(name)
    errors = []
    for module in wiring.modules:
        if module.name in groups.members:
            errors.append(NetworkError(module.spec.where, f"module {module.name}: a group has the same name; "
                                                          f"a group is a ROS node, so its name must be its own"))
    for arbiter in wiring.arbiters:
        if arbiter.name in groups.members:
            errors.append(NetworkError(arbiter.spec.where, f"arbiter {arbiter.name}: a group has the same name; "
                                                           f"a group is a ROS node, so its name must be its own"))
    if errors:
        raise NetworkInvalid(errors)
    return groups
