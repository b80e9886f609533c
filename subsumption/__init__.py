"""Brooks' subsumption architecture on ROS 1.

The public pieces a robot is built from:

- :class:`Module`, :class:`Input`, :class:`Output`, :class:`Param`: a box of the network, its lines and knobs;
- :class:`AFSM` and its four kinds of state (:class:`OutputState`, :class:`SideEffect`,
  :class:`ConditionalDispatch`, :class:`EventDispatch`): Brooks' augmented finite state machines;
- :class:`ArbiterRule` / :class:`ArbiterKind`: the inhibitor, suppressor and defaulter timing rule;
- :class:`LocalRuntime`: many modules in one process on a simulated clock (fast, reproducible);
  under ROS each module is its own node (``rosrun subsumption module _class:=pkg.mod:Class``);
- :mod:`subsumption.network`: network files (levels, modules, arbiters), checked, drawn and launched;
- the shared kernel: :mod:`subsumption.planar` (wrap, yaw, quaternion, SE(2) poses and their messages),
  :mod:`subsumption.pinhole` (one camera model from K, a field of view or a CameraInfo) and
  :class:`InputFileError` (the one error for a bad network, world, map or goal file).

The core imports no simulator and no robot; rospy is imported only under :mod:`subsumption.ros`.
"""
from .afsm import AFSM, ConditionalDispatch, EventDispatch, MachineError, OutputState, SideEffect
from .arbiter import Arbiter
from .arbitration import ArbiterKind, ArbiterRule
from .errors import InputFileError
from .local import LocalRuntime, TopicTypeError
from .module import Input, Module, Output, Param, ParamError
from .runtime import NodeHandle

__all__ = [
    "AFSM", "Arbiter", "ArbiterKind", "ArbiterRule", "ConditionalDispatch", "EventDispatch", "Input",
    "InputFileError", "LocalRuntime", "MachineError", "Module", "NodeHandle", "Output", "OutputState", "Param", "ParamError",
    "SideEffect", "TopicTypeError",
]
