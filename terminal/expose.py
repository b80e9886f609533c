"""Which topics of the ROS graph the terminal serves read-only beside its own (``--expose`` / ``~expose``).

Foxglove and Lichtblick want the whole graph (/tf, /scan, /odom, costmaps, /rosout, ...), the terminal's own
channels are a fixed set. ``all`` exposes every topic the master knows a publisher of; a list exposes those names
only. Exposed topics are subscribed on the ROS side only while a client watches them (as rosbridge does), so an
exposed camera costs nothing until someone looks. They are never publishable: commands stay the operator's four.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import rosgraph.names

ALL = "all"
# types whose every message matters (several publishers share /tf; a log line or a status is not a frame):
# queued like alarms, the others keep only their newest message per client, as a camera frame does
KEEP_ALL_TYPES = frozenset({"tf2_msgs/TFMessage", "tf/tfMessage", "rosgraph_msgs/Log",
                            "diagnostic_msgs/DiagnosticArray"})
KEEP = 50


class ExposeError(ValueError):
    """A bad ``~expose`` value; the text names the parameter and the bad part."""


def parse_expose(value: object) -> tuple[str, ...]:
    """``~expose`` / ``--expose`` as given: ``all``, a comma- or space-separated list of topic names, or a list;
    empty means nothing beyond the terminal's own topics."""
    if isinstance(value, str):
        value = [part for part in value.replace(",", " ").split() if part]
    if not isinstance(value, (list, tuple)) or not all(isinstance(item, str) for item in value):
        raise ExposeError(f"~expose must be 'all' or a list of topic names, got {value!r}")
    if ALL in value:
        if len(value) > 1:
            raise ExposeError(f"~expose: 'all' already exposes every topic, got {', '.join(value)}")
        return (ALL,)
    for name in value:
        if not rosgraph.names.is_legal_name(name) or not name.strip("/~"):
            raise ExposeError(f"~expose: {name!r} is not a topic name")
    return tuple(value)


@dataclass(frozen=True)
class Exposure:
    """The parsed setting with its names resolved in the terminal's namespace."""

    everything: bool = False
    names: frozenset[str] = frozenset()

    @classmethod
    def of(cls, expose: tuple[str, ...], resolve: Callable[[str], str]) -> Exposure:
        """The exposure `expose` (from :func:`parse_expose`) asks for, names resolved with `resolve`."""
        if expose == (ALL,):
            return cls(everything=True)
        return cls(names=frozenset(resolve(name) for name in expose))

    def __bool__(self) -> bool:
        return self.everything or bool(self.names)

    def allows(self, name: str) -> bool:
        """Whether the resolved topic `name` may be served read-only."""
        return self.everything or name in self.names

    def describe(self) -> str:
        """For the start-up line: all, the names, or none."""
        return ALL if self.everything else (", ".join(sorted(self.names)) or "none")


def keep_for(msg_type: str) -> int:
    """Messages queued per client of an exposed topic of `msg_type` (1: only the newest matters)."""
    return KEEP if msg_type in KEEP_ALL_TYPES else 1
