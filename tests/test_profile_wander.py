"""The wander robot on each robot profile, started as a user would: the simulator posing as the robot (its
drivers' topics, types, rates and frames), then `roslaunch subsumption wander.launch robot:=...`. The robot must
move, and touch nothing."""
from __future__ import annotations

import pytest

import subsim
from conftest import launch_against_simulator

# Listens to the simulator's scoring topics (never given to the robot) until simulated time `until`.
WATCHER = r"""
import json, math, sys, time, rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32
until = float(sys.argv[1])
seen = {"collisions": 0, "distance": 0.0, "last": None, "t": 0.0, "commands": 0}
def on_truth(m):
    p = m.pose.pose.position
    if seen["last"] is not None:
        seen["distance"] += math.hypot(p.x - seen["last"][0], p.y - seen["last"][1])
    seen["last"], seen["t"] = (p.x, p.y), m.header.stamp.to_sec()
rospy.init_node("watcher")
rospy.Subscriber("/ground_truth", Odometry, on_truth)
rospy.Subscriber("/collisions", UInt32, lambda m: seen.__setitem__("collisions", m.data))
deadline = time.monotonic() + 150
while seen["t"] < until and time.monotonic() < deadline:
    time.sleep(0.1)
print(json.dumps(seen))
"""

# (profile, world, simulated seconds, rate, minimum distance m, extra launch arguments). The distance only shows the
# robot drove: on a loaded 2-core machine the wander robot's ROS graph turns on the spot near its start much of the
# time, with or without a profile (robot:=sim on the same world under ROS: 5.5 m in 40 s; in process: 15.4 m).
CASES = {
    "turtlebot3": ("corridors_turtlebot3", 20.0, 2.0, 1.0, []),
    "turtlebot2": ("corridors_turtlebot2", 20.0, 2.0, 1.0, []),
    # a base with the simulator's own names (Twist, Odometry, a 270-degree laser), wired by launch arguments
    "generic": ("corridors", 20.0, 2.0, 1.0, ["cmd_vel:=/cmd_vel", "odom:=/odom", "scan:=/scan", "max_v:=0.4"]),
}


@pytest.mark.parametrize("robot", sorted(CASES))
def test_wander_on_the_profile_touches_nothing(ros_processes, robot):
    world, duration, rate, min_distance, extra = CASES[robot]
    args = ["subsumption", "wander.launch", f"robot:={robot}", "use_sim_time:=true", *extra]
    seen, logs = launch_against_simulator(ros_processes, args, WATCHER, duration, subsim.world_path(world), rate)
    assert "Traceback" not in logs and "[ERROR]" not in logs, logs
    assert seen["t"] >= duration, (seen, logs)
    assert seen["collisions"] == 0, (seen, logs)
    assert seen["distance"] >= min_distance, (seen, logs)
