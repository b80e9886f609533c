"""Frontier exploration with a robot that cannot move: the real Explore and MoveBase in-process, on a map whose
known floor is a square in unknown space (one frontier all round it), and a base whose wheels do nothing (its
odometry stays where it is). Every frontier goal fails without the robot moving, and that is the robot stuck, not
the frontiers unreachable: exploration must not blacklist them all and say done (office seed 1 did: "no reachable
frontier left" with half the office unseen), but say where it is stuck and, after ``stuck_timeout``, give up."""
from __future__ import annotations

import genpy
import numpy as np
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import Bool
from tf2_msgs.msg import TFMessage

from navigation.explore import Explore
from navigation.grid_messages import grid_msg
from navigation.move_base import MoveBase
from subsumption import LocalRuntime
from subsumption.mapfile import OccupancyMap
from subsumption.planar import pose_msg, transform_msg

ROBOT = np.array([1.5, 1.5, 0.0])


class WheelsThatDoNothing:
    """A map (0.9 m of known floor round the robot, unknown beyond), odometry that stays at ROBOT whatever is
    commanded, and map -> odom: a robot stuck where it stands."""

    def __init__(self, runtime: LocalRuntime) -> None:
        occ = np.full((60, 60), -1, dtype=np.int8)  # 3 x 3 m, 5 cm cells
        occ[21:39, 21:39] = 0
        node = runtime.node("stuck_robot")
        node.publisher("/map", OccupancyGrid, latch=True).publish(grid_msg(OccupancyMap(occ, 0.05, (0.0, 0.0)), 0.0,
                                                                           "map"))
        self.odom = node.publisher("/odom", Odometry)
        self.tf = node.publisher("/tf", TFMessage)
        self.runtime = runtime
        node.call_every(0.1, self.tick)

    def tick(self) -> None:
        now = self.runtime.now()
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = genpy.Time.from_sec(now), "odom", "base_link"
        msg.pose.pose = pose_msg(ROBOT)
        self.odom.publish(msg)
        self.tf.publish(TFMessage([transform_msg(np.zeros(3), now, "map", "odom")]))


def test_a_robot_that_cannot_move_is_stuck_not_out_of_frontiers_and_exploration_gives_up_not_done():
    runtime = LocalRuntime()
    WheelsThatDoNothing(runtime)
    runtime.add_module(MoveBase, "move_base", remap={"scan": "/scan", "odom": "/odom", "map": "/map"},
                       params={"oscillation_timeout": 2.0, "max_recoveries": 0, "costmap_publish_frequency": 0.0})
    explore = runtime.add_module(Explore, "explore", remap={"map": "/map", "odom": "/odom"},
                                 params={"progress_timeout": 3.0, "stuck_timeout": 25.0})
    done: list[bool] = []
    gave_up: list[PointStamped] = []
    watch = runtime.node("watch")
    watch.subscribe("/explore/done", Bool, lambda msg: done.append(msg.data))
    watch.subscribe("/explore/gave_up", PointStamped, gave_up.append)
    runtime.run_for(24.0)
    # on the old rule every frontier was blacklisted in turn (the robot never got nearer), and it was done by 22 s
    assert not explore.finished and not any(done)
    assert explore.stuck_at is not None and np.hypot(*(explore.stuck_at - ROBOT[:2])) < 0.05
    assert explore.goals_sent > explore.stuck_goals  # the frontiers are tried again while it is stuck
    assert not explore.gave_up and not gave_up
    runtime.run_for(4.0)
    assert explore.gave_up and not explore.finished and not any(done)  # stuck for 25 s: given up, not done
    # and says so on ~gave_up (what a run on the ROS graph reads): where it stands, since when it has not moved
    assert len(gave_up) == 1 and gave_up[0].header.frame_id == "map"
    assert np.hypot(gave_up[0].point.x - ROBOT[0], gave_up[0].point.y - ROBOT[1]) < 0.05
    assert runtime.now() - gave_up[0].header.stamp.to_sec() >= 25.0
    assert explore.blacklist == []  # no frontier was shown unreachable: the robot never moved
