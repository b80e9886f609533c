"""The arbiter nodes under faults: a mis-typed line that speaks first, and an input queue that overflows.

As in test_arbiter_ros.py, the publishers live in a helper process (this file run as a script), because
rospy allows one node per process. The tests judge which messages came through and what ~status counted,
never how fast.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
DEADLINE = 20.0


def _helper(scenario: str, args: dict[str, Any]) -> None:
    import rospy
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import Twist
    from std_msgs.msg import Float64, String

    rospy.init_node("helper", anonymous=True, disable_signals=True)
    lock = threading.Lock()
    heard: list[dict[str, Any]] = []
    statuses: list[dict[str, Any]] = []

    def on_output(msg: rospy.AnyMsg) -> None:
        with lock:
            heard.append({"type": msg._connection_header["type"], "bytes": len(msg._buff)})

    def on_status(msg: DiagnosticStatus) -> None:
        with lock:
            statuses.append({"level": msg.level, "message": msg.message,
                             "values": {kv.key: kv.value for kv in msg.values}})

    def wait_for(condition, what: str) -> None:
        end = time.monotonic() + DEADLINE
        while not condition():
            if time.monotonic() > end:
                raise TimeoutError(f"helper: no {what} within {DEADLINE} s")
            time.sleep(0.01)

    rospy.Subscriber("/out", rospy.AnyMsg, on_output)
    rospy.Subscriber("/arb/status", DiagnosticStatus, on_status)
    if scenario == "upper_first":
        # the lower line's publisher exists (as a module's does from start-up) but has not spoken yet
        lower = rospy.Publisher("/lower", Twist, queue_size=10)
        upper = rospy.Publisher("/upper", String, queue_size=10)
        wait_for(lambda: upper.get_num_connections() > 0 and lower.get_num_connections() > 0, "connections")
        for i in range(20):                 # the upper line speaks first, with the wrong type, for 1 s
            upper.publish(String(f"wrong {i}"))
            time.sleep(0.05)
        wait_for(lambda: any(s["level"] == DiagnosticStatus.ERROR for s in list(statuses)), "error status")
        end = time.monotonic() + DEADLINE   # then the lower line: its Twists must come through
        while time.monotonic() < end and len([h for h in list(heard) if h["type"] == "geometry_msgs/Twist"]) < 5:
            lower.publish(Twist())
            time.sleep(0.05)
        time.sleep(0.3)
    elif scenario == "overflow":
        count = args["count"]
        lower = rospy.Publisher("/lower", Float64, queue_size=count + 10, tcp_nodelay=True)
        wait_for(lambda: lower.get_num_connections() > 0, "connection")
        lower.publish(Float64(0.0))
        wait_for(lambda: any(int(s["values"]["lower_passed"]) >= 1 for s in list(statuses)), "first message")
        print("ready", flush=True)
        sys.stdin.readline()                # the test has stopped the arbiter (SIGSTOP)
        for i in range(count):
            lower.publish(Float64(float(i)))
        print("sent", flush=True)
        sys.stdin.readline()                # ... and let it go on (SIGCONT)

        def accounted() -> bool:
            last = statuses[-1]["values"] if statuses else None
            return last is not None and int(last["lower_passed"]) + int(last["lower_dropped"]) >= count + 1

        end = time.monotonic() + DEADLINE
        while time.monotonic() < end and not accounted():
            time.sleep(0.05)
        time.sleep(1.5)                     # one more periodic status: nothing counted twice
    with lock:
        print(json.dumps({"heard": heard, "statuses": statuses}), flush=True)


# ------------------------------------------------------------------------------------------------------------
from conftest import output_of  # noqa: E402


def start_suppressor(ros_processes, *extra: str) -> subprocess.Popen:
    return ros_processes.start([sys.executable, "nodes/suppressor", "upper:=/upper", "lower:=/lower",
                                "output:=/out", "__name:=arb", "_time_constant:=0.5", *extra])


def helper(ros_processes, scenario: str, **args: Any) -> subprocess.Popen:
    return ros_processes.start([sys.executable, str(HERE), scenario, json.dumps(args)],
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def test_upper_line_speaking_first_with_a_wrong_type_is_refused(ros_processes):
    """Before: the output was advertised as String and every Twist of the lower line was dropped."""
    node = start_suppressor(ros_processes)
    process = helper(ros_processes, "upper_first")
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    result = json.loads(out.strip().splitlines()[-1])
    assert {h["type"] for h in result["heard"]} == {"geometry_msgs/Twist"}
    assert len(result["heard"]) >= 5
    error = next(s for s in result["statuses"] if s["level"] == 2)["message"]
    assert "/upper" in error and "std_msgs/String" in error and "geometry_msgs/Twist" in error
    assert result["statuses"][-1]["values"]["upper_passed"] == "0"
    assert node.poll() is None
    assert "std_msgs/String" in output_of(node)


def test_declared_type_is_advertised_at_start_and_enforced(ros_processes):
    """With ~type (set by every generated launch file) the output exists before any message arrives."""
    node = start_suppressor(ros_processes, "_type:=geometry_msgs/Twist")
    env = ros_processes.env
    end = time.monotonic() + DEADLINE
    topic_type = ""
    while time.monotonic() < end and topic_type != "geometry_msgs/Twist":
        topic_type = subprocess.run(["rostopic", "type", "/out"], env=env, capture_output=True, text=True,
                                    timeout=DEADLINE).stdout.strip()
        time.sleep(0.2)
    assert topic_type == "geometry_msgs/Twist"
    process = helper(ros_processes, "upper_first")
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    result = json.loads(out.strip().splitlines()[-1])
    assert {h["type"] for h in result["heard"]} == {"geometry_msgs/Twist"}
    assert node.poll() is None


def test_bad_type_parameter_exits_naming_it(ros_processes):
    node = start_suppressor(ros_processes, "_type:=Twist")
    node.wait(timeout=DEADLINE)
    assert node.returncode == 2 and "/arb/type" in output_of(node)


def test_messages_lost_in_the_input_queue_are_counted(ros_processes):
    """The arbiter is stopped (SIGSTOP) while 30,000 lower messages pile up in its socket, then resumed: it
    reads them in large batches and keeps the newest of each. Every message must be accounted for on ~status,
    passed or dropped; before, the discarded ones simply vanished (lower_dropped 0)."""
    count = 30000
    node = start_suppressor(ros_processes)
    process = helper(ros_processes, "overflow", count=count)
    assert process.stdout.readline().strip() == "ready"
    os.kill(node.pid, signal.SIGSTOP)
    try:
        process.stdin.write("go\n")
        process.stdin.flush()
        assert process.stdout.readline().strip() == "sent"
        time.sleep(0.5)
    finally:
        os.kill(node.pid, signal.SIGCONT)
    process.stdin.write("go\n")
    process.stdin.flush()
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    values = json.loads(out.strip().splitlines()[-1])["statuses"][-1]["values"]
    passed, dropped, queue = (int(values[k]) for k in ("lower_passed", "lower_dropped", "lower_queue_dropped"))
    assert passed + dropped == count + 1, values
    assert queue == dropped > 0, values  # nothing was in a window: every drop is a queue drop


if __name__ == "__main__":
    _helper(sys.argv[1], json.loads(sys.argv[2]))
