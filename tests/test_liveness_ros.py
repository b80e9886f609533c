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
import threading
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Log
rospy.init_node("listen", anonymous=True)
lock = threading.Lock()
def say(*parts):  # one whole line at a time: the subscribers' threads print at once (print writes part by part)
    with lock:
        print(*parts, flush=True)
def values(m): return " ".join(f"{kv.key}={kv.value}" for kv in m.values)
events = rospy.Subscriber("/net_monitor/liveness", DiagnosticStatus,
                          lambda m: say("EVENT", m.level, m.name, m.message, "|", values(m)))
rospy.Subscriber("/rosout", Log, lambda m: m.level >= Log.ERROR and say("ROSOUT", m.msg))
def linked(_event):  # the events topic is not latched: an event sent before the link is made is not heard
    if events.get_num_connections() > 0 and not linked.said:
        linked.said = True
        say("LINKED")
linked.said = False
rospy.Timer(rospy.Duration(0.1), linked)
rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: [say("DIAG", s.level, s.name, s.message)
                 for s in a.status if s.name == "/wander" and s.level == 2])
rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: [say("LIVE", kv.value)
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
    wait_for(listener, "LINKED")  # and it hears the monitor's events
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


HUSHED = """
import threading, time, rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Clock
rospy.init_node("hushed")  # /use_sim_time is set: this node's clock is the one it publishes, at 3x real time
clock = rospy.Publisher("/clock", Clock, queue_size=10)
status = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)
quiet_since = []
def on_event(m):
    if m.name == "/hushed" and quiet_since:
        print("DEATH", round(time.monotonic() - quiet_since[0], 2), m.message, flush=True)
        rospy.signal_shutdown("reported")
rospy.Subscriber("/net_monitor/liveness", DiagnosticStatus, on_event)
start, simulated, spoke = time.monotonic(), 0.0, -1.0
while not rospy.is_shutdown() and time.monotonic() - start < 40:
    simulated += 0.03
    clock.publish(Clock(rospy.Time.from_sec(simulated)))
    if time.monotonic() - start < 6.0:  # speaks once a simulated second, then is silent but alive
        if simulated - spoke >= 1.0:
            spoke = simulated
            status.publish(DiagnosticArray(status=[DiagnosticStatus(0, "/hushed", "ok", "", [])]))
    elif not quiet_since:
        quiet_since.append(time.monotonic())
    time.sleep(0.01)
"""


@pytest.mark.timeout(90)
def test_a_silent_node_under_a_fast_clock_is_hung_after_ten_seconds_of_wall_clock_too(ros_processes):
    """Simulated time at 3x: a node that stops speaking but answers its pid is called hung after HUNG seconds on
    both clocks (10 s of wall clock, not the 3.3 s that 10 simulated seconds take); a busy level's process at a
    fast rate is not a false alarm."""
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=ros_processes.env, check=True, timeout=20)
    ros_processes.start([sys.executable, "nodes/monitor", "__name:=net_monitor", "_network:=net", "_arbiters:=[]",
                         "_nodes:=[{name: hushed, modules: [h], critical: '', respawn: false, reports: true}]"])
    hushed = ros_processes.start([sys.executable, "-c", HUSHED], stdout=subprocess.PIPE)
    out = hushed.communicate(timeout=60)[0]
    print(out)
    death = [line for line in out.splitlines() if line.startswith("DEATH")]
    assert death and "hung" in death[0], out
    assert float(death[0].split()[1]) >= 9.0, death  # on ROS time alone: about 3.3 s
