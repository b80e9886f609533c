"""Run any module class as its own ROS node::

    rosrun subsumption module __name:=avoid _class:=subsumption.examples.avoid:Avoid \\
        heading:=/wander/heading force:=/feelforce/force

Inputs subscribe their own (relative) names, outputs publish ``~<output>``, parameters are the node's private
parameters; remap and set them the usual ROS ways. ``~class`` is required.
"""
from __future__ import annotations

import sys

import rospy

from ..loading import ClassPathError, load_module_class
from .runtime import init_node


def main(argv: list[str] | None = None) -> int:
    node = init_node("module", argv=argv if argv is not None else sys.argv)
    class_path = rospy.get_param("~class", None)
    try:
        if not class_path:
            raise ClassPathError(f"{rospy.resolve_name('~class')} is required (package.module:Class)")
        module_class = load_module_class(class_path)
    except ClassPathError as error:
        rospy.logfatal("%s: %s", node.name, error)
        print(f"{node.name}: error: {error}", file=sys.stderr)
        return 2
    with node.lock:  # no callback may run before the module is fully built
        module_class(node)
    rospy.loginfo("%s: running %s", node.name, class_path)
    rospy.spin()
    return 0
