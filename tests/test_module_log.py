"""Module.log_every: a lasting condition logs once per period of the runtime's clock, per key (rospy's
logwarn_throttle, in simulated time)."""
from __future__ import annotations

import logging

from std_msgs.msg import Empty

from subsumption import Input, Module
from subsumption.testing import Harness


class Complainer(Module):
    """Complains on every tick it hears, through log_every."""

    tick = Input(Empty, "each one: a complaint")

    def on_tick(self, msg: Empty) -> None:
        self.log_every("tick", 1.0, "ticked again", "warn")
        self.log_every("other", 1.0, "another complaint", "warn")


def test_log_every_logs_once_per_period_for_each_key(caplog):
    harness = Harness(Complainer)
    with caplog.at_level(logging.WARNING, logger="subsumption.local"):
        for _ in range(10):           # 10 ticks in 0.5 s: once each
            harness.feed("tick", Empty())
            harness.run_for(0.05)
        harness.run_for(0.6)          # more than a period since the first: again
        harness.feed("tick", Empty())
    messages = [r.getMessage() for r in caplog.records]
    assert sum("ticked again" in m for m in messages) == 2
    assert sum("another complaint" in m for m in messages) == 2


def test_log_once_logs_the_first_time_only_for_each_key(caplog):
    harness = Harness(Complainer)
    with caplog.at_level(logging.WARNING, logger="subsumption.local"):
        for key in ("tf", "tf", "map", "tf"):
            harness.module.log_once(key, f"no {key} yet")
            harness.run_for(100.0)
    messages = [r.getMessage() for r in caplog.records]
    assert sum("no tf yet" in m for m in messages) == 1
    assert sum("no map yet" in m for m in messages) == 1
