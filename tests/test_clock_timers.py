"""subsumption.ros.clock_timers: a process's timers on one thread, on ROS time. Simulated time is set here as
rospy's own /clock subscriber sets it (rospy.rostime._set_rostime, which also wakes every waiter), so the timers
are driven tick by tick without a master; the module groups' tests run them on a real graph."""
from __future__ import annotations

import threading
import time

import pytest
import rospy

from subsumption.ros.clock_timers import ClockTimers

TICK = 0.04  # a 25 Hz /clock


MADE: list[ClockTimers] = []  # the test's timer threads: each tick waits until they have called what is due


def tick(t: float) -> None:
    """Set ROS time to `t` as a /clock message does, and wait until every timer thread has acted on it."""
    rospy.rostime._set_rostime(rospy.Time.from_sec(t))
    when = rospy.get_time()
    deadline = time.monotonic() + 10.0
    while any(c.called_until != when for c in MADE) and time.monotonic() < deadline:
        time.sleep(0.001)


@pytest.fixture
def sim_time():
    """Simulated time under the test's control; rospy's wall clock again afterwards."""
    rospy.rostime.set_rostime_initialized(True)
    now = [0.0]

    def advance(seconds: float) -> None:
        end = now[0] + seconds
        while now[0] < end - 1e-9:
            now[0] = round(now[0] + TICK, 6)
            tick(now[0])

    def set_to(t: float) -> None:
        now[0] = t
        tick(t)

    advance.set_to = set_to  # type: ignore[attr-defined]
    yield advance
    rospy.rostime.switch_to_wallclock()
    rospy.rostime.set_rostime_initialized(False)


@pytest.fixture
def timers(sim_time):
    """A ClockTimers per call, each closed at the end of the test (before `sim_time` gives the clock back)."""
    made: list[ClockTimers] = []

    def make(name: str = "clock timers") -> ClockTimers:
        made.append(ClockTimers(name))
        MADE.append(made[-1])
        return made[-1]

    yield make
    for each in made:
        each.close()
        MADE.remove(each)


def recorder(calls: list, name: str):
    return lambda: calls.append((name, rospy.get_time(), threading.current_thread().name))


def test_periodic_timers_fire_each_period_of_ros_time_on_one_shared_thread(sim_time, timers):
    sim_time.set_to(1.0)
    clock, calls = timers("test timers"), []
    before = threading.active_count()
    clock.add(0.1, recorder(calls, "fast"))
    clock.add(0.5, recorder(calls, "slow"))
    clock.add(0.2, recorder(calls, "mid"))
    assert threading.active_count() == before + 1  # three timers, one thread
    sim_time(1.02)  # to 2.04: the tick at 2.0 may read a hair below it
    fast = [t for name, t, _ in calls if name == "fast"]
    slow = [t for name, t, _ in calls if name == "slow"]
    mid = [t for name, t, _ in calls if name == "mid"]
    assert len(fast) == 10 and len(mid) == 5 and len(slow) == 2, calls
    assert slow[0] == pytest.approx(1.52, abs=TICK)  # one period after it was added, on the first tick past it
    assert all(b - a == pytest.approx(0.1, abs=TICK + 1e-6) for a, b in zip(fast, fast[1:]))
    assert {thread for _, _, thread in calls} == {"test timers"}


def test_oneshot_fires_once_and_cancel_stops_a_timer(sim_time, timers):
    sim_time.set_to(5.0)
    clock, calls = timers(), []
    clock.add(0.3, recorder(calls, "once"), oneshot=True)
    stopped = clock.add(0.1, recorder(calls, "stopped"))
    sim_time(0.25)
    stopped.cancel()
    sim_time(1.0)
    names = [name for name, _, _ in calls]
    assert names.count("once") == 1
    assert 1 <= names.count("stopped") <= 3  # within the first 0.25 s only
    assert all(t <= 5.26 for name, t, _ in calls if name == "stopped")


def test_a_timer_behind_fires_once_not_in_a_burst_and_time_going_back_starts_afresh(sim_time, timers):
    sim_time.set_to(10.0)
    clock, calls = timers(), []
    clock.add(0.1, recorder(calls, "t"))
    sim_time(0.2)
    count = len(calls)
    sim_time.set_to(13.0)  # 3 s (30 periods) in one jump: a stall
    assert len(calls) == count + 1
    sim_time(0.3)
    assert len(calls) >= count + 3
    count = len(calls)
    sim_time.set_to(2.0)  # a simulation restarted
    sim_time(0.5)
    later = [t for _, t, _ in calls[count:]]
    assert later and all(2.0 < t <= 2.55 for t in later) and len(later) >= 4


def test_timers_added_before_ros_time_starts_count_from_its_start(sim_time, timers):
    rospy.rostime._set_rostime(rospy.Time(0))
    clock, calls = timers(), []
    clock.add(0.5, recorder(calls, "t"))
    time.sleep(0.05)
    assert calls == []
    sim_time.set_to(100.0)  # the first /clock: a bag's time
    assert calls == []       # not at once: one period after time began
    sim_time(0.6)
    assert [round(t, 2) for _, t, _ in calls] == [100.52]


def test_a_failing_callback_leaves_the_other_timers_running(sim_time, timers):
    sim_time.set_to(1.0)
    clock, calls = timers(), []

    def fails() -> None:
        raise RuntimeError("broken")

    clock.add(0.1, fails)
    clock.add(0.1, recorder(calls, "fine"))
    sim_time(0.5)
    assert len(calls) >= 4


def test_period_must_be_positive():
    with pytest.raises(ValueError, match="period must be > 0"):
        ClockTimers("named").add(0.0, lambda: None)
