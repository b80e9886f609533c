"""The last step of the motor line before a real base: speed and acceleration caps, and stops that win.

Every level of a subsumption network may command the base, and the last arbiter's output is whoever won. On a
real robot something must still hold whatever wins to the base's safe envelope and stop it when the robot
touches something, nears a cliff, is lifted, or the graph has lost its clock or its operator. :class:`MotorGuard`
is that rule, kept free of ROS so it is tested on its own; :mod:`subsumption.ros.base_guard` runs it between the
network's ``cmd_vel`` and the driver's velocity topic.

* **Caps**: forward and reverse speed, turn rate, and acceleration (each command may change the speed by at most
  ``acc * dt`` of ROS time since the last one; a stop is never slowed down by it).
* **Contact**: a bumper press, a cliff or a dropped wheel stops the base at once (the event itself sends the stop;
  it does not wait for the next command); while a bumper is pressed or a cliff is seen, only reversing and
  turning on the spot pass (the robot's own level 0 backs off); while a wheel is dropped nothing moves.
* **Clock and dead-man**: while the clock is lost or the dead-man has run out, every command is refused and one
  stop is sent when it happens (the node watches both on the wall clock: a stopped clock cannot time itself).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Caps:
    """A base's safe envelope (m/s, rad/s, m/s^2, rad/s^2)."""
    max_v: float
    max_w: float
    acc_v: float
    acc_w: float
    max_reverse: float | None = None  # None: max_v

    def __post_init__(self) -> None:
        for name in ("max_v", "max_w", "acc_v", "acc_w"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.max_reverse is not None and not (math.isfinite(self.max_reverse) and self.max_reverse >= 0):
            raise ValueError(f"max_reverse must be a finite number >= 0, got {self.max_reverse!r}")

    @property
    def reverse(self) -> float:
        return self.max_v if self.max_reverse is None else self.max_reverse


# why the base is held: reasons a command is refused or cut
BUMPER, CLIFF, WHEEL_DROP, CLOCK, DEADMAN = "bumper", "cliff", "wheel_drop", "clock", "deadman"
SENSORS = "sensors"  # a sensor the network needs has not spoken yet
MAX_DT = 0.5  # s: a command after a longer pause is limited as if this long had passed (the base stood or stopped)


@dataclass
class MotorGuard:
    """Caps and stops between the network's motor line and the base."""

    caps: Caps
    v: float = 0.0  # the last command passed to the base
    w: float = 0.0
    last: float | None = None  # ROS time of that command
    contacts: dict[str, set[int]] = field(default_factory=lambda: {BUMPER: set(), CLIFF: set(), WHEEL_DROP: set()})
    held: set[str] = field(default_factory=set)  # CLOCK and/or DEADMAN while they refuse every command
    stops: dict[str, int] = field(default_factory=dict)  # how many stops each reason caused (for ~status)

    def command(self, v: float, w: float, now: float) -> tuple[float, float]:
        """The command to send the base for the wanted (v, w) at ROS time `now`."""
        if not (math.isfinite(v) and math.isfinite(w)):
            v, w = 0.0, 0.0  # a broken controller's NaN means stop
        if self.held or self.contacts[WHEEL_DROP]:
            v, w = 0.0, 0.0
        elif (self.contacts[BUMPER] or self.contacts[CLIFF]) and v > 0.0:
            v = 0.0  # only away from it: reverse, or turn on the spot
        v = min(max(v, -self.caps.reverse), self.caps.max_v)
        w = min(max(w, -self.caps.max_w), self.caps.max_w)
        dt = MAX_DT if self.last is None else min(max(now - self.last, 0.0), MAX_DT)
        if v != 0.0 or w != 0.0:  # a stop is a stop: never eased in by the acceleration cap
            v = self.v + min(max(v - self.v, -self.caps.acc_v * dt), self.caps.acc_v * dt)
            w = self.w + min(max(w - self.w, -self.caps.acc_w * dt), self.caps.acc_w * dt)
        self.v, self.w, self.last = v, w, now
        return v, w

    def contact(self, kind: str, sensor: int, active: bool) -> bool:
        """A bumper/cliff/wheel-drop sensor changed; True when the base must be stopped now."""
        sensors = self.contacts[kind]
        (sensors.add if active else sensors.discard)(sensor)
        if active:
            return self._stop(kind)
        return False

    def hold(self, reason: str, on: bool) -> bool:
        """Start (on) or end holding for `reason` (CLOCK, DEADMAN); True when the base must be stopped now."""
        if on and reason not in self.held:
            self.held.add(reason)
            return self._stop(reason)
        if not on:
            self.held.discard(reason)
        return False

    def _stop(self, reason: str) -> bool:
        self.v = self.w = 0.0
        self.stops[reason] = self.stops.get(reason, 0) + 1
        return True

    def state(self) -> dict[str, str]:
        """What holds the base now, for diagnostics."""
        return {"held": ",".join(sorted(self.held)) or "-",
                **{kind: ",".join(str(s) for s in sorted(sensors)) or "-" for kind, sensors in self.contacts.items()},
                **{f"stops_{reason}": str(count) for reason, count in sorted(self.stops.items())},
                "v": f"{self.v:.3f}", "w": f"{self.w:.3f}"}
