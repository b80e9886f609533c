"""An arbiter reports a window that ran out with no message to announce it within EXPIRY_CHECK_PERIOD, not at
the next once-a-second status (before: up to 1 s late, so the recorder and the monitor credited a dead upper
line with control it no longer had).

Both runtimes are driven on a clock the test owns (LocalRuntime's own, and /clock under /use_sim_time for the
ROS node), so the check is about time on that clock, never about how fast this machine is.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import Float64

from subsumption import LocalRuntime
from subsumption.arbiter import EXPIRY_CHECK_PERIOD, STATUS_PERIOD, Arbiter

HERE = Path(__file__).resolve()
T = 0.5


def _holder(msg: DiagnosticStatus) -> str:
    return {kv.key: kv.value for kv in msg.values}["in_control"]


def test_local_arbiter_reports_expiry_within_the_check_period():
    runtime = LocalRuntime()
    Arbiter(runtime.node("arb", remap={"upper": "/upper", "lower": "/lower", "output": "/out"}), "suppressor", T,
            Float64)
    heard: list[tuple[float, str]] = []
    runtime.node("listener").subscribe("/arb/status", DiagnosticStatus,
                                       lambda msg: heard.append((runtime.now(), _holder(msg))))
    upper = runtime.node("sender").publisher("/upper", Float64)
    runtime.run_until(0.23)  # between two periodic statuses
    upper.publish(Float64(1.0))
    runtime.run_until(0.23 + T + EXPIRY_CHECK_PERIOD + 1e-6)
    assert heard[-1] == (heard[-1][0], "lower") and heard[-1][0] < STATUS_PERIOD, heard


def _helper() -> None:
    """Owns /clock: starts at 100 s, one upper message at 100.2 s, then steps to 100.85 s and holds there."""
    import rospy
    from rosgraph_msgs.msg import Clock

    rospy.init_node("helper", anonymous=True, disable_signals=True)
    clock = rospy.Publisher("/clock", Clock, queue_size=10, latch=True)
    heard: list[tuple[float, str]] = []
    now = [100.0]
    rospy.Subscriber("/arb/status", DiagnosticStatus, lambda msg: heard.append((now[0], _holder(msg))))
    upper = rospy.Publisher("/upper", Float64, queue_size=10)

    def set_clock(seconds: float, hold: float = 0.05) -> None:
        now[0] = seconds
        clock.publish(Clock(rospy.Time.from_sec(seconds)))
        time.sleep(hold)

    set_clock(100.0)
    end = time.monotonic() + 30
    while time.monotonic() < end and (upper.get_num_connections() == 0 or not heard):
        set_clock(100.0, 0.1)
    set_clock(100.2, 0.5)
    upper.publish(Float64(1.0))
    time.sleep(0.5)  # wall time for the message to arrive while the clock stands still
    while now[0] < 100.85 - 1e-9:
        set_clock(round(now[0] + 0.05, 2))
    set_clock(100.85, 2.0)  # ... and hold: any report must come from the expiry check, not the 1 s status
    print(json.dumps(heard), flush=True)


def test_ros_arbiter_reports_expiry_within_the_check_period(ros_processes):
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=ros_processes.env, check=True, timeout=15)
    ros_processes.start([sys.executable, "nodes/suppressor", "upper:=/upper", "lower:=/lower", "output:=/out",
                         "__name:=arb", f"_time_constant:={T}", "_type:=std_msgs/Float64"])
    helper = ros_processes.start([sys.executable, str(HERE)], stdout=subprocess.PIPE)
    out, _ = helper.communicate(timeout=60)
    heard = [tuple(item) for item in json.loads(out.strip().splitlines()[-1])]
    after = [(t, holder) for t, holder in heard if t >= 100.2]
    assert ("upper" in {h for _, h in after}) and after[-1][1] == "lower", heard
    # the window closed at 100.7; the clock never reached 101.0, where the periodic status would have said it
    assert max(t for t, _ in after) <= 100.85, heard


if __name__ == "__main__":
    _helper()
