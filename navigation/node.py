"""Runs one navigation module as its own ROS node, with the topic names ROS users expect by default.

``rosrun subsumption slam`` and ``rosrun subsumption amcl`` use it: like ``rosrun subsumption module
_class:=...``, but the outputs land where gmapping's and amcl's do (``/map``, ``/amcl_pose``, ...) and the
inputs read ``/scan``, ``/odom``, ... unless the command line remaps them.
"""
from __future__ import annotations

import sys
from typing import Callable

from subsumption.module import Module


def run_node(module_class: type[Module], name: str, default_remaps: dict[str, str],
             on_shutdown: Callable[[Module], None] | None = None, argv: list[str] | None = None) -> int:
    """Run `module_class` as the ROS node `name` with its default remappings until shutdown; the exit status."""
    import rospy

    from subsumption.ros.runtime import init_node

    argv = list(sys.argv if argv is None else argv)
    given = {arg.split(":=", 1)[0] for arg in argv[1:] if ":=" in arg}
    argv += [f"{src}:={dst}" for src, dst in default_remaps.items() if src not in given]
    node = init_node(name, argv=argv)
    with node.lock:  # no callback may run before the module is fully built
        module = module_class(node)
    if on_shutdown is not None:
        rospy.on_shutdown(lambda: on_shutdown(module))
    rospy.loginfo("%s: running %s.%s", node.name, module_class.__module__, module_class.__qualname__)
    rospy.spin()
    return 0
