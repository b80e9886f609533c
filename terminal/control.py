"""Who may command the robot, when the robot must stop on its own, and how fast a client may talk.

Pure logic with the time passed in (seconds of a monotonic wall clock): the rules are tested without a
network, and the server and the ROS side only ask them.

- :class:`ControlLease`: one operator at a time. Any client may watch; the first to send a command gets
  control and keeps it until it releases it or disconnects; a second gets a refusal that says who holds it.
- :class:`DeadMan`: the robot-side dead-man switch. While the operator drives, commands arrive every few tens
  of milliseconds; when they stop coming (a lost connection, a frozen tab) for longer than the timeout, the
  robot is told to stop. Wall clock on purpose: it guards a network connection, not simulated motion.
- :class:`TokenBucket`: a flood limit per client.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass


@dataclass
class Holder:
    client_id: int
    peer: str
    since: float


class ControlLease:
    """One operator at a time; `held_s` adds up how long anyone held control."""

    def __init__(self) -> None:
        self.holder: Holder | None = None
        self._held_before = 0.0

    def acquire(self, client_id: int, peer: str, now: float) -> str | None:
        """None when `client_id` holds control (now or already); otherwise the refusal to send it."""
        if self.holder is None:
            self.holder = Holder(client_id, peer, now)
            return None
        if self.holder.client_id == client_id:
            return None
        return (f"refused: control is held by operator client {self.holder.client_id} ({self.holder.peer}) "
                f"for {now - self.holder.since:.0f} s; you may watch; it is free again when that operator "
                f"releases it or disconnects")

    def release(self, client_id: int, now: float) -> bool:
        """Give control back; False when `client_id` did not hold it."""
        if self.holder is None or self.holder.client_id != client_id:
            return False
        self._held_before += now - self.holder.since
        self.holder = None
        return True

    def holds(self, client_id: int) -> bool:
        """Whether client `client_id` holds control."""
        return self.holder is not None and self.holder.client_id == client_id

    def held_s(self, now: float) -> float:
        """Seconds control has been held by anyone, up to `now`."""
        return self._held_before + (now - self.holder.since if self.holder else 0.0)

    def describe(self) -> str:
        """Who holds control, in words."""
        if self.holder is None:
            return "control is free"
        return f"control is held by client {self.holder.client_id} ({self.holder.peer})"


class DeadMan:
    """Decides when the robot must be stopped because driving commands stopped coming. Thread-safe.

    :meth:`command` is called for every motor command sent; :meth:`due` is polled by a watchdog and says
    True once when the last command was a motion and is older than `timeout`; :meth:`cut` says whether a
    stop is needed right now (the connection closed, control was released) and forgets the motion.
    """

    def __init__(self, timeout: float) -> None:
        if not timeout > 0:
            raise ValueError(f"dead-man timeout must be > 0 s, got {timeout!r}")
        self.timeout = timeout
        self._lock = threading.Lock()
        self._last = 0.0
        self._moving = False
        self.stops = 0  # how many times the switch stopped the robot

    def command(self, moving: bool, now: float) -> None:
        """Note a motor command at `now` (and whether it moves the robot)."""
        with self._lock:
            self._last = now
            self._moving = moving

    def due(self, now: float) -> bool:
        """True once when the robot moves and no command came for `timeout` s: it must be stopped."""
        with self._lock:
            if self._moving and now - self._last > self.timeout:
                self._moving = False
                self.stops += 1
                return True
            return False

    def cut(self) -> bool:
        """The connection is gone: stop now; True if the robot was moving."""
        with self._lock:
            was_moving, self._moving = self._moving, False
            if was_moving:
                self.stops += 1
            return was_moving


class TokenBucket:
    """At most `rate` messages a second on average, `burst` at once; `allow` spends one token."""

    def __init__(self, rate: float, burst: float, now: float) -> None:
        if not rate > 0 or not burst >= 1:
            raise ValueError(f"rate must be > 0 and burst >= 1, got {rate!r}, {burst!r}")
        self.rate = rate
        self.burst = burst
        self._tokens = burst
        self._at = now

    def allow(self, now: float) -> bool:
        """Whether a message may pass at `now` (a token taken), else it is over the rate."""
        self._tokens = min(self.burst, self._tokens + (now - self._at) * self.rate)
        self._at = now
        if self._tokens >= 1.0:
            self._tokens -= 1.0
            return True
        return False
