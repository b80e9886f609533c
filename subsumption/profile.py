"""Robot profiles: what a real base's drivers publish and take, in which frames, at which rates, within which
limits. One short YAML file per robot (``profiles/<name>.yaml`` in the package), read by the motor guard (its
caps and the driver's stop events), by ``subsumption doctor`` (what to listen for) and by the docs.

Format (every field checked; a mistake is a :class:`ProfileError` naming the file and the field)::

    name: turtlebot3
    description: TurtleBot 3 Burger (OpenCR board, LDS-01 laser)
    frames: {odom: odom, base: base_footprint}
    base:
      cmd_vel: /cmd_vel                  # the driver's velocity input (the guard publishes there)
      cmd_timeout: 0.5                   # s: the driver stops the motors this long after the last command
      bumper: {topic: /mobile_base/events/bumper, type: kobuki_msgs/BumperEvent}   # optional; also cliff, wheel_drop
    limits: {max_v: 0.22, max_reverse: 0.22, max_w: 2.84, acc_v: 1.0, acc_w: 4.0}
    topics:                              # what the drivers publish; the doctor listens to each
      scan: {topic: /scan, type: sensor_msgs/LaserScan, frame: base_scan, rate: 5, needs: {wander: 0, patrol: 0}}

``rate`` is the driver's nominal rate (Hz; 0 for topics that only speak on events); ``needs`` says from which
level of which robot the topic is needed (a topic needed by no robot is listed for information).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import yamlfile
from .safety import Caps

def _profiles_folder() -> Path:
    """profiles/ beside the Python packages (a source checkout), else in the package's share folder (catkin)."""
    here = Path(__file__).resolve().parent.parent / "profiles"
    if here.is_dir():
        return here
    try:
        import rospkg
        return Path(rospkg.RosPack().get_path("subsumption")) / "profiles"
    except Exception:  # rospkg missing or the package not on ROS_PACKAGE_PATH: names() is then empty
        return here


PROFILES = _profiles_folder()
EVENT_KINDS = ("bumper", "cliff", "wheel_drop")
ROBOTS = ("wander", "patrol")


class ProfileError(ValueError):
    """A profile file is unusable; the message names the file and the field."""

    def __init__(self, path: str | Path, where: str, problem: str) -> None:
        super().__init__(f"{path}: field '{where}': {problem}")


@dataclass(frozen=True)
class TopicSpec:
    """A topic a driver publishes: its name, type, frame (\"\" when it has none), nominal rate, who needs it."""
    key: str
    topic: str
    type: str
    frame: str = ""
    rate: float = 0.0
    needs: dict[str, int] = field(default_factory=dict)

    def needed(self, robot: str, level: int) -> bool:
        return robot in self.needs and self.needs[robot] <= level


@dataclass(frozen=True)
class EventSpec:
    topic: str
    type: str


@dataclass(frozen=True)
class Profile:
    name: str
    description: str
    path: str
    odom_frame: str
    base_frame: str
    cmd_vel: str
    cmd_timeout: float
    events: dict[str, EventSpec]
    caps: Caps
    topics: dict[str, TopicSpec]

    def needed(self, robot: str, level: int) -> list[TopicSpec]:
        return [t for t in self.topics.values() if t.needed(robot, level)]


def names() -> list[str]:
    """The shipped profiles."""
    return sorted(p.stem for p in PROFILES.glob("*.yaml"))


def path_of(name_or_path: str | Path) -> Path:
    """A shipped profile's file by name ("turtlebot2"), or a file of the user's own by path."""
    text = str(name_or_path)
    if text.endswith((".yaml", ".yml")) or "/" in text:
        return Path(text)
    path = PROFILES / f"{text}.yaml"
    if not path.is_file():
        raise ProfileError(text, "(name)", f"no such profile (shipped: {', '.join(names())}; or give a file's path)")
    return path


def load_profile(name_or_path: str | Path) -> Profile:
    path = path_of(name_or_path)
    try:
        data = yamlfile.load(path, "robot profile")
    except yamlfile.YamlFileError as error:
        raise ProfileError(path, "(file)", str(error).split(": ", 1)[-1]) from None
    r = _Reader(path)
    data = r.mapping(data, "", {"name", "description", "frames", "base", "limits", "topics"}, required={"name"})
    frames = r.mapping(data.get("frames", {}) or {}, "frames", {"odom", "base"})
    base = r.mapping(data.get("base"), "base", {"cmd_vel", "cmd_timeout", *EVENT_KINDS}, required={"cmd_vel"})
    limits = r.mapping(data.get("limits"), "limits", {"max_v", "max_reverse", "max_w", "acc_v", "acc_w"},
                       required={"max_v", "max_w", "acc_v", "acc_w"})
    caps = Caps(**{key: r.number(value, f"limits.{key}", positive=key != "max_reverse")
                   for key, value in limits.items()})
    events = {}
    for kind in EVENT_KINDS:
        if base.get(kind) is not None:
            spec = r.mapping(base[kind], f"base.{kind}", {"topic", "type"}, required={"topic", "type"})
            events[kind] = EventSpec(r.topic(spec["topic"], f"base.{kind}.topic"), r.type(spec["type"], f"base.{kind}.type"))
    topics = {}
    for key, raw in (r.mapping(data.get("topics", {}) or {}, "topics", None)).items():
        at = f"topics.{key}"
        spec = r.mapping(raw, at, {"topic", "type", "frame", "rate", "needs"}, required={"topic", "type"})
        needs = r.mapping(spec.get("needs", {}) or {}, f"{at}.needs", set(ROBOTS))
        for robot, level in needs.items():
            if isinstance(level, bool) or not isinstance(level, int) or level < 0:
                raise r.fail(f"{at}.needs.{robot}", f"expected the lowest level that needs it (an integer >= 0), got {level!r}")
        frame = spec.get("frame", "")
        if not isinstance(frame, str):
            raise r.fail(f"{at}.frame", f"expected a frame name, got {frame!r}")
        topics[key] = TopicSpec(key, r.topic(spec["topic"], f"{at}.topic"), r.type(spec["type"], f"{at}.type"), frame,
                                r.number(spec.get("rate", 0.0), f"{at}.rate", positive=False), dict(needs))
    name = data["name"]
    if not isinstance(name, str) or not name:
        raise r.fail("name", f"expected a name, got {name!r}")
    return Profile(name=name, description=str(data.get("description", "")), path=str(path),
                   odom_frame=str(frames.get("odom", "odom")), base_frame=str(frames.get("base", "base_link")),
                   cmd_vel=r.topic(base["cmd_vel"], "base.cmd_vel"),
                   cmd_timeout=r.number(base.get("cmd_timeout", 0.5), "base.cmd_timeout", positive=True),
                   events=events, caps=caps, topics=topics)


class _Reader:
    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, where: str, problem: str) -> ProfileError:
        return ProfileError(self.path, where, problem)

    def mapping(self, value: Any, where: str, allowed: set[str] | None, required: set[str] = frozenset()) -> dict:
        if not isinstance(value, dict):
            raise self.fail(where or "(file)", f"expected a mapping, got {yamlfile.brief(value)}")
        if allowed is not None:
            unknown = sorted(str(k) for k in set(value) - allowed)
            if unknown:
                raise self.fail(f"{where}.{unknown[0]}" if where else unknown[0],
                                f"unknown field (known: {', '.join(sorted(allowed))})")
        for key in sorted(required):
            if key not in value:
                raise self.fail(f"{where}.{key}" if where else key, "missing")
        return value

    def number(self, value: Any, where: str, positive: bool) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(where, f"expected a finite number, got {yamlfile.brief(value)}")
        if (positive and not value > 0) or value < 0:
            raise self.fail(where, f"must be {'> 0' if positive else '>= 0'}, got {value}")
        return float(value)

    def topic(self, value: Any, where: str) -> str:
        if not isinstance(value, str) or not value.startswith("/") or " " in value:
            raise self.fail(where, f"expected an absolute topic name (/...), got {yamlfile.brief(value)}")
        return value

    def type(self, value: Any, where: str) -> str:
        if not isinstance(value, str) or value.count("/") != 1 or not all(value.split("/")):
            raise self.fail(where, f"expected a message type package/Name, got {yamlfile.brief(value)}")
        return value


__all__ = ["Profile", "ProfileError", "TopicSpec", "EventSpec", "load_profile", "names", "path_of", "PROFILES"]
