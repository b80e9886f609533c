"""The simulator node under a real (private) ROS master, seen by real rospy subscribers and rostopic."""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

import subsim
from conftest import output_of

ROOT = Path(__file__).resolve().parent.parent

# A separate process with a real rospy node: listens, drives forward, prints what it saw as JSON.
CHECKER = r"""
import json, time, rospy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan, Range
from tf2_msgs.msg import TFMessage
seen = {"clock": [], "scan": [], "sonar": set(), "odom_x": [], "tf": set()}
rospy.init_node("checker")
rospy.Subscriber("/clock", Clock, lambda m: seen["clock"].append(m.clock.to_sec()))
rospy.Subscriber("/scan", LaserScan, lambda m: seen["scan"].append((len(m.ranges), m.header.frame_id)))
rospy.Subscriber("/sonar", Range, lambda m: seen["sonar"].add(m.header.frame_id))
rospy.Subscriber("/odom", Odometry, lambda m: seen["odom_x"].append(m.pose.pose.position.x))
rospy.Subscriber("/tf", TFMessage, lambda m: seen["tf"].update(
    (t.header.frame_id, t.child_frame_id) for t in m.transforms))
pub = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
cmd = Twist(); cmd.linear.x = 0.5
start = time.monotonic()
while not seen["clock"] and time.monotonic() < start + 45.0:  # the simulator may start after this node
    time.sleep(0.01)
end = time.monotonic() + 4.0
while time.monotonic() < end:
    pub.publish(cmd)
    time.sleep(0.05)
print(json.dumps({"clock": seen["clock"][:1] + seen["clock"][-1:], "n_clock": len(seen["clock"]),
                  "scan": seen["scan"][-1:], "sonar": sorted(seen["sonar"]), "odom_x": seen["odom_x"][:1] +
                  seen["odom_x"][-1:], "tf": sorted(seen["tf"]), "sim_time": rospy.get_param("/use_sim_time")}))
"""


def wait_for_topic(env, topic: str, timeout: float = 15.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        out = subprocess.run(["rostopic", "list"], env=env, capture_output=True, text=True, timeout=10).stdout
        if topic in out.split():
            return
        time.sleep(0.3)
    raise AssertionError(f"{topic} did not appear within {timeout} s")


@pytest.mark.timeout(100)
def test_simulator_node_under_ros(ros_processes):
    env = ros_processes.env
    # the checker first, as a graph started before the simulator (experiments.runner): the simulator waits for it
    checker = ros_processes.start([sys.executable, "-c", CHECKER], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE)
    wait_for_topic(env, "/cmd_vel")
    sim = ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"),
                               f"_world:={subsim.world_path('room')}", "_rate:=2.0"])
    out, err = checker.communicate(timeout=70)  # allows for a first numba compile (several s)
    assert checker.returncode == 0, err
    seen = json.loads(out.strip().splitlines()[-1])

    assert seen["sim_time"] is True
    assert seen["n_clock"] > 50
    # it heard the clock from the first /clock on (0.04 s: every 2nd step at 50 Hz): the simulator stepped only once
    # the checker was connected (before, it stepped at once and the first 0.1-1.2 s went unheard)
    assert seen["clock"][0] <= 0.05, seen["clock"]
    assert 5.0 < seen["clock"][1] - seen["clock"][0] < 10.0  # _rate:=2.0: about 8 s in the 4 s of wall time
    (n_ranges, frame), = seen["scan"]
    assert (n_ranges, frame) == (541, "laser")
    assert seen["sonar"] == sorted(f"sonar_{i}" for i in range(12))
    assert seen["odom_x"][1] > seen["odom_x"][0] + 1.0  # cmd_vel moved the robot
    assert ["map", "odom"] in seen["tf"] and ["odom", "base_link"] in seen["tf"]

    listed = subprocess.run(["rostopic", "list"], env=env, capture_output=True, text=True, timeout=10).stdout.split()
    for topic in ("/clock", "/scan", "/sonar", "/odom", "/tf", "/tf_static", "/map", "/cmd_vel", "/bumper",
                  "/collisions", "/ground_truth"):
        assert topic in listed
    types = {t: subprocess.run(["rostopic", "type", t], env=env, capture_output=True, text=True,
                               timeout=10).stdout.strip() for t in ("/scan", "/sonar", "/odom", "/clock", "/tf")}
    assert types == {"/scan": "sensor_msgs/LaserScan", "/sonar": "sensor_msgs/Range", "/odom": "nav_msgs/Odometry",
                     "/clock": "rosgraph_msgs/Clock", "/tf": "tf2_msgs/TFMessage"}
    assert sim.poll() is None  # still running; the fixture stops it by pid


@pytest.mark.timeout(60)
def test_bad_world_is_a_clear_error_under_ros(ros_processes, tmp_path):
    bad = tmp_path / "w.yaml"
    bad.write_text("map: nowhere.yaml\nrobots: [{name: r}]\n")
    sim = ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"), "--world", str(bad)])
    sim.wait(timeout=30)
    out = output_of(sim)
    assert sim.returncode == 2
    assert str(bad) in out and "'map'" in out
