"""Frontier exploration with a robot that cannot move: the real Explore and MoveBase in-process, on a map whose
known floor is a square in unknown space (one frontier all round it), and a base whose wheels do nothing (its
odometry stays where it is). Every frontier goal fails without the robot moving, and that is the robot stuck, not
the frontiers unreachable: exploration must not blacklist them all and say done (office seed 1 did: "no reachable
frontier left" with half the office unseen), but say where it is stuck and, after ``stuck_timeout``, give up."""
from __future__ import annotations

import genpy
import numpy as np
from geometry_msgs.msg import PointStamped, PoseStamped
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
        self.known(occ)
        node = runtime.node("stuck_robot")
        node.publisher("/map", OccupancyGrid, latch=True).publish(grid_msg(OccupancyMap(occ, 0.05, (0.0, 0.0)), 0.0,
                                                                           "map"))
        self.odom = node.publisher("/odom", Odometry)
        self.tf = node.publisher("/tf", TFMessage)
        self.runtime = runtime
        node.call_every(0.1, self.tick)

    def known(self, occ: np.ndarray) -> None:
        """More known floor (none here)."""

    def pose_at(self, now: float) -> np.ndarray:
        """Where odometry says the robot is at `now`: where it stands."""
        return ROBOT

    def tick(self) -> None:
        now = self.runtime.now()
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = genpy.Time.from_sec(now), "odom", "base_link"
        msg.pose.pose = pose_msg(self.pose_at(now))
        self.odom.publish(msg)
        self.tf.publish(TFMessage([transform_msg(np.zeros(3), now, "map", "odom")]))


def explore_with_move_base(runtime: LocalRuntime, stuck_timeout: float) -> Explore:
    """The real MoveBase (no recoveries, quick to call a goal stuck) and Explore on the fake robot's topics."""
    runtime.add_module(MoveBase, "move_base", remap={"scan": "/scan", "odom": "/odom", "map": "/map"},
                       params={"oscillation_timeout": 2.0, "max_recoveries": 0, "costmap_publish_frequency": 0.0})
    return runtime.add_module(Explore, "explore", remap={"map": "/map", "odom": "/odom"},
                              params={"progress_timeout": 3.0, "stuck_timeout": stuck_timeout})


def test_a_robot_that_cannot_move_is_stuck_not_out_of_frontiers_and_exploration_gives_up_not_done():
    runtime = LocalRuntime()
    WheelsThatDoNothing(runtime)
    explore = explore_with_move_base(runtime, 25.0)
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


class DrivesInThenStops(WheelsThatDoNothing):
    """The robot drives 1.2 m east along y 1.5 into the known floor (odometry says so) in its first 3 s, then its
    wheels do nothing: a robot that drove into a pocket and cannot get on."""

    ENTRY = np.array([0.3, 1.5, 0.0])

    def known(self, occ: np.ndarray) -> None:
        occ[24:36, 1:21] = 100  # the corridor it came in by, walled: its frontiers are all round the square
        occ[25:35, 2:21] = 0

    def pose_at(self, now: float) -> np.ndarray:
        """Driving in from ENTRY for 3 s, then at ROBOT."""
        return self.ENTRY + min(now / 3.0, 1.0) * (ROBOT - self.ENTRY)


def test_a_robot_whose_goals_fail_where_it_stands_is_sent_back_the_way_it_came():
    """Office seed 1's pocket: the robot drove in and no goal got it on. After a frontier goal fails without the
    robot moving, explore sends it escape_distance m back along its own path (ground it drove over), then further
    back; never onto the unknown, never off its path."""
    runtime = LocalRuntime()
    DrivesInThenStops(runtime)
    explore = explore_with_move_base(runtime, 60.0)
    goals: list = []
    runtime.node("watch").subscribe("/explore/goal", PoseStamped, lambda m: goals.append(
        (runtime.now(), m.pose.position.x, m.pose.position.y)))
    runtime.run_for(16.0)
    assert explore.escapes >= 1
    back = [(t, x, y) for t, x, y in goals if x < 1.0]  # in the corridor it came by (no frontier there)
    assert back, goals
    t, x, y = back[0]
    assert t > 3.0 and abs(y - 1.5) < 0.06 and abs(x - 0.5) < 0.12  # 1 m of travel back along its path
    assert all(x >= DrivesInThenStops.ENTRY[0] - 0.06 and abs(y - 1.5) < 0.06 for _, x, y in back)
