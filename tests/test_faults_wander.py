"""The wander robot's level 2 when a part of it is gone: whenlook must not hold wander down for good.

Before: with look dead, whenlook started a look every 1.5 s, each inhibiting wander's heading for 7.5 s, so
wander never spoke again and the robot stood still (bench/faults, "look killed"). Now whenlook notices that
its looks go unanswered (pathplan never says busy) and backs off; the first answer brings it back.
"""
from __future__ import annotations

from std_msgs.msg import Bool

from robots.wander.level2 import Whenlook
from subsumption.testing import Harness


def looks_between(harness: Harness, start: float, end: float) -> int:
    return sum(1 for t, _ in harness.outputs["startlook"] if start <= t < end)


def test_unanswered_looks_make_whenlook_back_off_and_an_answer_ends_it():
    harness = Harness(Whenlook)
    harness.feed("busy", Bool(False))
    harness.run_for(60.0)  # nobody answers: look (or pathplan) is dead
    first = looks_between(harness, 0.0, 5.0)
    late = looks_between(harness, 30.0, 60.0)
    assert first == 3  # misses, at the usual pace: idle + cooldown = 1.5 s apart
    assert late <= 2   # then every 10 s, 20 s, 40 s ...: wander holds the heading most of the time
    inhibited = 7.5 * late  # each look inhibits wander for 7.5 s (I 75)
    assert inhibited < 30.0
    # level 2 comes back (a respawned look): its first answer restores the usual pace
    harness.run_for(harness.module.max_retry)
    harness.feed("busy", Bool(True))
    harness.feed("busy", Bool(False))
    now = harness.runtime.now()
    harness.run_for(3.2)
    assert looks_between(harness, now, now + 3.2) >= 1
    harness.feed("busy", Bool(True))  # answered
    harness.feed("busy", Bool(False))
    harness.run_for(3.1)
    assert looks_between(harness, now + 3.2, now + 6.3) == 2


def test_answered_looks_keep_the_usual_pace():
    harness = Harness(Whenlook)
    harness.feed("busy", Bool(False))
    answered = 0
    for _ in range(300):  # 30 s; every look is taken up at once: pathplan travels, arrives, is free again
        harness.run_for(0.1)
        if len(harness.sent("startlook")) > answered:
            answered = len(harness.sent("startlook"))
            harness.feed("busy", Bool(True))
            harness.feed("busy", Bool(False))
    assert answered == 20  # one look per idle + cooldown = 1.5 s, never backing off
