"""The upper line is never cut in an arbiter's input queue, however far the node falls behind.

bench.arbiter_soak found an inhibitor on a loaded machine losing 6 % of its upper line: the node kept only the newest
100 messages of each read of a socket, for both lines. The upper line is the higher level's say; it is now
taken whole (it is in memory already), and only the lower line is cut (and counted). The node is stopped with
SIGSTOP while thousands of messages pile up on both lines, then resumed.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve()
COUNT = 5000


def _helper() -> None:
    import rospy
    from diagnostic_msgs.msg import DiagnosticStatus
    from std_msgs.msg import Float64

    rospy.init_node("helper", anonymous=True, disable_signals=True)
    statuses: list[dict[str, str]] = []
    rospy.Subscriber("/arb/status", DiagnosticStatus, lambda msg: statuses.append(
        {kv.key: kv.value for kv in msg.values} | {"level": msg.level, "message": msg.message}))
    upper = rospy.Publisher("/upper", Float64, queue_size=COUNT + 10, tcp_nodelay=True)
    lower = rospy.Publisher("/lower", Float64, queue_size=COUNT + 10, tcp_nodelay=True)
    end = time.monotonic() + 20
    while time.monotonic() < end and (upper.get_num_connections() == 0 or lower.get_num_connections() == 0
                                      or not statuses):
        time.sleep(0.05)
    print("ready", flush=True)
    sys.stdin.readline()  # the node is stopped
    for i in range(COUNT):
        upper.publish(Float64(-1.0 - i))
        lower.publish(Float64(1.0 + i))
    print("sent", flush=True)
    sys.stdin.readline()  # ... and goes on

    def done() -> bool:
        last = statuses[-1] if statuses else {}
        return bool(last) and int(last["upper_passed"]) + int(last["upper_dropped"]) >= COUNT \
            and int(last["lower_passed"]) + int(last["lower_dropped"]) >= COUNT

    end = time.monotonic() + 30
    while time.monotonic() < end and not done():
        time.sleep(0.05)
    warned = [s["message"] for s in statuses if s["level"] == DiagnosticStatus.WARN]
    time.sleep(3.5)  # two status periods without a loss (and the next status): OK again
    print(json.dumps(statuses[-1] | {"warned": warned}), flush=True)


def test_upper_line_is_taken_whole_when_the_node_falls_behind(ros_processes):
    node = ros_processes.start([sys.executable, "nodes/inhibitor", "upper:=/upper", "lower:=/lower",
                                "output:=/out", "__name:=arb", "_time_constant:=0.5", "_type:=std_msgs/Float64"])
    helper = ros_processes.start([sys.executable, str(HERE)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                 stderr=subprocess.DEVNULL)
    assert helper.stdout.readline().strip() == "ready"
    os.kill(node.pid, signal.SIGSTOP)
    try:
        helper.stdin.write("go\n")
        helper.stdin.flush()
        assert helper.stdout.readline().strip() == "sent"
        time.sleep(0.5)
    finally:
        os.kill(node.pid, signal.SIGCONT)
    out, _ = helper.communicate("go\n", timeout=60)
    status = json.loads(out.strip().splitlines()[-1])
    assert int(status["upper_passed"]) + int(status["upper_dropped"]) == COUNT, status
    assert status["upper_queue_dropped"] == "0", status
    lower = int(status["lower_passed"]) + int(status["lower_dropped"])
    assert lower == COUNT and int(status["lower_queue_dropped"]) > 0, status  # the lower line is cut, and counted
    # ... and ~status said so while it dropped (WARN, as a module node does), then went back to OK
    assert status["warned"] and "messages lost in the input queue" in status["warned"][0], status
    assert status["level"] == 0, status


if __name__ == "__main__":
    _helper()
