"""The network monitor reports a dead arbiter as gone, and its return when it is started again.

Before: the monitor's latched arbitration topic kept naming the last holder of a killed arbiter for good ("nothing
reports the death"). Now an arbiter whose ~status has been silent for 3 s is `gone` there and the monitor's
/diagnostics status turns ERROR; a status from a restarted (respawned) node brings the holder back.
"""
from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

# prints each arbitration message's text on a line of its own, as it comes
LISTEN = """
import sys, rospy
from diagnostic_msgs.msg import DiagnosticStatus
rospy.init_node("listen", anonymous=True)
rospy.Subscriber("/net_monitor/arbitration", DiagnosticStatus,
                 lambda m: print(m.level, m.message, flush=True))
rospy.spin()
"""
DEADLINE = 40.0


def start_arbiter(ros_processes) -> subprocess.Popen:
    return ros_processes.start([sys.executable, "nodes/suppressor", "__name:=arb", "upper:=/u", "lower:=/l",
                                "output:=/o", "_time_constant:=0.5", "_type:=std_msgs/Float64"])


def wait_line(listener: subprocess.Popen, text: str) -> str:
    end = time.monotonic() + DEADLINE  # wall clock: processes starting and dying
    while time.monotonic() < end:
        line = listener.stdout.readline()
        if text in line:
            return line
        assert line, "the listener ended"
    raise AssertionError(f"no arbitration message with {text!r} within {DEADLINE} s")


@pytest.mark.timeout(150)
def test_monitor_reports_a_dead_arbiter_as_gone_and_its_return(ros_processes):
    arbiter = start_arbiter(ros_processes)
    ros_processes.start([sys.executable, "nodes/monitor", "__name:=net_monitor", "_network:=net",
                         '_arbiters:=[{name: arb, kind: suppressor, upper: a.b, lower: c.d}]'])
    listener = ros_processes.start([sys.executable, "-c", LISTEN], stdout=subprocess.PIPE)
    assert wait_line(listener, "arb: lower c.d").startswith("0 ")
    arbiter.send_signal(signal.SIGKILL)
    arbiter.wait()
    gone = wait_line(listener, "arb: gone")
    assert gone.startswith("2 ") and "no status for 3 s" in gone
    start_arbiter(ros_processes)  # as roslaunch's respawn would
    assert wait_line(listener, "arb: lower c.d").startswith("0 ")
