"""move_base on a real (private) ROS master beside the simulator and amcl nodes: ROS's own
``actionlib.SimpleActionClient`` sends a goal (SUCCEEDED), cancels one (PREEMPTED) and sends one into a wall
(ABORTED at once, with the reason); the plan and the costmaps rviz shows are in frame ``map``."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import subsim

ROOT = Path(__file__).resolve().parent.parent

CLIENT = r"""
import json, math, time, rospy, actionlib
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Path
rospy.init_node("nav_client")
frames = {}
def keep(name):
    return lambda m: frames.setdefault(name, m.header.frame_id)
rospy.Subscriber("/move_base/plan", Path, keep("plan"))
rospy.Subscriber("/move_base/global_costmap/costmap", OccupancyGrid, keep("global_costmap"))
rospy.Subscriber("/move_base/local_costmap/costmap", OccupancyGrid, keep("local_costmap"))
client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
assert client.wait_for_server(rospy.Duration(90)), "move_base did not come up"
from geometry_msgs.msg import PoseWithCovarianceStamped
rospy.wait_for_message("/amcl_pose", PoseWithCovarianceStamped, timeout=90)  # localized: goals can be judged
def goal(x, y, yaw):
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = "map"
    g.target_pose.header.stamp = rospy.Time.now()
    g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
    g.target_pose.pose.orientation.z, g.target_pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return g
out = {}
client.send_goal(goal(2.6, 2.2, 1.0))
client.wait_for_result(rospy.Duration(60))
out["reached"] = [client.get_state(), client.get_goal_status_text()]
client.send_goal(goal(1.0, 4.8, 0.0))
rospy.sleep(1.5)
client.cancel_goal()
client.wait_for_result(rospy.Duration(20))
out["cancelled"] = [client.get_state(), client.get_goal_status_text()]
started = time.monotonic()
client.send_goal(goal(4.1, 4.1, 0.0))  # the room's block
client.wait_for_result(rospy.Duration(20))
out["wall"] = [client.get_state(), client.get_goal_status_text(), time.monotonic() - started]
deadline = time.monotonic() + 10
while len(frames) < 3 and time.monotonic() < deadline:
    time.sleep(0.2)
out["frames"] = frames
print(json.dumps(out))
"""


@pytest.mark.timeout(180)
def test_simple_action_client_against_move_base_node(ros_processes):
    env = ros_processes.env
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True, timeout=20)
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={subsim.world_path('room')}",
                         "_rate:=2.0", "_map_to_odom:=false", "_publish_map:=true"])
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "amcl"), "_initial_pose_x:=1.0", "_initial_pose_y:=1.5",
                         "_initial_cov_xx:=0.01", "_initial_cov_yy:=0.01"])
    move_base = ros_processes.start([sys.executable, str(ROOT / "nodes" / "move_base"),
                                     "_costmap_publish_frequency:=1.0"])
    client = ros_processes.start([sys.executable, "-c", CLIENT], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = client.communicate(timeout=150)
    assert client.returncode == 0, err[-3000:]
    result = json.loads(out.strip().splitlines()[-1])
    SUCCEEDED, PREEMPTED, ABORTED = 3, 2, 4
    assert result["reached"][0] == SUCCEEDED, result
    assert result["reached"][1].startswith("reached")
    assert result["cancelled"] == [PREEMPTED, "cancelled by the client"]
    state, text, seconds = result["wall"]
    assert state == ABORTED and "inside an obstacle" in text and seconds < 3.0
    assert result["frames"] == {"plan": "map", "global_costmap": "map", "local_costmap": "map"}
    assert move_base.poll() is None
