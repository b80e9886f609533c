"""A network's motor lines, and who can stop them: what ``critical: true`` needs of the wiring.

A module marked ``critical: true`` is one the robot cannot drive without: while its node is dead the network's
motor lines are held (subsumption.ros.motor_hold). A motor line is an external topic of type
``geometry_msgs/Twist`` an output line is delivered to (``cmd_vel``); the node that publishes it (the last
arbiter on the line, or the module itself when no arbiter sits on it) is the one that holds it, so nothing from
any level passes while the hold lasts. Other external lines (an alarm, speech, goals) are never held: the
alarm must still be heard while the robot stands.

An existing ROS node (``node: package/type``) that publishes a motor line itself cannot be told to hold it, and
a network with no motor line has nothing to stop: with a ``critical: true`` module either is an error
(:func:`motor_errors`), so the promise of the file is never silently not kept.
"""
from __future__ import annotations

from dataclasses import dataclass

from .spec import NetworkError
from .wiring import Wiring

MOTOR_TYPE = "geometry_msgs/Twist"


@dataclass(frozen=True)
class MotorLine:
    """One motor line: the external topic (relative to the robot's namespace) and the node that publishes it."""

    topic: str
    writer: str   # a module or arbiter name
    kind: str     # "module" or "arbiter"


def motor_lines(wiring: Wiring) -> list[MotorLine]:
    """The network's motor lines at the wired level, each with its publisher, in the wiring's order."""
    external = wiring.network.external
    return [MotorLine(wire.topic, wire.source.name, wire.source.kind) for wire in wiring.wires
            if wire.target.kind == "external" and wire.target.name in external
            and external[wire.target.name].type == MOTOR_TYPE]


def stopping_modules(wiring: Wiring) -> list[str]:
    """The wired modules marked ``critical: true``: the death of any of them stops the motors."""
    return [m.name for m in wiring.modules if m.spec.stops_motors]


def motor_errors(wiring: Wiring) -> list[NetworkError]:
    """``critical: true`` that could not be kept: no motor line to stop, or one published by an existing node."""
    stopping = [m for m in wiring.modules if m.spec.stops_motors]
    if not stopping:
        return []
    lines = motor_lines(wiring)
    first = stopping[0]
    if not lines:
        return [NetworkError(first.spec.where, f"module {first.name}: critical: true stops the motors, but network "
                                               f"{wiring.network.name} delivers no {MOTOR_TYPE} to an external topic "
                                               f"at level {wiring.level}: name what is lost instead "
                                               f"(critical: WHAT)")]
    modules = {m.name: m for m in wiring.modules}
    errors = []
    for line in lines:
        writer = modules.get(line.writer) if line.kind == "module" else None
        if writer is not None and writer.spec.is_node:
            errors.append(NetworkError(writer.spec.where,
                                       f"module {writer.name}: existing node {writer.spec.node} publishes motor "
                                       f"line {line.topic} itself, so it cannot be held while a critical: true "
                                       f"module ({first.name}) is dead: put an arbiter on the line"))
    return errors
