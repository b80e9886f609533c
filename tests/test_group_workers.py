"""A module group's worker threads (subsumption.ros.workers), without a master: a member's callbacks run one at a
time and in arrival order, members run side by side up to the number of workers, what a member publishes to
another runs on the same worker after its callback (no thread woken), full slots drop their oldest, and each
member's CPU is counted."""
from __future__ import annotations

import threading
import time

import pytest

from subsumption.ros.workers import Inbox, Slot, Workers

WAIT_S = 10.0  # wall seconds a test waits for what must happen at once on an idle machine


def inbox(workers: Workers, name: str) -> Inbox:
    return Inbox(name, threading.RLock(), workers)


def wait_for(condition, what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.005)


def test_one_member_runs_in_order_and_never_twice_at_once():
    workers = Workers(2, "/order")
    member = inbox(workers, "/a")
    seen, running, overlaps = [], [0], []

    def run(item: int) -> None:
        running[0] += 1
        overlaps.append(running[0] > 1)
        time.sleep(0.001)
        seen.append(item)
        running[0] -= 1

    slot = Slot(100, run)
    for item in range(50):
        member.put(slot, item)
    wait_for(lambda: len(seen) == 50, f"only {len(seen)} of 50 callbacks ran")
    assert seen == list(range(50))
    assert not any(overlaps), "two workers ran one member's callbacks at once"


def test_members_run_side_by_side_up_to_the_number_of_workers():
    workers = Workers(2, "/side")
    inside = threading.Barrier(2, timeout=WAIT_S)  # passes only if two callbacks are running at the same time
    passed = []

    def slow(_item) -> None:
        inside.wait()
        passed.append(threading.get_ident())

    for name in ("/detect", "/track"):
        inbox(workers, name).put(Slot(1, slow), True)
    wait_for(lambda: len(passed) == 2, "two members' callbacks did not run at once on two workers")
    assert len(set(passed)) == 2


def test_a_message_published_in_a_callback_runs_on_the_same_worker_after_it():
    workers = Workers(2, "/chain")
    order: list[tuple[str, int, str]] = []
    reader = inbox(workers, "/reader")
    read = Slot(10, lambda item: order.append(("read", threading.get_ident(), item)))

    def publish(item: str) -> None:
        order.append(("publish start", threading.get_ident(), item))
        reader.put(read, item)
        time.sleep(0.05)  # the reader waits for this callback to return: no other worker is woken for it
        order.append(("publish end", threading.get_ident(), item))

    time.sleep(0.1)  # both workers idle
    inbox(workers, "/writer").put(Slot(10, publish), "scan")
    wait_for(lambda: len(order) == 3, f"the chain did not run: {order}")
    assert [step for step, _, _ in order] == ["publish start", "publish end", "read"]
    assert len({thread for _, thread, _ in order}) == 1, order
    assert workers.woken == 1  # the message from outside; the hop inside woke nobody


def test_a_message_for_a_running_member_wakes_no_worker():
    workers = Workers(2, "/busy")
    member = inbox(workers, "/detect")
    started, gate, seen = threading.Event(), threading.Event(), []

    def scan(item: int) -> None:
        started.set()
        gate.wait(WAIT_S)
        seen.append(item)

    slot = Slot(10, scan)
    time.sleep(0.1)  # both workers idle
    member.put(slot, 1)
    assert started.wait(WAIT_S)
    member.put(slot, 2)  # its worker takes it when the first returns: the other worker is left asleep
    member.put(slot, 3)
    gate.set()
    wait_for(lambda: len(seen) == 3, f"only {seen} ran")
    assert seen == [1, 2, 3] and workers.woken == 1


def test_a_full_slot_keeps_the_newest_items():
    workers = Workers(1, "/full")
    member = inbox(workers, "/slow")
    gate = threading.Event()
    seen = []
    hold = Slot(1, lambda _item: gate.wait(WAIT_S))
    latest = Slot(1, seen.append)
    queued = Slot(3, seen.append)
    member.put(hold, True)  # the member is busy until the gate opens
    wait_for(lambda: not hold.items, "the first callback did not start")
    for item in range(10):
        member.put(latest, f"latest {item}")
        member.put(queued, f"queued {item}")
    gate.set()
    wait_for(lambda: len(seen) == 4, f"expected the newest of each slot, got {seen}")
    assert sorted(seen) == ["latest 9", "queued 7", "queued 8", "queued 9"]


def test_each_member_s_cpu_is_counted():
    workers = Workers(1, "/cpu")
    busy, idle = inbox(workers, "/busy"), inbox(workers, "/idle")
    done = threading.Event()

    def spin(_item) -> None:
        end = time.thread_time() + 0.05
        while time.thread_time() < end:
            pass
        done.set()

    idle.put(Slot(1, lambda _item: None), True)
    busy.put(Slot(1, spin), True)
    assert done.wait(WAIT_S)
    wait_for(lambda: busy.cpu_s > 0, "no CPU counted")
    assert busy.cpu_s >= 0.05 > idle.cpu_s


def test_a_cancelled_slot_runs_nothing_more_and_an_error_keeps_the_worker():
    workers = Workers(1, "/cancel")
    member = inbox(workers, "/m")
    seen = []
    gate = threading.Event()
    member.put(Slot(1, lambda _item: gate.wait(WAIT_S)), True)
    cancelled = Slot(5, seen.append)
    member.put(cancelled, "never")
    cancelled.cancelled = True

    def fail(_item) -> None:
        raise RuntimeError("a callback's own error")

    member.put(Slot(1, fail), True)
    member.put(Slot(1, seen.append), "after the error")
    gate.set()
    wait_for(lambda: seen, "the worker stopped after an error")
    assert seen == ["after the error"]


@pytest.mark.parametrize("count", [0, -1, 1.5, True, "2"])
def test_a_bad_number_of_workers_is_refused(count):
    with pytest.raises(ValueError, match="integer >= 1"):
        Workers(count, "/bad")  # type: ignore[arg-type]
