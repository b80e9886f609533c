"""A node process gives back the memory of a burst of camera-frame buffers (subsumption.ros.memory).

The soak's growth of the vision nodes (docs/faults.md, "Memory of the vision nodes") was glibc keeping what a
burst of ~1 MB frame buffers had used, on several threads, once its mmap threshold had risen past their size.
Here a fresh process does just that, then trims as the node's returner does every 10 s: with the node's memory
setting (one arena) the burst leaves nothing behind; with glibc left alone (SUBSUMPTION_MALLOC=default, the old
behaviour: a trim cannot reach the tops of the threads' own arenas) it keeps tens of MB, which shows the scene is
one that fails without the setting."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

BURST = r"""
import threading
from pathlib import Path
from subsumption.ros.memory import FreedMemoryReturner, return_freed_memory

def anon_mb():
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("RssAnon:"):
            return int(line.split()[1]) / 1024

return_freed_memory()  # what init_node does in every node process, before rospy's threads start
big = bytearray(8 << 20)  # one large block freed: glibc's mmap threshold rises past a frame's size
del big
kept = []

def burst():  # a reader thread that fell behind: 30 frames at once, each decoded to bytes, then dropped
    frames = [bytes(bytearray(900_000)) for _ in range(30)]
    kept.append(bytearray(200_000))
    del frames

start = anon_mb()
threads = [threading.Thread(target=burst) for _ in range(3)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
FreedMemoryReturner().trim_now()  # the returner's next tick (every 10 s in a node)
print(anon_mb() - start)
"""


def _kept_mb(setting: str | None) -> float:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    env.pop("SUBSUMPTION_MALLOC", None)
    if setting is not None:
        env["SUBSUMPTION_MALLOC"] = setting
    done = subprocess.run([sys.executable, "-c", BURST], env=env, cwd=ROOT, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    return float(done.stdout.split()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_a_burst_of_frame_buffers_is_given_back():
    assert _kept_mb("default") > 20.0  # glibc alone keeps the burst (about 36 MB of the 81 MB)
    assert _kept_mb(None) < 4.0


def test_a_bad_setting_names_the_variable():
    from subsumption.ros.memory import allocator_default

    with pytest.raises(ValueError, match="SUBSUMPTION_MALLOC must be 'return'.*got 'off'"):
        allocator_default({"SUBSUMPTION_MALLOC": "off"})
    assert allocator_default({"SUBSUMPTION_MALLOC": "default"}) and not allocator_default({})
