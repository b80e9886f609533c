"""The generic arbiter nodes on a real (private) ROS master.

rospy allows one node per process, so the publishers and subscribers live in a helper: this very file, run
as a script (``python tests/test_arbiter_ros.py SCENARIO JSON``). The helper plays a scripted sequence,
waits for conditions (a connection, a first relayed message) with generous deadlines instead of fixed
sleeps wherever it can, and prints what arrived as one JSON line. The tests only judge which messages came
through, never how fast.
"""
from __future__ import annotations

import json
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable

HERE = Path(__file__).resolve()
DEADLINE = 20.0  # seconds for anything that should take well under one


# ------------------------------------------------------------------------------------------------------------
# The helper (runs in its own process, under the private master)
# ------------------------------------------------------------------------------------------------------------

def _helper(scenario: str, args: dict[str, Any]) -> dict[str, Any]:
    import roslib.message
    import rospy
    from diagnostic_msgs.msg import DiagnosticStatus
    from rosgraph_msgs.msg import Clock

    rospy.init_node("helper", anonymous=True, disable_signals=True)
    heard: list[dict[str, Any]] = []
    statuses: list[dict[str, Any]] = []
    lock = threading.Lock()

    def msg_class(type_name: str) -> type:
        return roslib.message.get_message_class(type_name)

    def make(type_name: str, tag: str) -> Any:
        msg = msg_class(type_name)()
        if hasattr(msg, "header"):
            msg.header.frame_id = tag
        elif isinstance(getattr(msg, "data", None), str):
            msg.data = tag
        elif hasattr(msg, "data"):
            msg.data = 1.5
        if type_name == "sensor_msgs/LaserScan":
            msg.angle_min, msg.angle_increment, msg.range_max = -3.14, 0.0175, 10.0
            msg.ranges = [0.5 + 0.01 * i for i in range(360)]
        return msg

    def tag_of(msg: Any) -> str:
        return msg.header.frame_id if hasattr(msg, "header") else str(msg.data)

    def on_output(msg: Any) -> None:
        entry = {"tag": tag_of(msg), "type": msg._connection_header["type"], "at": time.monotonic()}
        if hasattr(msg, "ranges"):
            entry["ranges"] = list(msg.ranges)
        with lock:
            heard.append(entry)

    def on_status(msg: DiagnosticStatus) -> None:
        with lock:
            statuses.append({"level": msg.level, "message": msg.message, "at": time.monotonic(),
                             "values": {kv.key: kv.value for kv in msg.values}})

    out_type = args["lower_type"]
    upper = rospy.Publisher(args["upper"], msg_class(args["upper_type"]), queue_size=100, tcp_nodelay=True)
    lower = rospy.Publisher(args["lower"], msg_class(out_type), queue_size=100, tcp_nodelay=True)
    rospy.Subscriber(args["output"], msg_class(out_type), on_output, tcp_nodelay=True)
    rospy.Subscriber(args["status"], DiagnosticStatus, on_status)

    clock_value = [float(args.get("clock", 0.0))]
    if "clock" in args:
        clock_pub = rospy.Publisher("/clock", Clock, queue_size=1)

        def drive_clock() -> None:
            while not rospy.is_shutdown():
                clock_pub.publish(Clock(rospy.Time.from_sec(clock_value[0])))
                time.sleep(0.01)

        threading.Thread(target=drive_clock, daemon=True).start()

    def wait_for(condition: Callable[[], bool], what: str, deadline: float = DEADLINE) -> None:
        end = time.monotonic() + deadline
        while not condition():
            if time.monotonic() > end:
                raise TimeoutError(f"helper: no {what} within {deadline} s")
            time.sleep(0.01)

    def tags() -> list[str]:
        with lock:
            return [h["tag"] for h in heard]

    def poll_lower_until_passes(prefix: str) -> float:
        """Publish lower messages every 50 ms until one is relayed; return when (monotonic) it was sent."""
        sent: dict[str, float] = {}
        end = time.monotonic() + DEADLINE
        i = 0
        while time.monotonic() < end:
            tag = f"{prefix}{i}"
            sent[tag] = time.monotonic()
            lower.publish(make(out_type, tag))
            i += 1
            for _ in range(5):
                time.sleep(0.01)
                passed = [t for t in tags() if t.startswith(prefix)]
                if passed:
                    return sent[passed[0]]
        raise TimeoutError(f"helper: no {prefix}* message relayed within {DEADLINE} s")

    def burst(publisher: rospy.Publisher, type_name: str, prefix: str, count: int, period: float) -> None:
        for i in range(count):
            publisher.publish(make(type_name, f"{prefix}{i}"))
            time.sleep(period)

    wait_for(lambda: upper.get_num_connections() > 0 and lower.get_num_connections() > 0, "arbiter connection")
    # The arbiter advertises its output when the first lower message tells it the type: warm up until the
    # relay path is connected end to end.
    poll_lower_until_passes("warm")
    result: dict[str, Any] = {}

    if scenario == "window":
        T = args["T"]
        upper.publish(make(args["upper_type"], "u1"))
        t_upper = time.monotonic()
        # topics are separate connections, unordered between them: the arbiter must have seen u1 first
        wait_for(lambda: any(s["values"]["in_control"] == "upper" for s in list(statuses)), "upper in control")
        burst(lower, out_type, "inside", 5, 0.02)             # ~0.1 s after the upper message: all inside T
        result["first_after_sent_after"] = poll_lower_until_passes("after") - t_upper
        burst(lower, out_type, "tail", 3, 0.02)
        wait_for(lambda: "tail2" in tags(), "tail messages")
        result["T"] = T
    elif scenario == "sim":
        clock_value[0] = 100.0
        time.sleep(0.1)
        upper.publish(make(out_type, "u1"))
        wait_for(lambda: "u1" in tags(), "relayed upper message")
        burst(lower, out_type, "frozen", 15, 0.1)             # 1.5 s of wall clock, 0 s of ROS time (T = 0.5)
        clock_value[0] = 100.6                                # past the window in ROS time
        poll_lower_until_passes("advanced")
        upper.publish(make(out_type, "u2"))
        wait_for(lambda: "u2" in tags(), "second upper message")
        clock_value[0] = 50.0                                 # time jumps backwards: window must reset
        poll_lower_until_passes("back")
        t_back = time.monotonic()
        for _ in range(60):                                   # ROS time 50 -> 56 in 3 s of wall clock
            clock_value[0] += 0.1
            time.sleep(0.05)
        with lock:
            result["statuses_after_jump"] = len([s for s in statuses if s["at"] > t_back])
    elif scenario == "mismatch":
        end = time.monotonic() + DEADLINE
        while not any(s["level"] == DiagnosticStatus.ERROR for s in list(statuses)):
            if time.monotonic() > end:
                raise TimeoutError("helper: no error status")
            upper.publish(make(args["upper_type"], "wrong"))
            time.sleep(0.1)
        burst(lower, out_type, "late", 3, 0.02)
    with lock:
        result.update(heard=heard, statuses=statuses)
    return result


# ------------------------------------------------------------------------------------------------------------
# The tests
# ------------------------------------------------------------------------------------------------------------

from conftest import output_of  # noqa: E402  (here, not at the top: the helper above runs without pytest)

TOPICS = {"upper": "/avoid/heading", "lower": "/runaway/heading", "output": "/turn/heading"}


def start_arbiter(ros_processes, kind: str, T: Any = None, name: str = "arb", use_rosrun: bool = True,
                  topics: dict[str, str] = TOPICS, extra: tuple[str, ...] = ()) -> subprocess.Popen:
    remaps = [f"{line}:={topic}" for line, topic in topics.items()] + [f"__name:={name}", *extra]
    if T is not None:
        remaps.append(f"_time_constant:={T}")
    command = ["rosrun", "subsumption", kind] if use_rosrun else [sys.executable, f"nodes/{kind}"]
    return ros_processes.start(command + remaps)


def run_helper(ros_processes, scenario: str, **args: Any) -> dict[str, Any]:
    args = {**TOPICS, "status": "/arb/status", "upper_type": "std_msgs/String",
            "lower_type": "std_msgs/String", **args}
    helper = ros_processes.start([sys.executable, str(HERE), scenario, json.dumps(args)],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = helper.communicate(timeout=45)
    assert helper.returncode == 0, f"helper failed:\n{err}"
    return json.loads(out.strip().splitlines()[-1])


def stop(process: subprocess.Popen) -> str:
    """Stop one node (by its pid, SIGTERM) and return everything it printed."""
    process.terminate()
    process.wait(timeout=10)
    return output_of(process)


def real(heard: list[dict[str, Any]]) -> list[str]:
    return [h["tag"] for h in heard if not h["tag"].startswith("warm")]


def check_window(result: dict[str, Any], kind: str) -> None:
    tags = real(result["heard"])
    assert not [t for t in tags if t.startswith("inside")], f"lower messages inside the window passed: {tags}"
    assert ("u1" in tags) is (kind == "suppressor")
    # the first lower message to pass was sent about T after the upper one (a window that did not hold would
    # let "after0", sent ~0.1 s after it, through); the margin is generous, this is not a latency check
    assert result["first_after_sent_after"] > 0.6 * result["T"]
    assert [t for t in tags if t.startswith("tail")] == ["tail0", "tail1", "tail2"]


def test_suppressor_relays_strings(ros_processes):
    node = start_arbiter(ros_processes, "suppressor", 1.0)
    result = run_helper(ros_processes, "window", T=1.0)
    check_window(result, "suppressor")
    assert {h["type"] for h in result["heard"]} == {"std_msgs/String"}
    status = result["statuses"][-1]["values"]
    assert status["kind"] == "suppressor" and status["upper_passed"] == "1" and int(status["lower_dropped"]) >= 5
    assert node.poll() is None


def test_inhibitor_relays_laser_scans_with_any_upper_type(ros_processes):
    """Bytes of a larger type pass untouched, published as that type; the inhibiting line is std_msgs/Empty."""
    start_arbiter(ros_processes, "inhibitor", 0.8, use_rosrun=False, extra=("_queue_size:=10",))  # queued path
    result = run_helper(ros_processes, "window", T=0.8, lower_type="sensor_msgs/LaserScan",
                        upper_type="std_msgs/Empty")
    check_window(result, "inhibitor")
    assert {h["type"] for h in result["heard"]} == {"sensor_msgs/LaserScan"}
    float32 = [struct.unpack("f", struct.pack("f", 0.5 + 0.01 * i))[0] for i in range(360)]
    assert result["heard"][-1]["ranges"] == float32       # every byte through, as sent
    values = result["statuses"][-1]["values"]
    assert values["upper_passed"] == "0" and values["upper_dropped"] == "1" and int(values["lower_dropped"]) >= 5


def test_window_follows_sim_time(ros_processes):
    import rosgraph

    rosgraph.Master("/test", master_uri=ros_processes.env["ROS_MASTER_URI"]).setParam("/use_sim_time", True)
    start_arbiter(ros_processes, "suppressor", 0.5)
    result = run_helper(ros_processes, "sim", clock=1.0)
    tags = real(result["heard"])
    assert not [t for t in tags if t.startswith("frozen")], "window expired on the wall clock, not on /clock"
    assert any(t.startswith("advanced") for t in tags), "lower line still blocked after /clock passed T"
    assert "u1" in tags and "u2" in tags and any(t.startswith("back") for t in tags)
    # ~status keeps its period after time went backwards (rospy's Timer dies there without reset=True)
    assert result["statuses_after_jump"] >= 2


def test_type_mismatch_is_reported(ros_processes):
    node = start_arbiter(ros_processes, "suppressor", 1.0)
    result = run_helper(ros_processes, "mismatch", upper_type="std_msgs/Float64")
    error = next(s for s in result["statuses"] if s["level"] == 2)["message"]
    for part in ("/avoid/heading", "std_msgs/Float64", "/runaway/heading", "std_msgs/String"):
        assert part in error
    tags = real(result["heard"])
    assert "wrong" not in tags and "1.5" not in tags
    # a mis-typed upper line is a broken level: never relayed, and it takes no control (the lower line goes on)
    assert [t for t in tags if t.startswith("late")] == ["late0", "late1", "late2"]
    env = ros_processes.env
    topic_type = subprocess.run(["rostopic", "type", "/arb/status"], env=env, capture_output=True, text=True,
                                timeout=DEADLINE)
    assert topic_type.stdout.strip() == "diagnostic_msgs/DiagnosticStatus"
    echo = subprocess.run(["rostopic", "echo", "-n", "1", "/arb/status"], env=env, capture_output=True,
                          text=True, timeout=DEADLINE)
    assert "level: 2" in echo.stdout and "std_msgs/Float64" in echo.stdout and "upper_dropped" in echo.stdout
    printed = stop(node)
    assert "/avoid/heading" in printed and "std_msgs/Float64" in printed and "std_msgs/String" in printed


def test_bad_time_constant_exits_naming_the_parameter(ros_processes):
    cases = {"missing": None, "zero": 0, "negative": -1.5, "text": "soon"}
    nodes = {case: start_arbiter(ros_processes, "suppressor", T, name=f"bad_{case}")
             for case, T in cases.items()}
    queue = start_arbiter(ros_processes, "suppressor", 1.0, name="bad_queue", extra=("_queue_size:=-3",))
    for case, node in nodes.items():
        node.wait(timeout=DEADLINE)
        out = output_of(node)
        assert node.returncode != 0, f"{case}: exit status {node.returncode}"
        assert f"/bad_{case}/time_constant" in out, f"{case}: {out}"
    queue.wait(timeout=DEADLINE)
    assert queue.returncode != 0 and "/bad_queue/queue_size" in output_of(queue)


def test_defaulter_node_starts_and_reports_status(ros_processes):
    start_arbiter(ros_processes, "defaulter", 2)
    echo = subprocess.run(["rostopic", "echo", "-n", "1", "/arb/status"], env=ros_processes.env,
                          capture_output=True, text=True, timeout=DEADLINE)
    assert 'name: "/arb"' in echo.stdout and "defaulter" in echo.stdout and "upper line in control" in echo.stdout


if __name__ == "__main__":
    print(json.dumps(_helper(sys.argv[1], json.loads(sys.argv[2]))))
