"""The in-process runtime: many modules, one thread, a simulated clock, reproducible to the bit.

Everything that happens is an event on one queue ordered by (time, sequence number): a message delivery,
a timer firing. Publishing puts one delivery per subscriber on the queue at the current time, so messages
reach their readers in time order and in publication order, with no serialisation and no threads. The
clock only moves when the next event is later than the current one, which makes a ten-minute experiment
take as long as its computation does.

Module code cannot tell this runtime from ROS: it sees the same :class:`~subsumption.runtime.NodeHandle`.
Names are resolved and remapped by ROS's own rules (``rosgraph.names``), and a topic carries one message
type: publishing or subscribing with another type is an error naming the topic and both types.
"""
from __future__ import annotations

import heapq
import itertools
import logging
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from rosgraph.names import resolve_name

from .module import Module, type_name
from .runtime import Callback, Message, MessageType, NodeHandle, Publisher, TimerHandle

log = logging.getLogger("subsumption.local")


class TopicTypeError(TypeError):
    """Two ends of one topic disagree on its message type."""


@dataclass
class _Timer(TimerHandle):
    runtime: "LocalRuntime"
    callback: Callable[[], None]
    period: float | None
    cancelled: bool = False

    def cancel(self) -> None:
        self.cancelled = True

    def fire(self) -> None:
        if self.cancelled:
            return
        if self.period is not None:
            self.runtime._schedule(self.runtime.now() + self.period, self.fire)
        self.callback()


@dataclass
class _Topic:
    msg_type: MessageType | None = None
    first_user: str = ""
    subscribers: list[Callback] = field(default_factory=list)
    latched: Message | None = None
    published: int = 0


class LocalRuntime:
    """Hosts modules (and anything else that wants a NodeHandle, such as a simulator) on a simulated clock."""

    def __init__(self, start_time: float = 0.0) -> None:
        self._time = float(start_time)
        self._queue: list[tuple[float, int, Callable[[], None]]] = []
        self._sequence = itertools.count()
        self.topics: dict[str, _Topic] = defaultdict(_Topic)
        self.nodes: dict[str, "LocalNode"] = {}
        self.modules: dict[str, Module] = {}

    # Clock and queue ------------------------------------------------------------------------------
    def now(self) -> float:
        return self._time

    def _schedule(self, when: float, action: Callable[[], None]) -> None:
        heapq.heappush(self._queue, (max(when, self._time), next(self._sequence), action))

    def run_until(self, end_time: float) -> None:
        """Process every event up to and including `end_time`; the clock then reads `end_time`."""
        while self._queue and self._queue[0][0] <= end_time:
            when, _, action = heapq.heappop(self._queue)
            self._time = when
            action()
        self._time = max(self._time, end_time)

    def run_for(self, duration: float) -> None:
        self.run_until(self._time + duration)

    # Nodes and modules ----------------------------------------------------------------------------
    def node(self, name: str, remap: Mapping[str, str] | None = None,
             params: Mapping[str, Any] | None = None) -> "LocalNode":
        """A NodeHandle for a node called `name` (e.g. 'avoid' or '/robot1/avoid')."""
        full = resolve_name(name, "/")
        if full in self.nodes:
            raise ValueError(f"a node named {full} already runs in this runtime")
        handle = LocalNode(self, full, dict(remap or {}), dict(params or {}))
        self.nodes[full] = handle
        return handle

    def add_module(self, module_class: type[Module], name: str, remap: Mapping[str, str] | None = None,
                   params: Mapping[str, Any] | None = None) -> Module:
        module = module_class(self.node(name, remap, params))
        self.modules[module.node.name] = module
        return module

    # Topics ---------------------------------------------------------------------------------------
    def _claim(self, topic: str, msg_type: MessageType, who: str) -> _Topic:
        entry = self.topics[topic]
        if entry.msg_type is None:
            entry.msg_type, entry.first_user = msg_type, who
        elif entry.msg_type is not msg_type and type_name(entry.msg_type) != type_name(msg_type):
            raise TopicTypeError(
                f"topic {topic}: {who} uses {type_name(msg_type)} but {entry.first_user} uses "
                f"{type_name(entry.msg_type)}")
        return entry

    def publish(self, topic: str, msg: Message) -> None:
        entry = self.topics[topic]
        entry.published += 1
        for callback in list(entry.subscribers):
            self._schedule(self._time, lambda cb=callback: cb(msg))


class _LocalPublisher(Publisher):
    def __init__(self, runtime: LocalRuntime, topic: str, latch: bool) -> None:
        self._runtime, self._topic, self._latch = runtime, topic, latch

    def publish(self, msg: Message) -> None:
        if self._latch:
            self._runtime.topics[self._topic].latched = msg
        self._runtime.publish(self._topic, msg)

    def has_subscribers(self) -> bool:
        return bool(self._runtime.topics[self._topic].subscribers)


class LocalNode(NodeHandle):
    clock_waits_for_callbacks = True  # the simulated clock moves only between events

    def __init__(self, runtime: LocalRuntime, name: str, remap: dict[str, str], params: dict[str, Any]) -> None:
        self.runtime = runtime
        self.name = name
        self._remap = {resolve_name(k, name): resolve_name(v, name) for k, v in remap.items()}
        self._params = params

    def now(self) -> float:
        return self.runtime.now()

    def resolve(self, topic: str) -> str:
        return resolve_name(topic, self.name, self._remap)

    def publisher(self, topic: str, msg_type: MessageType, latch: bool = False, latest: bool = False) -> Publisher:
        resolved = self.resolve(topic)
        self.runtime._claim(resolved, msg_type, f"publisher {self.name}")
        return _LocalPublisher(self.runtime, resolved, latch)

    def subscribe(self, topic: str, msg_type: MessageType, callback: Callback, latest: bool = False) -> None:
        # `latest` changes nothing here: a message is delivered when it is sent, no queue builds up
        resolved = self.resolve(topic)
        entry = self.runtime._claim(resolved, msg_type, f"subscriber {self.name}")
        entry.subscribers.append(callback)
        if entry.latched is not None:
            latched = entry.latched
            self.runtime._schedule(self.runtime.now(), lambda: callback(latched))

    def call_every(self, period: float, callback: Callable[[], None]) -> TimerHandle:
        if not period > 0:
            raise ValueError(f"{self.name}: timer period must be > 0, got {period!r}")
        timer = _Timer(self.runtime, callback, float(period))
        self.runtime._schedule(self.runtime.now() + period, timer.fire)
        return timer

    def call_later(self, delay: float, callback: Callable[[], None]) -> TimerHandle:
        timer = _Timer(self.runtime, callback, None)
        self.runtime._schedule(self.runtime.now() + max(0.0, delay), timer.fire)
        return timer

    def param(self, name: str, default: Any) -> Any:
        return self._params.get(name, default)

    def set_param(self, name: str, value: Any) -> None:
        self._params[name] = value

    def log(self, level: str, text: str) -> None:
        getattr(log, "warning" if level == "warn" else level)("[%s] [%.3f] %s", self.name, self.now(), text)
