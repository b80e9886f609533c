"""What a module may ask of whatever runs it.

A module never talks to rospy or to the in-process scheduler directly: it is handed a :class:`NodeHandle`
and asks it for the time, publishers, subscriptions, timers, parameters and a logger. Two runtimes
implement the handle: :mod:`subsumption.ros.runtime` (one ROS node per module, ROS time, so /use_sim_time
works) and :mod:`subsumption.local` (many modules in one process, a simulated clock, deterministic).

Both promise the same thing to module code: callbacks of one module never run concurrently, and time
comes only from the runtime's clock.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, Callable

Message = Any  # a genpy message instance (std_msgs.msg.String(), ...)
MessageType = type
Callback = Callable[[Message], None]


class TimerHandle(ABC):
    """A started timer; cancel() stops it (a no-op if it already fired or was cancelled)."""

    @abstractmethod
    def cancel(self) -> None:
        """Stop the timer: its callback is not called again."""


class Publisher(ABC):
    """What a module publishes through: one topic, bound by the runtime (rospy's publisher or the local runtime's)."""

    @abstractmethod
    def publish(self, msg: Message) -> None:
        """Send `msg` on the topic."""

    def has_subscribers(self) -> bool:
        """Whether anyone reads the topic now, so that a costly message (a camera frame) need not be made for
        nobody; a runtime that cannot tell says True."""
        return True


class NodeHandle(ABC):
    """The services one module gets from its runtime. Topic names follow ROS rules: `name` is relative to the
    node's namespace, `~name` is private to the node, `/name` is global; remappings apply to all three."""

    name: str  # the node's resolved name, e.g. "/avoid"
    # True where the clock stands still while a callback runs (the in-process runtime): a long computation in a
    # callback then costs no time, and handing it to a thread would only make runs depend on the machine's speed
    clock_waits_for_callbacks: bool = False

    @abstractmethod
    def now(self) -> float:
        """Seconds on the runtime's clock (ROS time under ROS; the simulated clock in-process)."""

    @abstractmethod
    def resolve(self, topic: str) -> str:
        """The global topic name that `topic` means for this node, after remapping."""

    @abstractmethod
    def publisher(self, topic: str, msg_type: MessageType, latch: bool = False, latest: bool = False) -> Publisher:
        """A publisher on `topic`; with `latest` (a camera's images), a runtime that queues messages for a slow
        connection keeps only the newest one for it, so that nobody is handed a backlog of old frames."""

    @abstractmethod
    def subscribe(self, topic: str, msg_type: MessageType, callback: Callback, latest: bool = False) -> None:
        """Call `callback` with each message on `topic`; with `latest`, a runtime that queues may keep only the
        newest (see Input's ``latest``)."""

    @abstractmethod
    def call_every(self, period: float, callback: Callable[[], None]) -> TimerHandle:
        """Call `callback` every `period` seconds of runtime time, the first time one period from now."""

    @abstractmethod
    def call_later(self, delay: float, callback: Callable[[], None]) -> TimerHandle:
        """Call `callback` once, `delay` seconds of runtime time from now."""

    @abstractmethod
    def param(self, name: str, default: Any) -> Any:
        """The node's private parameter `name` (`~name` under ROS), or `default` when it is not set."""

    def set_param(self, name: str, value: Any) -> None:
        """Write the node's private parameter `name` (`~name` under ROS), so that the values a module runs with
        can be read back (``rosparam get``). A runtime without a parameter server keeps nothing."""

    @abstractmethod
    def log(self, level: str, text: str) -> None:
        """level is one of debug, info, warn, error."""

    def service(self, name: str, srv_type: type, handler: Callable[[Message], Message]) -> None:
        """Answer the service `name` (a ROS service of `srv_type`, e.g. ``std_srvs/Empty``; resolved like a topic)
        with `handler(request) -> response`, never while another callback of the module runs. A runtime without
        services (in-process) keeps the handler in ``services``, by resolved name, for in-process callers."""
        if not hasattr(self, "services"):
            self.services: dict[str, Callable[[Message], Message]] = {}
        self.services[self.resolve(name)] = handler
