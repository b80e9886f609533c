"""subsumption.ros.thread_names: a thread named for the system, as `top -H` and /proc show it."""
from __future__ import annotations

import sys
import threading

import pytest

from subsumption.ros.thread_names import name_this_thread, os_thread_name


def test_a_node_s_thread_name_is_its_last_part_within_15_bytes():
    assert os_thread_name("/track") == "track"
    assert os_thread_name("/patrol/track") == "track"
    assert os_thread_name("/inhibitor_wander_heading") == "inhibitor_wande"
    assert len(os_thread_name("/" + "é" * 20).encode()) <= 15  # never half a character


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="thread names are Linux's")
def test_the_system_sees_the_name_a_thread_gives_itself():
    seen: dict = {}

    def run() -> None:
        seen["named"] = name_this_thread("detect")
        with open(f"/proc/self/task/{threading.get_native_id()}/comm") as comm:
            seen["comm"] = comm.read().strip()

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    assert seen == {"named": True, "comm": "detect"}
