"""A node's one-shot timers are freed once they have fired, and all its timers share one thread. An AFSM starts one per timed state (whenlook: every
0.5-1 s), so a node that kept them all grew by 20 MB an hour (bench.soak: whenlook +41.6% in 55 minutes)."""
from __future__ import annotations

import json
import subprocess
import sys

CHILD = r"""
import gc, json, threading, time, weakref
import rospy
import subsumption.ros.clock_timers as clock_timers
created = []
made = clock_timers.ClockTimer.__init__

def recording(self, *args, **kwargs):
    made(self, *args, **kwargs)
    created.append(weakref.ref(self))

clock_timers.ClockTimer.__init__ = recording
from subsumption.ros.runtime import init_node
node = init_node("timers", argv=["timers"])
fired = []
for i in range(200):
    node.call_later(0.001, lambda: fired.append(1))
periodic = node.call_every(0.05, lambda: None)
end = time.monotonic() + 20
while len(fired) < 200 and time.monotonic() < end:
    time.sleep(0.05)
time.sleep(0.2)  # the last callbacks return
gc.collect()
print(json.dumps({"fired": len(fired), "alive": sum(ref() is not None for ref in created),
                  "timer_threads": sum(t.name == "timers" for t in threading.enumerate())}))
rospy.signal_shutdown("done")
"""


def test_one_shot_timers_are_freed_after_they_fire_and_periodic_ones_live_on(ros_master):
    done = subprocess.run([sys.executable, "-c", CHILD], env=ros_master, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["fired"] == 200
    assert result["alive"] == 1  # the periodic timer only
    assert result["timer_threads"] == 1  # 201 timers, one thread (subsumption.ros.clock_timers)
