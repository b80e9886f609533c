"""One thread for all of a process's timers on ROS time, as roscpp's TimerManager keeps them.

``rospy.Timer`` gives every timer a thread of its own, and under simulated time every such thread waits on
rospy's one clock condition: each ``/clock`` message wakes them all, and each finds its time not yet come and
waits again. A module group hosts a level's modules and arbiters with a dozen timers between them (the patrol
robot's level 0: 14), so a dozen threads were woken 25 times a second for nothing, each wake a lock and an
interpreter-lock hand-over; an arbiter node has three. Here a process's timers share one thread
(:func:`process_timers`), woken on each ``/clock`` message (on the wall clock: at the next due time), which calls
each due timer's callback. A slow callback delays the process's other timers: a group member's timer only puts a
tick in the member's inbox, and a node of one module runs its timers under the node's one lock anyway.

What a timer does is ``rospy.Timer(..., reset=True)``'s: the first call one period after it was added (after ROS
time has started, when it was added before the first ``/clock``), then every period; a timer that fell more than
a period behind (a stalled process, time jumping forward) is called once and goes on a period from now, not in a
burst; time going backwards (a simulation restarted) starts every timer afresh from the new time.
"""
from __future__ import annotations

import heapq
import itertools
import threading
import traceback
from typing import Callable

import rospy

from ..runtime import TimerHandle
from .thread_names import name_this_thread

WAIT_MAX_S = 0.5  # wall seconds a wait lasts at most: shutdown is noticed within this


class ClockTimer(TimerHandle):
    """One timer of a :class:`ClockTimers` thread; cancel() stops it."""

    def __init__(self, period: float, callback: Callable[[], None], oneshot: bool) -> None:
        self.period, self.callback, self.oneshot = period, callback, oneshot
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class ClockTimers:
    """A process's timers on one thread (started at the first :meth:`add`, named `name` for ``top -H``)."""

    def __init__(self, name: str = "clock timers") -> None:
        self._name = name
        self._wake = threading.Condition()
        self._heap: list[tuple[float, int, ClockTimer]] = []
        self._unstarted: list[ClockTimer] = []  # added before ROS time began
        self._order = itertools.count()
        self._last_now: float | None = None
        self._thread: threading.Thread | None = None
        self._closed = False
        self.called_until: float | None = None  # the ROS time up to which every due timer has been called

    def add(self, period: float, callback: Callable[[], None], oneshot: bool = False) -> ClockTimer:
        """Call ``callback`` every ``period`` s of ROS time (once, ``period`` s from now, if ``oneshot``)."""
        if not period > 0:
            raise ValueError(f"{self._name}: timer period must be > 0, got {period!r}")
        timer = ClockTimer(float(period), callback, oneshot)
        with self._wake:
            now = rospy.get_time()
            if now > 0 or rospy.rostime.is_wallclock():
                self._anchor([timer], now)
            else:
                self._unstarted.append(timer)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
                self._thread.start()
            self._wake.notify()
        return timer

    def close(self) -> None:
        """Stop the thread (it also stops at ROS shutdown) and wait for it: no timer is called after this."""
        with self._wake:
            self._closed = True
            self._wake.notify()
        clock = rospy.rostime.get_rostime_cond()
        with clock:
            clock.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join()

    def _push(self, timer: ClockTimer, due: float) -> None:
        heapq.heappush(self._heap, (due, next(self._order), timer))

    def _anchor(self, timers: list[ClockTimer], now: float) -> None:
        """Start `timers` afresh at `now`: each first due one period later."""
        for timer in timers:
            self._push(timer, now + timer.period)

    def _run(self) -> None:
        name_this_thread(self._name)
        while not rospy.is_shutdown():
            with self._wake:
                if self._closed:
                    return
                now = rospy.get_time()
                due = self._due(now)
                wait = min(WAIT_MAX_S, self._heap[0][0] - now) if self._heap else WAIT_MAX_S
            for timer in due:
                self._call(timer)
            self.called_until = now
            if due:
                continue  # the calls took time: look again before waiting
            self._wait(now, wait)

    def _due(self, now: float) -> list[ClockTimer]:
        """The timers due at `now`, in the order they fell due; the periodic ones put back for their next call."""
        if now <= 0 and not rospy.rostime.is_wallclock():
            return []  # ROS time has not started: nothing is due yet
        self._anchor(self._unstarted, now)
        self._unstarted.clear()
        if self._last_now is not None and now < self._last_now:  # time went backwards: every timer afresh
            timers = [timer for _, _, timer in self._heap]
            self._heap.clear()
            self._anchor(timers, now)
        self._last_now = now
        due = []
        while self._heap and self._heap[0][0] <= now:
            when, _, timer = heapq.heappop(self._heap)
            if timer.cancelled:
                continue
            due.append(timer)
            if not timer.oneshot:
                following = when + timer.period
                self._push(timer, following if following > now else now + timer.period)
        return due

    def _call(self, timer: ClockTimer) -> None:
        if timer.cancelled or self._closed or rospy.is_shutdown():
            return
        try:
            timer.callback()
        except Exception as error:  # one failing callback must not stop every other timer of the process
            rospy.logerr("%s: a timer's callback failed: %s: %s\n%s", self._name, type(error).__name__, error,
                         traceback.format_exc())

    def _wait(self, now: float, seconds: float) -> None:
        """Until the next ``/clock`` message under simulated time (none if one came since `now` was read), or
        `seconds` on the wall clock (an earlier timer added meanwhile cuts it short)."""
        if rospy.rostime.is_wallclock():
            with self._wake:
                self._wake.wait(max(0.0, seconds))
        else:
            clock = rospy.rostime.get_rostime_cond()
            with clock:  # rospy sets the time, then notifies under this lock: read under it, no tick is missed
                if rospy.get_time() <= now:
                    clock.wait(WAIT_MAX_S)


_process: ClockTimers | None = None
_process_lock = threading.Lock()


def process_timers() -> ClockTimers:
    """This process's timer thread, shared by every node handle, arbiter and diagnostics publisher in it."""
    global _process
    with _process_lock:
        if _process is None:
            _process = ClockTimers("timers")
        return _process


__all__ = ["ClockTimers", "ClockTimer", "process_timers"]
