"""The network monitor watches the life of every node, not only arbiters (issue 31, item 1).

Before: SIGKILL of a module node (detect, track, move_base, amcl) left /diagnostics, /rosout and the record
silent. Now the monitor reports the death on its ``~liveness`` topic, on /rosout (ERROR, naming the node, the
modules it runs, how it died and what a critical node's death loses) and on /diagnostics (an ERROR under the
node's own name), and reports the node's return under a new pid as a respawn. How fast is printed (pytest -s),
not asserted: bench/chaos.py measures it.
"""
from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

LISTEN = """
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Log
rospy.init_node("listen", anonymous=True)
def values(m): return " ".join(f"{kv.key}={kv.value}" for kv in m.values)
rospy.Subscriber("/net_monitor/liveness", DiagnosticStatus,
                 lambda m: print("EVENT", m.level, m.name, m.message, "|", values(m), flush=True))
rospy.Subscriber("/rosout", Log, lambda m: m.level >= Log.ERROR and print("ROSOUT", m.msg, flush=True))
rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: [print("DIAG", s.level, s.name, s.message, flush=True)
                 for s in a.status if s.name == "/wander" and s.level == 2])
rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: [print("LIVE", kv.value, flush=True)
                 for s in a.status for kv in s.values if kv.key == "liveness"])
rospy.spin()
"""
DEADLINE = 40.0
NODES = ('_nodes:=[{name: wander, modules: [wander], critical: navigation, respawn: true, reports: true}, '
         '{name: gone_before, modules: [x], critical: "", respawn: false, reports: true}]')


def start_module(ros_processes) -> subprocess.Popen:
    return ros_processes.start([sys.executable, "nodes/module", "__name:=wander",
                                "_class:=robots.wander.level1:Wander"])


def wait_for(listener: subprocess.Popen, *texts: str) -> str:
    """The first line the listener printed (before or after this call) holding every text."""
    seen: list[str] = listener.seen  # type: ignore[attr-defined]
    end = time.monotonic() + DEADLINE  # wall clock: processes starting and dying
    index = 0
    while time.monotonic() < end:
        while index < len(seen):
            if all(text in seen[index] for text in texts):
                return seen.pop(index)
            index += 1
        line = listener.stdout.readline()
        assert line, "the listener ended"
        seen.append(line)
    raise AssertionError(f"no line with {texts} within {DEADLINE} s")


@pytest.mark.timeout(150)
def test_a_killed_module_is_reported_everywhere_and_its_respawn_recorded(ros_processes):
    module = start_module(ros_processes)
    listener = ros_processes.start([sys.executable, "-c", LISTEN], stdout=subprocess.PIPE)
    listener.seen = []  # type: ignore[attr-defined]
    ros_processes.start([sys.executable, "nodes/monitor", "__name:=net_monitor", "_network:=net",
                         "_arbiters:=[]", NODES])
    # alive: the monitor has probed the module and knows its pid (the other node never runs)
    wait_for(listener, "LIVE 1/2 nodes alive")
    old_pid = module.pid
    killed = time.monotonic()
    module.send_signal(signal.SIGKILL)
    module.wait()
    event = wait_for(listener, "EVENT 2 /wander")
    print(f"\ndeath reported {time.monotonic() - killed:.2f} s after SIGKILL: {event.strip()}")
    assert "event=death" in event and "killed" in event and "critical=navigation" in event
    assert "navigation lost" in event and f"pid={old_pid}" in event
    assert "/wander" in wait_for(listener, "ROSOUT", "/wander", "died")
    assert "dead" in wait_for(listener, "DIAG 2 /wander")
    new = start_module(ros_processes)  # as roslaunch's respawn would
    back = wait_for(listener, "EVENT 0 /wander")
    assert "event=respawn" in back and f"pid={new.pid}" in back
    # a node that never ran is not reported dead (it is "starting": roslaunch's own wait names it)
    listener.send_signal(signal.SIGINT)
    rest = listener.communicate(timeout=20)[0]
    assert "gone_before" not in rest + "".join(listener.seen)
