"""The slam and amcl nodes on a real (private) ROS master beside the simulator node: the topics rviz shows
carry the frames rviz expects (REP 105: map -> odom -> base_link)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import subsim
from test_sim_ros import wait_for_topic

ROOT = Path(__file__).resolve().parent.parent

# A rospy node in its own process: reads what rviz would, prints it as JSON.
LISTENER = r"""
import json, sys, time, rospy
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Path
from tf2_msgs.msg import TFMessage
topics = json.loads(sys.argv[1])
seen = {"tf": set()}
rospy.init_node("listener")
def keep(name):
    def cb(m):
        seen[name] = {"frame": m.header.frame_id, "stamp": m.header.stamp.to_sec()}
        if name == "/amcl_pose":
            seen[name]["xy"] = [m.pose.pose.position.x, m.pose.pose.position.y]
        if name == "/map":
            seen[name]["size"] = [m.info.width, m.info.height, sum(1 for v in m.data if v == 100)]
    return cb
kinds = {"OccupancyGrid": OccupancyGrid, "Path": Path, "PoseArray": PoseArray,
         "PoseWithCovarianceStamped": PoseWithCovarianceStamped}
for name, kind in topics.items():
    rospy.Subscriber(name, kinds[kind], keep(name))
rospy.Subscriber("/tf", TFMessage, lambda m: seen["tf"].update((t.header.frame_id, t.child_frame_id) for t in m.transforms))
if "/amcl_pose" in topics:  # what rviz's 2D Pose Estimate sends
    pub = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = "map"
    msg.pose.pose.position.x, msg.pose.pose.position.y = 1.1, 1.4
    msg.pose.pose.orientation.w = 1.0
    msg.pose.covariance[0] = msg.pose.covariance[7] = 0.04
    msg.pose.covariance[35] = 0.05
    pub.publish(msg)
deadline = time.monotonic() + 25
while time.monotonic() < deadline and not all(t in seen for t in topics):
    time.sleep(0.2)
time.sleep(1.0)
seen["tf"] = sorted(seen["tf"])
print(json.dumps(seen))
"""


def listen(ros_processes, topics: dict[str, str]) -> dict:
    listener = ros_processes.start([sys.executable, "-c", LISTENER, json.dumps(topics)], stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE)
    out, err = listener.communicate(timeout=60)
    assert listener.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


def start_simulator(ros_processes, publish_map: bool):
    return ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"),
                                f"_world:={subsim.world_path('room')}", "_rate:=2.0", "_map_to_odom:=false",
                                f"_publish_map:={'true' if publish_map else 'false'}"])


@pytest.mark.timeout(120)
def test_slam_node_publishes_map_and_map_to_odom(ros_processes):
    slam = ros_processes.start([sys.executable, str(ROOT / "nodes" / "slam"), "_map_update_interval:=1.0",
                                "_initial_pose:=[1.0, 1.5, 0.0]"])
    start_simulator(ros_processes, publish_map=False)
    wait_for_topic(ros_processes.env, "/scan", timeout=45.0)
    seen = listen(ros_processes, {"/map": "OccupancyGrid", "/slam/trajectory": "Path"})
    assert seen["/map"]["frame"] == "map" and seen["/slam/trajectory"]["frame"] == "map"
    width, height, occupied = seen["/map"]["size"]
    assert width * 0.05 >= 5.6 and height * 0.05 >= 5.6 and occupied > 100  # the room's walls
    assert ["map", "odom"] in seen["tf"] and ["odom", "base_link"] in seen["tf"]
    assert slam.poll() is None


@pytest.mark.timeout(120)
def test_amcl_node_localizes_from_rviz_initial_pose(ros_processes):
    amcl = ros_processes.start([sys.executable, str(ROOT / "nodes" / "amcl")])
    start_simulator(ros_processes, publish_map=True)
    wait_for_topic(ros_processes.env, "/scan", timeout=45.0)
    seen = listen(ros_processes, {"/amcl_pose": "PoseWithCovarianceStamped", "/particlecloud": "PoseArray"})
    assert seen["/amcl_pose"]["frame"] == "map" and seen["/particlecloud"]["frame"] == "map"
    x, y = seen["/amcl_pose"]["xy"]
    assert abs(x - 1.0) < 0.3 and abs(y - 1.5) < 0.3  # the robot stands at the world's start (1.0, 1.5)
    assert ["map", "odom"] in seen["tf"]
    assert amcl.poll() is None
