"""A module that fails in its callbacks, for the diagnostics tests (imported by a module node: PYTHONPATH=tests)."""
from __future__ import annotations

from std_msgs.msg import Float64

from subsumption import Module, Output, Param


class Faulty(Module):
    """Sends `value` every `period` s; from the third tick on, its timer callback raises."""

    out = Output(Float64)
    period = Param(0.2)
    value = Param(1.0)

    def setup(self) -> None:
        self.ticks = 0
        self.every(self.period, self.tick)

    def tick(self) -> None:
        self.ticks += 1
        if self.ticks >= 3:
            raise ZeroDivisionError(f"tick {self.ticks} divides by zero")
        self.out.publish(Float64(self.value))
