"""How fast this machine is right now: three fixed workloads, timed in CPU time.

A shared 2-core machine runs the same CPU-bound work 20-40% slower in one hour than in another (measured: a face
scan of the same picture took 34 ms at 09:40 and 42 ms at 09:50 with nothing else running), so a bench figure such
as "cores at 1x" from one hour does not compare with one from another. Benches print these figures beside theirs
(:mod:`bench.ros_load` before and after the run): they show the processor's own speed at the time. A ROS graph's
figure can move further than they do (docs/ros.md, "Detect at 5-10 scans a second"), so changes are still measured
side by side (``bench.ros_load --versus``).

- ``python_ms``: a pure-Python loop (the interpreter's speed: rospy, the modules' own code);
- ``opencv_ms``: the patrol robot's face cascade (haar_alt2, faces of 24 px and up) over the rows above the
  horizon of a fixed 640 x 480 picture (the shipped poster of the cat, scaled): native code, the cache;
- ``wakeup_us``: CPU microseconds (both sides) of one round trip of a byte between two processes through pipes,
  each waiting for the other: the cost of a wake-up, which every ROS message pays at least twice (a socket write
  and the reader's thread woken). On a virtual machine most of it is waking a processor that had gone idle: on
  the 2-core development machine 47-68 us with nothing else running, 4 us while other work kept both busy.

Each is the median of 5 repetitions. Usage: .venv/bin/python -m bench.machine_speed
"""
from __future__ import annotations

import json
import os
import resource
import statistics
import time
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parent.parent
PICTURE = ROOT / "subsim" / "pictures" / "poster_chelsea.png"
REPEATS = 5


def _python_loop() -> None:
    total = 0
    for i in range(1_000_000):
        total += i % 7
    if total < 0:
        raise AssertionError  # keeps the loop from being optimised away by any future interpreter


def _face_scan() -> tuple[Callable[[], None], Callable[[], None]]:
    """The scan to time, and what puts OpenCV's thread count back afterwards."""
    import cv2

    from vision.faces import FaceDetector, to_gray

    picture = cv2.cvtColor(cv2.imread(str(PICTURE)), cv2.COLOR_BGR2RGB)
    gray = to_gray(cv2.resize(picture, (640, 480)))[:256]  # the rows the patrol robot's detect scans
    detector = FaceDetector("haar_alt2", 24, 1.1)
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)

    def scan() -> None:
        detector.detect(gray)

    return scan, lambda: cv2.setNumThreads(threads)


def _round_trips(count: int = 2000) -> float:
    """CPU s of `count` pipe round trips between this process and a child, both sides counted."""
    from_parent, to_child = os.pipe()  # (read end, write end)
    from_child, to_parent = os.pipe()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.process_time()
    pid = os.fork()
    if pid == 0:  # the child: echo each byte back, then leave at once (never run the parent's code)
        try:
            for _ in range(count):
                os.read(from_parent, 1)
                os.write(to_parent, b"x")
        finally:
            os._exit(0)
    for _ in range(count):
        os.write(to_child, b"x")
        os.read(from_child, 1)
    os.waitpid(pid, 0)
    mine = time.process_time() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    for fd in (to_child, from_parent, from_child, to_parent):
        os.close(fd)
    return mine + (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def _median_ms(work: Callable[[], None]) -> float:
    work()  # warm
    times = []
    for _ in range(REPEATS):
        start = time.thread_time()
        work()
        times.append(1000.0 * (time.thread_time() - start))
    return statistics.median(times)


def machine_speed() -> dict[str, float]:
    """{"python_ms": ..., "opencv_ms": ..., "wakeup_us": ...}: each workload's CPU now (smaller is faster)."""
    scan, restore = _face_scan()
    try:
        speed = {"python_ms": round(_median_ms(_python_loop), 1), "opencv_ms": round(_median_ms(scan), 1)}
    finally:
        restore()
    trips = sorted(_round_trips() for _ in range(REPEATS))
    speed["wakeup_us"] = round(1e6 * trips[REPEATS // 2] / 2000, 1)
    return speed


def describe(before: dict[str, float], after: dict[str, float] | None = None) -> str:
    """One line for a bench's report."""
    def both(key: str) -> str:
        return f"{before[key]:.0f}" + (f" / {after[key]:.0f}" if after else "")
    when = "before / after" if after else "now"
    return (f"this machine's speed ({when}; smaller is faster, python -m bench.machine_speed): a fixed Python loop "
            f"{both('python_ms')} ms, a fixed face scan {both('opencv_ms')} ms, a wake-up "
            f"{both('wakeup_us')} us")


if __name__ == "__main__":
    speed = machine_speed()
    print(describe(speed))
    print(json.dumps(speed))
