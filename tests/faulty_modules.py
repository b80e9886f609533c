"""Modules that misbehave, for the diagnostics and readiness tests (imported by a module node: PYTHONPATH=tests)."""
from __future__ import annotations

import time

from std_msgs.msg import Float64

from subsumption import Input, Module, Output, Param


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


class SlowSetup(Module):
    """Takes `seconds` of wall time to set up, as a module that compiles its kernels or reads a big map does."""

    out = Output(Float64)
    seconds = Param(6.0)

    def setup(self) -> None:
        time.sleep(self.seconds)  # wall clock: the set-up's own work, whatever the ROS clock says


class SlowReader(Module):
    """Takes `seconds` over each message and says which it took: on `latest` it should skip to the newest."""

    newest = Input(Float64, latest=True)
    every = Input(Float64)
    took_newest = Output(Float64)
    took_every = Output(Float64)
    seconds = Param(0.1)

    def on_newest(self, msg: Float64) -> None:
        time.sleep(self.seconds)  # wall clock: a slow callback, as a tracker on a loaded machine
        self.took_newest.publish(msg)

    def on_every(self, msg: Float64) -> None:
        time.sleep(self.seconds)
        self.took_every.publish(msg)
