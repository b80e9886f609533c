"""dynamic_reconfigure for nodes whose parameters are only known at run time.

A C++ or Python node usually gets its reconfigure description from a ``.cfg`` file that catkin turns into a
``<Name>Config`` module at build time. A module node learns its parameters only when it loads the class named
by ``~class``, so the description is built here, at run time, from the same data: what
``dynamic_reconfigure.server.Server`` reads from a generated config module is ``config_description`` (one
group of parameter dicts: name, type, default, level, description, min, max, edit_method), ``defaults``,
``min``, ``max``, ``level``, ``type`` and ``all_level``. The server then offers the standard interface
(``~parameter_descriptions``, ``~parameter_updates``, ``~set_parameters``), so ``rqt_reconfigure`` and
``dynamic_reconfigure.client`` work unchanged.

Only scalar parameters (bool, int, float, str) can be reconfigured; lists and mappings stay fixed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Callable, Mapping

import rospy

from ..module import Param, ParamError

DR_TYPES = {bool: "bool", int: "int", float: "double", str: "str"}
INT32 = (-2**31, 2**31 - 1)  # dynamic_reconfigure's int is 32 bits
LEVEL = 1


@dataclass(frozen=True)
class Knob:
    """One reconfigurable parameter as dynamic_reconfigure describes it."""

    name: str
    type: str            # "bool", "int", "double" or "str"
    default: Any
    description: str
    min: Any
    max: Any

    @classmethod
    def of(cls, name: str, param: Param) -> "Knob | None":
        """The knob for a module Param, or None when its type cannot be reconfigured (a list or mapping)."""
        kind = DR_TYPES.get(param.type)
        if kind is None:
            return None
        low, high = {"bool": (False, True), "int": INT32, "double": (-math.inf, math.inf), "str": ("", "")}[kind]
        low = param.min if param.min is not None else low
        high = param.max if param.max is not None else high
        if kind == "double":
            low, high = float(low), float(high)
        return cls(name, kind, param.default, param.doc, low, high)


def description(knobs: list[Knob], defaults: Mapping[str, Any] | None = None) -> SimpleNamespace:
    """What dynamic_reconfigure's Server reads from a generated ``<Name>Config`` module, for these knobs.
    `defaults` (the values the node runs with) override the knobs' own defaults."""
    defaults = dict(defaults or {})
    parameters = [{"name": k.name, "type": k.type, "default": defaults.get(k.name, k.default), "level": LEVEL,
                   "description": k.description, "min": k.min, "max": k.max, "edit_method": ""} for k in knobs]
    group = {"name": "Default", "type": "", "state": True, "cstate": "true", "id": 0, "parent": 0,
             "parameters": parameters, "groups": []}
    return SimpleNamespace(
        config_description=group,
        defaults={p["name"]: p["default"] for p in parameters},
        min={p["name"]: p["min"] for p in parameters},
        max={p["name"]: p["max"] for p in parameters},
        level={p["name"]: LEVEL for p in parameters},
        type={p["name"]: p["type"] for p in parameters},
        all_level=LEVEL if parameters else 0)


def serve(knobs: list[Knob], current: Mapping[str, Any], apply: Callable[[dict[str, Any]], None],
          lock: Any, namespace: str = "") -> Any:
    """Start a dynamic_reconfigure server in this node's private namespace (or in `namespace`: a group's member's).

    `current` holds the values in effect; `apply(changes)` is called (holding `lock`, so never during a
    module's callback) with the knobs whose value changed, and may raise ParamError (or ValueError) to refuse
    them: the refusal is logged as an error naming the parameter and the values in effect are kept and
    reported back to the client. Returns the server (keep a reference for the node's life)."""
    from dynamic_reconfigure.server import Server

    names = [k.name for k in knobs]
    in_effect = {name: current[name] for name in names}

    def on_request(config: dict[str, Any], _level: int) -> dict[str, Any]:
        changes = {name: config[name] for name in names if config[name] != in_effect[name]}
        if changes:
            try:
                with lock:
                    apply(changes)
            except (ParamError, ValueError) as error:
                rospy.logerr("%s: reconfigure refused: %s", namespace or rospy.get_name(), error)
                changes = {}
            in_effect.update(changes)
        for name in names:
            config[name] = in_effect[name]
        return config

    # "~" as dynamic_reconfigure's namespace becomes "~/", which rospy resolves at the root: a parameter named as
    # another node (bumpturn's `turn`) read that node's whole namespace, a dict, and the node died at start.
    # Its default ("") is the node's own private namespace.
    return Server(description(knobs, in_effect), on_request, namespace="" if namespace == "~" else namespace)


def main_reconfigure(node: str, assignments: list[tuple[str, Any]], timeout: float) -> int:
    """``subsumption reconfigure NODE [NAME=VALUE ...]``: print the node's parameters after setting any given.
    A refused value (the node logs why) shows as the value kept."""
    import sys

    import rosgraph
    from dynamic_reconfigure.client import Client

    try:
        rosgraph.Master("/subsumption_reconfigure").getPid()
    except Exception:
        print(f"subsumption reconfigure: no ROS master at {rosgraph.get_master_uri()}", file=sys.stderr)
        return 1
    rospy.init_node("subsumption_reconfigure", anonymous=True, disable_rosout=True)
    try:
        client = Client(node, timeout=timeout)
    except rospy.ROSException:
        print(f"subsumption reconfigure: {node} offers no dynamic_reconfigure service "
              f"({node}/set_parameters) within {timeout:g} s", file=sys.stderr)
        return 1
    known = {d["name"]: d for d in client.get_parameter_descriptions()}
    unknown = [name for name, _ in assignments if name not in known]
    if unknown:
        print(f"subsumption reconfigure: {node} has no reconfigurable parameter {', '.join(unknown)} "
              f"(it has: {', '.join(known) or 'none'})", file=sys.stderr)
        return 1
    from dynamic_reconfigure import DynamicReconfigureParameterException

    wanted = dict(assignments)
    try:
        config = client.update_configuration(wanted) if wanted else client.get_configuration(timeout)
    except DynamicReconfigureParameterException as error:  # a value the parameter's type cannot take
        print(f"subsumption reconfigure: {node}: {error}", file=sys.stderr)
        return 1
    refused = [name for name, value in wanted.items() if config[name] != value]
    for name in known:
        mark = "  (refused: see the node's log)" if name in refused else ""
        print(f"{node}/{name}: {config[name]!r}{mark}")
    return 1 if refused else 0
