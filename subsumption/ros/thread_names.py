"""Operating-system names for a node process's threads, so that ``top -H -p PID``, ``ps -L`` and
``/proc/PID/task/*/comm`` tell them apart: a group's workers (:mod:`subsumption.ros.workers`, named after the
group) from the process's timer thread (``timers``) and rospy's own.

Python names its threads for itself only, and every one of them shows as the interpreter to the system. Linux keeps
a thread name of 15 bytes (``prctl(PR_SET_NAME)``); elsewhere nothing is named.
"""
from __future__ import annotations

import ctypes
import sys

from .libc import libc_function

PR_SET_NAME = 15  # prctl's option number (linux/prctl.h)
MAX_BYTES = 15    # the kernel's limit, without the terminating zero


def os_thread_name(node_name: str) -> str:
    """The name a thread running node `node_name` gets: its last part without the namespace (``/patrol/track`` ->
    ``track``), cut to 15 bytes."""
    base = node_name.rstrip("/").rsplit("/", 1)[-1] or node_name
    return base.encode("utf-8")[:MAX_BYTES].decode("utf-8", errors="ignore")


def name_this_thread(name: str) -> bool:
    """Give the calling thread `name` (cut to 15 bytes) as the system sees it; False where that cannot be done."""
    if not sys.platform.startswith("linux"):
        return False
    prctl = libc_function("prctl", [ctypes.c_int, ctypes.c_char_p, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong])
    return prctl is not None and prctl(PR_SET_NAME, name.encode("utf-8")[:MAX_BYTES], 0, 0, 0) == 0


__all__ = ["os_thread_name", "name_this_thread"]
