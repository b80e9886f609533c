"""Modules for the module-group tests (imported by a group node: PYTHONPATH=tests)."""
from __future__ import annotations

import threading

from std_msgs.msg import Bool, Float64, Int64

from subsumption import Input, Module, Output, Param


class Count(Module):
    """Sends 1, 2, 3, ... every `period` s."""

    count = Output(Int64)
    period = Param(0.1)

    def setup(self) -> None:
        self.sent = 0
        self.every(self.period, self.tick)

    def tick(self) -> None:
        self.sent += 1
        self.count.publish(Int64(self.sent))


class Witness(Module):
    """Two or more witnesses read one line; the second to see each message says whether it got the very object
    the first got (True: delivered in-process, the same message; False: a copy, as a decode would make)."""

    count = Input(Int64)
    same = Output(Bool)
    _seen: dict[int, object] = {}
    _lock = threading.Lock()

    def on_count(self, msg: Int64) -> None:
        with self._lock:
            first = self._seen.pop(msg.data, None)
            if first is None:
                self._seen[msg.data] = msg
                return
        self.same.publish(Bool(first is msg))


class Pulse(Module):
    """Sends `sign` times the ROS time of sending, every `period` s: for `width` s, then silent for `gap` s, over
    and over from its first tick (gap <= 0: for ever): a line whose every message says when it was sent."""

    out = Output(Float64)
    period = Param(0.1)
    sign = Param(1.0)
    width = Param(1.0)
    gap = Param(0.0)

    def setup(self) -> None:
        self.began: float | None = None
        self.every(self.period, self.tick)

    def tick(self) -> None:
        now = self.now()
        if self.began is None:
            self.began = now
        since = now - self.began
        if self.gap <= 0 or since % (self.width + self.gap) < self.width:
            self.out.publish(Float64(self.sign * now))


class Relay(Module):
    """Passes its input on unchanged (a wire through a module)."""

    value = Input(Float64)
    out = Output(Float64)

    def on_value(self, msg: Float64) -> None:
        self.out.publish(msg)
