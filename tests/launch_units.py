"""The modules and arbiters of a launch file as roslaunch loaded it, whether each is a node of its own or a member
of a group node (a process per level): what tests of the launch structure read, whichever way a network runs."""
from __future__ import annotations

from types import SimpleNamespace

import roslaunch.config
import rosgraph.names

ARBITER_LINES = ("upper", "lower", "output")


def launch_units(config: roslaunch.config.ROSLaunchConfig) -> list:
    """Each node that is not a group as roslaunch loaded it, and each member of a group node with the name,
    namespace, type and remappings (``remap_args``) the group gives it from its ``~members`` (a module's
    ``remap``; an arbiter's upper, lower and output lines; its type the arbiter's kind, else "module")."""
    found = []
    for node in config.nodes:
        if node.type != "group":
            found.append(node)
            continue
        members = config.params[rosgraph.names.ns_join(rosgraph.names.ns_join(node.namespace, node.name), "members")]
        for entry in members.value:
            pairs = entry["remap"] if "remap" in entry else {line: entry[line] for line in ARBITER_LINES}
            found.append(SimpleNamespace(name=entry["name"], namespace=node.namespace,
                                         type=entry.get("arbiter", "module"), remap_args=list(pairs.items())))
    return found
