"""Run any module class as its own ROS node::

    rosrun subsumption module __name:=avoid _class:=subsumption.examples.avoid:Avoid \\
        heading:=/wander/heading force:=/feelforce/force

Inputs subscribe their own (relative) names, outputs publish ``~<output>``, parameters are the node's private
parameters; remap and set them the usual ROS ways. ``~class`` is required. ``~motor_hold`` (from ``subsumption
launch``, when the module itself publishes a motor line of a network with a ``critical: true`` module) holds that
line while such a module is dead (subsumption.ros.motor_hold).

At start every parameter is checked against its declared type (a bad one ends the node with status 2 and an
error naming it, e.g. ``/wander/interval must be a number, got 'abc'``) and written back to the parameter
server, so ``rosparam list`` shows all of them with the values in use. While it runs, the scalar parameters
can be changed through dynamic_reconfigure (``rqt_reconfigure``, ``rosrun dynamic_reconfigure
dynparam set /wander interval 3.0``), and the node reports its health on ``/diagnostics``.

Inputs are subscribed as ``rospy.AnyMsg`` and checked before they are decoded: a publisher of the wrong type is
refused, counted and logged once, and a message with NaN or inf in a scalar field is dropped and counted
(docs/faults.md); ``rostopic info`` shows such subscribers with type ``*``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import rospy

from ..loading import ClassPathError, load_module_class
from ..module import Module, ParamError
from ..runtime import NodeHandle
from .diagnostics import ModuleDiagnostics
from .motor_hold import MotorHoldError, read_motor_hold
from .reconfigure import Knob, serve
from .runtime import RosNodeHandle, init_node

PACKAGE_DIR = Path(__file__).resolve().parents[1]  # where this subsumption was imported from (logged at start)


def _fail(node_name: str, error: Exception) -> int:
    rospy.logfatal("%s: %s", node_name, error)
    print(f"{node_name}: error: {error}", file=sys.stderr, flush=True)
    return 2


def serve_params(node: NodeHandle, module: Module, namespace: str = ""):
    """The module's scalar parameters on dynamic_reconfigure (in `namespace`: a group's member's own);
    changes go through Module.reconfigure."""
    knobs = [knob for name, param in module.interface.params.items() if (knob := Knob.of(name, param))]
    if not knobs:
        return None
    return serve(knobs, module._params, module.reconfigure, node.lock, namespace)  # type: ignore[attr-defined]


def main(argv: list[str] | None = None) -> int:
    """Run ``rosrun subsumption module _class:=package.module:Class`` until shutdown; exit status 2 on a bad class or
    parameter."""
    node = init_node("module", argv=argv if argv is not None else sys.argv)
    class_path = rospy.get_param("~class", None)
    try:
        if not class_path:
            raise ClassPathError(f"{rospy.resolve_name('~class')} is required (package.module:Class)")
        module_class = load_module_class(class_path)
        node.hold = read_motor_hold()  # a motor line this module publishes itself (no arbiter on it)
        with node.lock:  # no callback may run before the module is fully built
            module = module_class(node)
    except MotorHoldError as error:
        return _fail(node.name, error)
    except (ClassPathError, ParamError) as error:
        if isinstance(error.__cause__, ModuleNotFoundError):
            error = ClassPathError(f"{error} (this node runs {sys.executable}, which lacks it: see docs/ros.md, "
                                   f"\"catkin workspace\")")
        return _fail(node.name, error)
    keep = (serve_params(node, module), ModuleDiagnostics(node, module, class_path))
    rospy.loginfo("%s: running %s (subsumption from %s)", node.name, class_path, PACKAGE_DIR)
    rospy.spin()
    del keep
    return 0
