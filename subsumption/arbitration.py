"""The timing rule of Brooks' arbiters, in one place.

Both runtimes (a ROS node relaying serialized bytes, and the in-process runtime) ask an
:class:`ArbiterRule` what to do with each message; the rule itself never sees a message or a clock,
only the arrival time it is given. That keeps the rule tiny, exactly testable, and identical everywhere.

- inhibitor:  drops every lower message that arrives less than T after the last upper message; upper
              messages are never forwarded (they only start the window).
- suppressor: the same, and every upper message is forwarded in place of the lower line's.
- defaulter:  (Brooks, later work) the lower line wins when present; an upper message is forwarded only
              when the lower line has been silent for at least T.

Time that jumps backwards (a simulation restarted, a bag looped) resets the window instead of
blocking the lower line until the old time comes round again.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum


class ArbiterKind(str, Enum):
    """The three arbiters of a network: an inhibitor silences the lower line while the upper one speaks, a suppressor
    also sends the upper line in its place, a defaulter sends the upper line only while the lower one is silent."""
    INHIBITOR = "inhibitor"
    SUPPRESSOR = "suppressor"
    DEFAULTER = "defaulter"

    @property
    def letter(self) -> str:
        """The mark Brooks draws in the arbiter's circle."""
        return {"inhibitor": "I", "suppressor": "S", "defaulter": "D"}[self.value]

    @property
    def needs_same_type(self) -> bool:
        """An inhibitor's upper line only starts a window, so it may carry any type; the others forward it."""
        return self is not ArbiterKind.INHIBITOR


@dataclass
class LineCounts:
    """Messages of one line: forwarded, and not forwarded (`dropped`, whatever the cause). `queue_dropped` is
    the part of `dropped` that never reached the rule: lost in the node's input queue under overload."""

    passed: int = 0
    dropped: int = 0
    queue_dropped: int = 0


@dataclass
class ArbiterRule:
    """Decides, message by message, which line gets through. Times are seconds of the runtime's clock."""

    kind: ArbiterKind
    time_constant: float
    upper: LineCounts = field(default_factory=LineCounts)
    lower: LineCounts = field(default_factory=LineCounts)
    _last_upper: float | None = None
    _last_lower: float | None = None

    def __post_init__(self) -> None:
        self.kind = ArbiterKind(self.kind)
        if not isinstance(self.time_constant, (int, float)) or isinstance(self.time_constant, bool):
            raise ValueError(f"time_constant must be a number of seconds, got {self.time_constant!r}")
        if not self.time_constant > 0:
            raise ValueError(f"time_constant must be > 0 seconds, got {self.time_constant!r}")

    def on_upper(self, now: float) -> bool:
        """Record an upper message at `now`; return True if it is to be forwarded."""
        self._forget_future(now)
        if self.kind is ArbiterKind.DEFAULTER:
            forward = not self._within(self._last_lower, now)
        else:
            self._last_upper = now
            forward = self.kind is ArbiterKind.SUPPRESSOR
        self._count(self.upper, forward)
        return forward

    def on_lower(self, now: float) -> bool:
        """Record a lower message at `now`; return True if it is to be forwarded."""
        self._forget_future(now)
        if self.kind is ArbiterKind.DEFAULTER:
            self._last_lower = now
            forward = True
        else:
            forward = not self._within(self._last_upper, now)
        self._count(self.lower, forward)
        return forward

    def upper_in_control(self, now: float) -> bool:
        """Whether the upper line holds the output at `now` (for status and metrics)."""
        if self.kind is ArbiterKind.DEFAULTER:
            return not self._within(self._last_lower, now)
        return self._within(self._last_upper, now)

    def control_until(self, now: float) -> float | None:
        """When the line holding the output at `now` loses it if no further message arrives; None while it holds
        indefinitely (the lower line of an inhibitor or suppressor, the upper line of a defaulter). With this,
        whoever listens to the status knows when control changes hands without re-computing the rule."""
        if self.kind is ArbiterKind.DEFAULTER:
            return self._last_lower + self.time_constant if self._within(self._last_lower, now) else None
        return self._last_upper + self.time_constant if self._within(self._last_upper, now) else None

    def lost_in_queue(self, line: str, count: int) -> None:
        """`count` messages of `line` ("upper" or "lower") were discarded before the rule saw them."""
        counts = self.upper if line == "upper" else self.lower
        counts.dropped += count
        counts.queue_dropped += count

    def reset(self) -> None:
        """Forget both lines' last messages: the lower line passes again at once (time went backwards, or a restart)."""
        self._last_upper = self._last_lower = None

    def _within(self, last: float | None, now: float) -> bool:
        # A `last` later than `now` means time went backwards: that window is void (the next message resets
        # it), so a status asked in between must not report the old line as still in control.
        return last is not None and 0 <= now - last < self.time_constant

    def _forget_future(self, now: float) -> None:
        if (self._last_upper is not None and now < self._last_upper) or (
            self._last_lower is not None and now < self._last_lower
        ):
            self.reset()

    @staticmethod
    def _count(counts: LineCounts, forward: bool) -> None:
        if forward:
            counts.passed += 1
        else:
            counts.dropped += 1

    def status(self, now: float) -> dict[str, object]:
        """A flat summary for status topics and logs."""
        until = self.control_until(now)
        return {
            "kind": self.kind.value,
            "time_constant": self.time_constant,
            "in_control": "upper" if self.upper_in_control(now) else "lower",
            "until": "" if until is None else repr(until),
            "upper_passed": self.upper.passed,
            "upper_dropped": self.upper.dropped,
            "lower_passed": self.lower.passed,
            "lower_dropped": self.lower.dropped,
            "upper_queue_dropped": self.upper.queue_dropped,
            "lower_queue_dropped": self.lower.queue_dropped,
        }
