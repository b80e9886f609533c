"""Module and arbiter nodes under 1,000 fuzzed messages per type, and publishers of the wrong type on their lines.

On a private master: `turn` (subsumption.examples.avoid_demo:Turn, Float64 heading -> Twist cmd_vel, the motors'
line), `feelforce` (robots.wander.level0:Feelforce, LaserScan -> force) and a suppressor with ~type Float64.
A helper process sends each 1,000 fuzzed messages per line: NaN and infinities, extreme and subnormal numbers,
empty and 100 kB frame ids, empty arrays and 250,000-beam scans full of NaN, zeros and negatives. A second
helper publishes std_msgs/String on turn's heading and geometry_msgs/Twist on the suppressor's upper line.

What must hold: no node dies; every message the modules got is accounted for on /diagnostics, as many dropped
as had NaN or inf in a scalar field, as many refused as were of the wrong type; turn never sends a non-finite
command; the suppressor accounts for every message of both lines on ~status and refuses the Twist connection.
The helper paces itself with sentinels (a batch is done when the node's answer to its last message arrives),
so no message is lost in an input queue and the counts are exact on any machine.
"""
from __future__ import annotations

import json
import math
import random
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

HERE = Path(__file__).resolve()
COUNT = 1000
BATCH = 50      # < the module nodes' input queue (100): a batch can never overflow it
WRONG = 200     # messages of the wrong type per line
DEADLINE = 60.0
VALUES = [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -0.0, 0.0, 1e-300]


def fuzz_float(rng: random.Random) -> float:
    return rng.choice(VALUES) if rng.random() < 0.5 else rng.uniform(-10.0, 10.0)


def _wait(condition, what: str, deadline: float = DEADLINE) -> None:
    end = time.monotonic() + deadline  # wall clock: waiting for other processes
    while not condition():
        if time.monotonic() > end:
            raise TimeoutError(f"helper: {what} within {deadline} s")
        time.sleep(0.01)


def _fuzz() -> None:
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from geometry_msgs.msg import Twist, Vector3Stamped
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import Float64

    rospy.init_node("fuzz", disable_signals=True)
    rng = random.Random(15)
    lock = threading.Lock()
    commands: list[tuple[float, float]] = []
    forces: list[str] = []
    diagnostics: dict[str, dict[str, Any]] = {}
    arbiter: list[dict[str, Any]] = []
    out = [0]

    def on_diagnostics(msg: DiagnosticArray) -> None:
        with lock:
            for s in msg.status:
                diagnostics[s.name] = {"level": s.level, "message": s.message,
                                       "values": {kv.key: kv.value for kv in s.values}}

    def on_command(msg: Twist) -> None:
        with lock:
            commands.append((msg.linear.x, msg.angular.z))

    def on_force(msg: Vector3Stamped) -> None:
        with lock:
            forces.append(msg.header.frame_id[:40])

    def on_out(_msg: rospy.AnyMsg) -> None:
        with lock:
            out[0] += 1

    def on_status(msg: DiagnosticStatus) -> None:
        with lock:
            arbiter.append({"level": msg.level, "message": msg.message,
                            "values": {kv.key: kv.value for kv in msg.values}})

    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=100)
    rospy.Subscriber("/turn/cmd_vel", Twist, on_command, queue_size=None)
    rospy.Subscriber("/feelforce/force", Vector3Stamped, on_force, queue_size=None)
    rospy.Subscriber("/fz/out", rospy.AnyMsg, on_out, queue_size=None)
    rospy.Subscriber("/arb/status", DiagnosticStatus, on_status, queue_size=100)
    heading = rospy.Publisher("/fz/heading", Float64, queue_size=COUNT)
    scan = rospy.Publisher("/fz/scan", LaserScan, queue_size=COUNT)
    upper = rospy.Publisher("/fz/upper", Float64, queue_size=COUNT)
    lower = rospy.Publisher("/fz/lower", Float64, queue_size=COUNT)
    _wait(lambda: all(p.get_num_connections() for p in (heading, scan, upper, lower)) and commands == [] and
          {"/turn", "/feelforce"} <= set(diagnostics), "no connections or no diagnostics")
    sent = {"heading_bad": 0, "scan_bad": 0, "upper": 0, "lower": 0}

    # turn: 1,000 fuzzed headings, in batches closed by a sentinel whose command must come back
    for batch in range(COUNT // BATCH):
        for _ in range(BATCH - 1):
            value = fuzz_float(rng)
            sent["heading_bad"] += not math.isfinite(value)
            heading.publish(Float64(value))
        sentinel = 1000.0 + batch
        heading.publish(Float64(sentinel))
        _wait(lambda s=sentinel: any(z == s for _, z in list(commands)), f"turn's answer to sentinel {sentinel}")

    # feelforce: 1,000 fuzzed scans (a sentinel's force carries its frame id back)
    for batch in range(COUNT // BATCH):
        for i in range(BATCH - 1):
            msg = LaserScan(angle_min=-1.0, angle_max=1.0, angle_increment=0.01, range_min=0.1, range_max=5.0)
            msg.header.frame_id = rng.choice(["", "laser", "x" * 100_000, "\x00\x1c\u00e9"])
            if rng.random() < 0.3:
                field = rng.choice(["angle_min", "angle_max", "angle_increment", "time_increment", "scan_time",
                                    "range_min", "range_max"])
                setattr(msg, field, rng.choice([math.nan, math.inf, -math.inf]))
                sent["scan_bad"] += 1
            size = 250_000 if (batch * BATCH + i) % 100 == 7 else rng.randrange(0, 400)
            pool = [math.nan, math.inf, -math.inf, 0.0, -1.0, 1e-30, 3.0]
            msg.ranges = [rng.choice(pool) for _ in range(size)] if size < 1000 else [math.nan, 0.0, 2.0] * (size // 3)
            msg.intensities = [] if rng.random() < 0.9 else [1.0] * size
            scan.publish(msg)
        tag = f"sentinel-{batch}"
        scan.publish(LaserScan(header=rospy.Header(frame_id=tag), angle_increment=0.1, range_min=0.1,
                               range_max=5.0, ranges=[1.0, 2.0]))
        _wait(lambda t=tag: t in list(forces), f"feelforce's answer to {tag}")

    # the suppressor: 1,000 fuzzed Float64 per line, interleaved
    for batch in range(COUNT // BATCH):
        for _ in range(BATCH):
            for line, publisher in (("upper", upper), ("lower", lower)):
                if rng.random() < 0.7:
                    publisher.publish(Float64(fuzz_float(rng)))
                    sent[line] += 1
        time.sleep(0.02)
    print("fuzzed", flush=True)
    sys.stdin.readline()  # the wrong-typed publishers have finished

    def settled() -> bool:
        with lock:
            turn, feel = diagnostics.get("/turn"), diagnostics.get("/feelforce")
            status = arbiter[-1]["values"] if arbiter else None
        return (turn is not None and feel is not None and status is not None
                and int(turn["values"]["refused"]) >= WRONG
                and int(turn["values"]["dropped"]) >= sent["heading_bad"]
                and int(feel["values"]["dropped"]) >= sent["scan_bad"]
                and int(status["upper_passed"]) + int(status["upper_dropped"]) >= sent["upper"] + WRONG
                and int(status["lower_passed"]) + int(status["lower_dropped"]) >= sent["lower"])

    end = time.monotonic() + DEADLINE
    while time.monotonic() < end and not settled():
        time.sleep(0.1)
    time.sleep(1.2)  # one more round of diagnostics: nothing counted twice
    with lock:
        print(json.dumps({"sent": sent, "diagnostics": diagnostics, "arbiter": arbiter[-1], "out": out[0],
                          "arbiter_errors": [s["message"] for s in arbiter if s["level"] == 2][:1],
                          "commands": len(commands), "non_finite_commands":
                              sum(1 for c in commands if not all(map(math.isfinite, c)))}), flush=True)


def _wrong() -> None:
    """std_msgs/String on turn's heading and geometry_msgs/Twist on the suppressor's upper line."""
    import rospy
    from geometry_msgs.msg import Twist
    from std_msgs.msg import String

    rospy.init_node("wrong", disable_signals=True)
    on_heading = rospy.Publisher("/fz/heading", String, queue_size=WRONG)
    on_upper = rospy.Publisher("/fz/upper", Twist, queue_size=WRONG)
    _wait(lambda: on_heading.get_num_connections() and on_upper.get_num_connections(), "no connections")
    time.sleep(0.5)
    for i in range(WRONG):
        on_heading.publish(String(f"not a heading {i}"))
        on_upper.publish(Twist())
        time.sleep(0.005)
    time.sleep(1.0)
    print("done", flush=True)


# ------------------------------------------------------------------------------------------------------------
@pytest.mark.timeout(180)
def _line_after_logs(stream) -> str:
    """The first line a helper process prints that is not one of rospy's log lines ("[WARN] [...]: ...")."""
    while (line := stream.readline()) and line.startswith("["):
        pass
    return line.strip()


def test_nodes_survive_fuzzed_and_mis_typed_messages_and_count_them(ros_processes):
    turn = ros_processes.start([sys.executable, "nodes/module", "__name:=turn",
                                "_class:=subsumption.examples.avoid_demo:Turn", "heading:=/fz/heading"])
    feelforce = ros_processes.start([sys.executable, "nodes/module", "__name:=feelforce",
                                     "_class:=robots.wander.level0:Feelforce", "map:=/fz/scan"])
    arb = ros_processes.start([sys.executable, "nodes/suppressor", "upper:=/fz/upper", "lower:=/fz/lower",
                               "output:=/fz/out", "__name:=arb", "_time_constant:=0.5", "_type:=std_msgs/Float64"])
    fuzz = ros_processes.start([sys.executable, str(HERE), "fuzz"], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    wrong = ros_processes.start([sys.executable, str(HERE), "wrong"], stdout=subprocess.PIPE)
    assert _line_after_logs(fuzz.stdout) == "fuzzed"  # rospy writes its warnings to stdout too
    assert wrong.communicate(timeout=DEADLINE)[0].strip().splitlines()[-1] == "done"
    out, _ = fuzz.communicate("go\n", timeout=DEADLINE + 30)
    result = json.loads(out.strip().splitlines()[-1])
    sent = result["sent"]

    assert [p.poll() for p in (turn, feelforce, arb)] == [None, None, None]  # no node died
    turn_status = result["diagnostics"]["/turn"]["values"]
    assert int(turn_status["dropped"]) == sent["heading_bad"] > 100
    assert int(turn_status["refused"]) == 200
    assert "refused (wrong type)" in turn_status["in heading"] and "dropped (NaN/inf)" in turn_status["in heading"]
    assert result["non_finite_commands"] == 0
    assert result["commands"] == COUNT - sent["heading_bad"]  # every finite heading became a command
    feel_status = result["diagnostics"]["/feelforce"]["values"]
    assert int(feel_status["dropped"]) == sent["scan_bad"] > 100
    assert int(feel_status["refused"]) == 0

    status = result["arbiter"]["values"]
    assert int(status["upper_passed"]) + int(status["upper_dropped"]) == sent["upper"] + 200, status
    assert int(status["lower_passed"]) + int(status["lower_dropped"]) == sent["lower"], status
    assert int(status["upper_passed"]) + int(status["lower_passed"]) == result["out"]
    assert "geometry_msgs/Twist" in result["arbiter_errors"][0]

    from conftest import output_of
    log = output_of(turn)
    assert log.count("wrong type on /fz/heading") == 1, log[-2000:]  # logged once, not 200 times
    assert log.count("NaN or inf") == 1 and "std_msgs/String" in log


if __name__ == "__main__":
    {"fuzz": _fuzz, "wrong": _wrong}[sys.argv[1]]()
