"""amcl's start-up on a known start pose: ``map -> odom`` is there before the first scan (move_base can plan at
once, instead of waiting while lower levels drive the robot off its first goal), and the first filter update
moves the particles by what odometry saw since the start."""
from __future__ import annotations

import math

import genpy
import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

import subsim
from navigation.amcl import Amcl
from navigation.grid_messages import grid_msg
from subsumption.planar import pose_msg, yaw_of
from subsim.mapio import load_map
from subsumption.testing import Harness

START = (1.0, 1.5, 0.0)


def _odom(t: float, x: float) -> Odometry:
    msg = Odometry(header=Header(0, genpy.Time.from_sec(t), "odom"), child_frame_id="base_link")
    msg.pose.pose = pose_msg(np.array([x, 0.0, 0.0]))
    return msg


def _amcl() -> tuple[Harness, list]:
    h = Harness(Amcl, params={"initial_pose_x": START[0], "initial_pose_y": START[1], "initial_pose_a": START[2],
                              "initial_cov_xx": 0.01, "initial_cov_yy": 0.01, "initial_cov_aa": 0.01})
    seen: list = []
    h.runtime.node("tf_listener").subscribe("/tf", TFMessage, lambda m: seen.extend(
        (h.runtime.now(), t) for t in m.transforms if t.header.frame_id == "map"))
    h.feed("map", grid_msg(load_map(subsim.world_path("room").parent / "room.yaml"), 0.0, "map"))
    return h, seen


def test_map_to_odom_from_the_start_pose_before_any_scan():
    h, seen = _amcl()
    h.run_for(0.5)
    assert seen == []  # no odometry yet: the odom frame's name is not known
    h.feed("odom", _odom(0.5, 0.0))
    h.run_for(0.2)
    assert seen and seen[0][0] <= 0.5 + 1e-9  # at once, with the first odometry
    tr = seen[-1][1].transform
    assert seen[-1][1].child_frame_id == "odom"
    assert (tr.translation.x, tr.translation.y) == (START[0], START[1]) and abs(yaw_of(tr.rotation)) < 1e-9
    assert h.sent("amcl_pose") == []  # the filter itself has not run: no estimate is claimed


def test_first_update_counts_the_motion_since_the_start():
    """The robot drives 0.8 m east before amcl's first scan: the estimate is where it is, not the start pose."""
    h, seen = _amcl()
    h.feed("odom", _odom(0.0, 0.0))
    for i in range(1, 9):
        h.feed("odom", _odom(0.1 * i, 0.1 * i))
    angles = np.linspace(-0.5, 0.5, 40)
    x, y = START[0] + 0.8, START[1]  # where it is: the room's walls' surfaces are at 0.2 and 5.8
    ranges = [min((5.8 - x) / math.cos(a), (y - 0.2) / -math.sin(a) if a < 0 else math.inf,
                  (5.8 - y) / math.sin(a) if a > 0 else math.inf) for a in angles]
    scan = LaserScan(header=Header(0, genpy.Time.from_sec(0.8), "base_link"), angle_min=-0.5, angle_max=0.5,
                     angle_increment=1.0 / 39, range_min=0.1, range_max=6.0, ranges=ranges)
    h.feed("scan", scan)
    h.run_for(0.1)
    poses = h.sent("amcl_pose")
    assert poses, "no filter update"
    p = poses[-1].pose.pose.position
    assert math.hypot(p.x - (START[0] + 0.8), p.y - START[1]) < 0.15, (p.x, p.y)
