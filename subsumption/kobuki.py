"""The Kobuki base's event messages (kobuki_msgs/BumperEvent, CliffEvent, WheelDropEvent) without kobuki_msgs.

A TurtleBot 2's driver reports its bumpers, cliff sensors and wheel drops as events on
``/mobile_base/events/{bumper,cliff,wheel_drop}``, typed by kobuki_msgs, which Debian does not package. ROS only
needs a class whose type name, md5sum and definition match the driver's to read and write those topics, so
the classes are built here with genpy's generator (the one rospy's own message packages come from) from the
definitions shipped in ``subsumption/msg/kobuki_msgs/`` (copied unchanged from yujinrobot/kobuki_msgs 0.7.0).
The generated source is compiled in memory: ``genpy.dynamic`` would write each class to a directory under /tmp
that only a clean exit removes, and a node stopped by a signal or a respawn would leave it behind.
If a real kobuki_msgs is installed, its classes are used instead: they are the same messages.

Each event carries the new state of one sensor (not a bitmask): ``BumperEvent(bumper=LEFT|CENTER|RIGHT,
state=RELEASED|PRESSED)``, ``CliffEvent(sensor=LEFT|CENTER|RIGHT, state=FLOOR|CLIFF, bottom)``,
``WheelDropEvent(wheel=LEFT|RIGHT, state=RAISED|DROPPED)``. The driver sends one on each change only.
"""
from __future__ import annotations

import types
from pathlib import Path

import genmsg.msg_loader
from genpy.generator import msg_generator

PACKAGE = "kobuki_msgs"
DEFINITIONS = Path(__file__).resolve().parent / "msg" / PACKAGE
NAMES = ("BumperEvent", "CliffEvent", "WheelDropEvent")


def definition(name: str) -> str:
    """The shipped .msg text of kobuki_msgs/<name>."""
    return (DEFINITIONS / f"{name}.msg").read_text()


def _generated_class(name: str) -> type:
    """The genpy class of kobuki_msgs/<name>, its source generated and compiled in memory (the shipped messages
    depend on no other message, so one definition is the whole input)."""
    full_name = f"{PACKAGE}/{name}"
    context = genmsg.msg_loader.MsgContext.create_default()
    spec = genmsg.msg_loader.load_msg_from_string(context, definition(name), full_name)
    context.register(full_name, spec)
    source = "\n".join(msg_generator(context, spec, {}))
    module = types.ModuleType(f"{PACKAGE}.msg._{name}")  # where a catkin-built kobuki_msgs keeps the class
    exec(compile(source, f"<{full_name}.msg>", "exec"), module.__dict__)
    return getattr(module, name)


def _generated() -> dict[str, type]:
    """genpy classes for the shipped definitions, by short name."""
    return {name: _generated_class(name) for name in NAMES}


def _installed() -> dict[str, type] | None:
    try:
        import kobuki_msgs.msg as installed  # type: ignore[import-not-found]
    except ImportError:
        return None
    return {name: getattr(installed, name) for name in NAMES}


_CLASSES = _installed() or _generated()
BumperEvent: type = _CLASSES["BumperEvent"]
CliffEvent: type = _CLASSES["CliffEvent"]
WheelDropEvent: type = _CLASSES["WheelDropEvent"]

# the topics of the kobuki driver (kobuki_node as turtlebot_bringup's minimal.launch starts it, nodelet mobile_base)
BUMPER_TOPIC = "/mobile_base/events/bumper"
CLIFF_TOPIC = "/mobile_base/events/cliff"
WHEEL_DROP_TOPIC = "/mobile_base/events/wheel_drop"
VELOCITY_TOPIC = "/mobile_base/commands/velocity"

# the project's bumper bitmask (std_msgs/UInt8 on `bumper`: 1 left, 2 centre, 4 right) for each Kobuki bumper
BUMPER_BITS = {0: 1, 1: 2, 2: 4}


def bumper_events(before: int, after: int) -> list:
    """The BumperEvents a Kobuki sends when its bumper bitmask (1 left, 2 centre, 4 right) goes from `before` to
    `after`: one per bumper whose state changed, in the order left, centre, right."""
    return [BumperEvent(bumper=index, state=BumperEvent.PRESSED if after & bit else BumperEvent.RELEASED)
            for index, bit in BUMPER_BITS.items() if (before ^ after) & bit]


__all__ = ["BumperEvent", "CliffEvent", "WheelDropEvent", "BUMPER_TOPIC", "CLIFF_TOPIC", "WHEEL_DROP_TOPIC",
           "VELOCITY_TOPIC", "BUMPER_BITS", "bumper_events", "definition"]
