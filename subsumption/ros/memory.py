"""Giving the memory a node has freed back to the system, so that its resident size is what it uses.

A node that reads camera frames handles buffers of about a megabyte each, 30 a second, on several threads
(rospy's socket reader, the newest-frame thread, the callbacks). glibc serves a buffer that large with mmap at
first and gives it back on free, but it raises its mmap threshold to the largest such block freed (up to 32 MB):
from then on frame buffers come from its per-thread arenas, and what is freed there is kept for reuse. When the
machine is loaded the node falls behind, frames pile up in its socket and one read brings several at once: the
buffers of that burst are freed a moment later, but the process stays as large as the burst made it.
Measured (bench.track_memory, docs/faults.md "Memory of the vision nodes"): the detect, track and follow nodes'
resident memory rose by 1-7 MB in steps at such stalls and stayed there, for nothing still in use. The one-hour
soak read that as growth.

So every long-running node process of the package (:func:`subsumption.ros.runtime.start_node`: modules,
groups, arbiters, monitors, the simulator, the terminal), before rospy starts its
threads, asks glibc for one arena (``mallopt(M_ARENA_MAX, 1)``: the threads started later share the main one;
Python's GIL lets one allocate at a time anyway), and a daemon thread calls ``malloc_trim(0)`` every 10 s of wall
time: the free pages of the arena go back to the system (madvise), the top of the heap too, which glibc's trim does
only for the main arena. A burst's buffers are then resident for at most 10 s after they are freed. (Pinning the
mmap threshold instead, so that every frame buffer is mapped and unmapped, also keeps the size flat, but costs a
page fault per 4 kB of every buffer: 0.85 ms per 900 kB buffer against 0.04 ms, measured.)

``SUBSUMPTION_MALLOC=default`` in a node's environment leaves glibc as it is (for comparison:
``bench.track_memory --allocator-default``).
"""
from __future__ import annotations

import ctypes
import os
import threading

from .libc import libc_function

TRIM_EVERY_S = 10.0
M_ARENA_MAX = -8  # mallopt's parameter number (malloc.h)
ENV = "SUBSUMPTION_MALLOC"


def _malloc_trim():
    return libc_function("malloc_trim", [ctypes.c_size_t])


def one_arena() -> bool:
    """Let threads started from now on share the main arena (glibc fixes its arena limit when a thread first
    needs a new arena, so call this before starting threads); whether glibc took it."""
    mallopt = libc_function("mallopt", [ctypes.c_int, ctypes.c_int])
    return bool(mallopt and mallopt(M_ARENA_MAX, 1))


class FreedMemoryReturner:
    """A daemon thread that calls malloc_trim(0) every `every_s` seconds of wall time (process housekeeping, not
    robot behaviour: it must go on whether or not simulated time does)."""

    def __init__(self, every_s: float = TRIM_EVERY_S) -> None:
        self.every_s = every_s
        self.trims = 0
        self._trim = _malloc_trim()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="malloc_trim", daemon=True)

    @property
    def available(self) -> bool:
        """Whether the C library has malloc_trim (glibc)."""
        return self._trim is not None

    def start(self) -> "FreedMemoryReturner":
        """Start the thread (nothing without glibc); returns self."""
        if self._trim is not None:
            self._thread.start()
        return self

    def trim_now(self) -> bool:
        """Return the free pages now; whether any memory was given back (False without glibc)."""
        if self._trim is None:
            return False
        self.trims += 1
        return bool(self._trim(0))

    def stop(self) -> None:
        """End the thread at its next wake-up."""
        self._stop.set()

    def _run(self) -> None:
        while not self._stop.wait(self.every_s):  # wall clock on purpose (see the class)
            self.trim_now()


_returner: FreedMemoryReturner | None = None


def allocator_default(environ=os.environ) -> bool:
    """Whether SUBSUMPTION_MALLOC asks to leave glibc alone ('default'); a ValueError naming it for any value
    but 'default' and 'return' (the default)."""
    value = environ.get(ENV, "return").strip() or "return"
    if value not in ("default", "return"):
        raise ValueError(f"environment variable {ENV} must be 'return' (give freed memory back, the default) or "
                         f"'default' (glibc's own behaviour), got {value!r}")
    return value == "default"


def return_freed_memory() -> FreedMemoryReturner | None:
    """Once per process: one arena, and the thread that trims every TRIM_EVERY_S seconds (call it before other
    threads start); None when SUBSUMPTION_MALLOC=default."""
    global _returner
    if _returner is None and not allocator_default():
        one_arena()
        _returner = FreedMemoryReturner(TRIM_EVERY_S).start()
    return _returner


__all__ = ["FreedMemoryReturner", "return_freed_memory", "one_arena", "allocator_default", "TRIM_EVERY_S", "ENV"]
