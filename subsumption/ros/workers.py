"""The threads of a module group that run its members' callbacks: nodelet's worker pool, ROS 2's executor.

A group (:mod:`subsumption.ros.group`) hosts a level's modules and arbiters in one process. Their callbacks
(messages and timer ticks) are queued here, each in its member's :class:`Inbox`, and run by a few shared
:class:`Workers` threads, not a thread per member:

- **One member at a time, in order.** A worker takes the oldest ready callback of a member that no other worker is
  running, so a member's callbacks never run concurrently and run in the order their messages came, while up to
  ``count`` members run side by side: a slow one (a face scan) holds up the rest only when every worker is busy.
- **One wake-up per message from outside, not per hop.** What a member publishes to another member is run by the
  worker that ran the publisher, once that callback returns; no thread is woken for it. A level's chain of modules
  (depth image -> scan -> five readers -> arbiters -> motor line) costs one wake-up, where a thread per member cost
  one per hop, each tens of microseconds of CPU when a processor had gone idle (``bench.machine_speed``). A message
  from outside the group or a timer tick wakes an idle worker, unless its member is running (the worker running it
  takes the message next).
- **Queues as rospy's.** Each subscription or timer is a :class:`Slot` keeping its newest `depth` items: a
  member that falls behind loses its oldest messages per input, never the newest; a `latest` input is a slot of one.
- **Its CPU, member by member.** ``top -H`` shows the workers (named after the group), not the members, so each
  inbox sums the CPU time its callbacks took (`cpu_s`), which the group reports on ``/diagnostics``.

Publishing only queues, so no cycle of wires can deadlock. A callback must not wait for another member's answer
(no module does: the in-process runtime, which runs them all on one thread, could not either).
"""
from __future__ import annotations

import threading
import time
import traceback
from collections import deque
from typing import Any, Callable

import rospy

from .thread_names import name_this_thread, os_thread_name

WORKERS = 2  # threads per group by default (a group node's ~workers): a TurtleBot's computer has 2-4 cores
WAIT_MAX_S = 0.5  # wall seconds an idle worker waits at most: shutdown is noticed within this


class Slot:
    """One subscription (or timer) of a member: its pending items, the newest `depth` of them, and what runs
    each."""

    __slots__ = ("items", "run", "cancelled")

    def __init__(self, depth: int, run: Callable[[Any], None]) -> None:
        self.items: deque = deque(maxlen=depth)
        self.run = run
        self.cancelled = False


class Inbox:
    """A member's place in the group's :class:`Workers`: its callbacks run one at a time under its `lock`, in the
    order their items came; `cpu_s` is the CPU time they have taken."""

    def __init__(self, name: str, lock: threading.RLock, workers: "Workers") -> None:
        self.name = name
        self.lock = lock
        self.workers = workers
        self.cpu_s = 0.0

    def put(self, slot: Slot, item: Any) -> None:
        """Queue `item` for `slot`'s callback (a full slot drops its oldest item)."""
        self.workers.put(self, slot, item)


def checked_count(count: object) -> int:
    """`count` as a number of workers; a ValueError saying what is wrong unless it is an integer >= 1."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise ValueError(f"the number of worker threads must be an integer >= 1, got {count!r}")
    return count


class Workers:
    """`count` threads running the callbacks queued in their inboxes (see the module's docstring); the threads
    are named after `name` for the system (``top -H``)."""

    def __init__(self, count: int, name: str) -> None:
        count = checked_count(count)
        self._ready: deque[tuple[Inbox, Slot]] = deque()
        self._running: set[Inbox] = set()
        self._idle = 0
        self._wake = threading.Condition()
        self._on_worker = threading.local()  # set on a worker's own thread
        self._os_name = os_thread_name(name)
        self.woken = 0  # times a put woke an idle worker
        self.threads = [threading.Thread(target=self._run, name=f"{name} worker {index}", daemon=True)
                        for index in range(count)]
        for thread in self.threads:
            thread.start()

    def put(self, inbox: Inbox, slot: Slot, item: Any) -> None:
        """Queue `item` for `slot` of `inbox`; wake an idle worker unless a worker is the caller (it runs the
        item itself once its callback returns) or the member is running (its worker takes the item next)."""
        with self._wake:
            slot.items.append(item)
            self._ready.append((inbox, slot))
            if self._idle and inbox not in self._running and not getattr(self._on_worker, "active", False):
                self.woken += 1
                self._wake.notify()

    def _take(self) -> tuple[Inbox, Slot, Any] | None:
        """The oldest ready item of a member no worker is running, taken off its slot (under the lock); None if
        there is none. Entries of a running member keep their place in the line."""
        skipped = []
        taken = None
        while self._ready:
            inbox, slot = self._ready.popleft()
            if not slot.items or slot.cancelled:
                continue  # its item was dropped by a full slot, or the timer cancelled
            if inbox in self._running:
                skipped.append((inbox, slot))
                continue
            taken = inbox, slot, slot.items.popleft()
            break
        self._ready.extendleft(reversed(skipped))
        return taken

    def _run(self) -> None:
        name_this_thread(self._os_name)
        self._on_worker.active = True
        while not rospy.is_shutdown():
            with self._wake:
                taken = self._take()
                if taken is None:
                    self._idle += 1
                    self._wake.wait(WAIT_MAX_S)
                    self._idle -= 1
                    continue
                inbox, slot, item = taken
                self._running.add(inbox)
            started = time.thread_time()
            try:
                with inbox.lock:
                    slot.run(item)
            except Exception:  # a member's own errors are caught in its callback; anything else must not stop a worker
                rospy.logerr("%s: a callback raised:\n%s", inbox.name, traceback.format_exc())
            finally:
                inbox.cpu_s += time.thread_time() - started
                with self._wake:
                    self._running.discard(inbox)


__all__ = ["Inbox", "Slot", "Workers", "WORKERS", "checked_count"]
