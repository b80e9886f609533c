"""MoveBase in-process: honest results through the action (ABORTED with the reason at once for a goal in a wall,
off the map or with no path; after the wait when no map comes; PREEMPTED on cancel and on a newer goal), and a
real drive in the simulator to SUCCEEDED within the tolerance, with the plan and costmaps in frame map."""
from __future__ import annotations

import logging
import math

import genpy
import numpy as np
from geometry_msgs.msg import PoseStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

import subsim
import subsim.local
from navigation.grid_messages import grid_msg
from navigation.move_base import MoveBase
from navigation.moving_obstacles import Track
from subsumption.planar import pose_msg, transform_msg
from subsumption import LocalRuntime
from subsumption.actions import ActionClient, GoalStatus
from subsumption.mapfile import OccupancyMap

REMAP = {"scan": "/scan", "odom": "/odom", "map": "/map", "~cmd_vel": "/cmd_vel"}


def goal_msg(x: float, y: float, yaw: float = 0.0, frame: str = "map") -> MoveBaseGoal:
    goal = MoveBaseGoal()
    goal.target_pose.header.frame_id = frame
    goal.target_pose.pose = pose_msg(np.array([x, y, yaw]))
    return goal


class StillRobot:
    """A map, odometry and map -> odom for a robot standing at (1, 1): enough for MoveBase to judge goals."""

    def __init__(self, runtime: LocalRuntime, with_map: bool = True) -> None:
        occ = np.zeros((80, 100), dtype=np.int8)
        occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
        occ[40:60, 40:60] = 100          # a block
        occ[5:20, 70] = occ[5:20, 90] = 100  # a closed box at x 3.5-4.5, y 0.25-1.0
        occ[5, 70:91] = occ[20, 70:91] = 100
        node = runtime.node("still_robot")
        if with_map:
            node.publisher("/map", OccupancyGrid, latch=True).publish(
                grid_msg(OccupancyMap(occ, 0.05, (0.0, 0.0)), 0.0, "map"))
        self.odom = node.publisher("/odom", Odometry)
        self.tf = node.publisher("/tf", TFMessage)
        self.runtime = runtime
        node.call_every(0.1, self.tick)

    localizing = True  # map -> odom published (a localizer that stops: False)

    def tick(self) -> None:
        now = self.runtime.now()
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = genpy.Time.from_sec(now), "odom", "base_link"
        msg.pose.pose = pose_msg(np.array([1.0, 1.0, 0.0]))
        self.odom.publish(msg)
        if self.localizing:
            self.tf.publish(TFMessage([transform_msg(np.zeros(3), now, "map", "odom")]))


def setup(with_map: bool = True, params: dict | None = None, robot: list | None = None):
    runtime = LocalRuntime()
    still = StillRobot(runtime, with_map)
    if robot is not None:
        robot.append(still)
    runtime.add_module(MoveBase, "move_base", remap=REMAP, params=params)
    client = ActionClient(runtime.node("client"), "/move_base", MoveBaseAction)
    runtime.run_for(0.5)
    return runtime, client


def test_a_localization_that_stops_pauses_the_goal_then_aborts_it_with_the_reason():
    robot: list = []
    runtime, client = setup(params={"transform_timeout": 1.0, "wait_for_map": 3.0}, robot=robot)
    cmds: list[Twist] = []
    runtime.node("listener").subscribe("/cmd_vel", Twist, cmds.append)
    goal = client.send_goal(goal_msg(3.0, 3.5))
    runtime.run_for(1.0)
    assert goal.status == GoalStatus.ACTIVE and any(c.linear.x != 0 or c.angular.z != 0 for c in cmds)
    robot[0].localizing = False
    runtime.run_for(2.0)  # the last map -> odom is older than transform_timeout: the robot stands and waits
    before = len(cmds)
    runtime.run_for(0.5)
    assert goal.status == GoalStatus.ACTIVE
    held = cmds[before:]  # a zero every control cycle (10 Hz), as ROS's move_base: the motor line is not let go
    assert len(held) >= 4 and all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in held)
    runtime.run_for(3.0)
    assert goal.status == GoalStatus.ABORTED and "no localization" in goal.text, goal.text


def test_impossible_goals_are_aborted_at_once_with_the_reason():
    runtime, client = setup()
    cases = {"inside an obstacle": goal_msg(2.5, 2.5), "off the map": goal_msg(9.0, 1.0),
             "closer to an obstacle than the robot's radius": goal_msg(1.9, 2.5),
             "no path": goal_msg(4.0, 0.6), "neither 'map' nor the odometry frame": goal_msg(1.5, 1.5, frame="laser"),
             "not a valid pose": MoveBaseGoal()}  # zero quaternion
    handles = {}
    for reason, goal in cases.items():
        handles[reason] = client.send_goal(goal)
        runtime.run_for(0.3)
    for reason, handle in handles.items():
        assert handle.status == GoalStatus.ABORTED, (reason, handle.status_name, handle.text)
        assert reason in handle.text


def test_a_goal_a_newer_map_shows_next_to_an_obstacle_is_aborted_with_the_reason():
    """SLAM's map grows while a goal is driven to: a box seen near the goal (0.15 m: within the robot's radius)
    ends the goal, as it would have on arrival, instead of the robot driving its rim up to the box."""
    runtime, client = setup()
    goal = client.send_goal(goal_msg(3.5, 3.6))
    runtime.run_for(1.0)
    assert goal.status == GoalStatus.ACTIVE
    occ = np.zeros((80, 100), dtype=np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[40:60, 40:60] = 100
    occ[73:76, 72:75] = 100  # a box whose nearest cell's centre is 0.146 m from the goal (3.5, 3.6)
    runtime.node("slam").publisher("/map", OccupancyGrid, latch=True).publish(
        grid_msg(OccupancyMap(occ, 0.05, (0.0, 0.0)), runtime.now(), "map"))
    runtime.run_for(1.5)
    assert goal.status == GoalStatus.ABORTED, goal.status_name
    assert "is now closer to an obstacle than the robot's radius" in goal.text, goal.text


def test_no_map_aborts_after_the_wait_naming_the_topic():
    runtime, client = setup(with_map=False, params={"wait_for_map": 2.0})
    goal = client.send_goal(goal_msg(1.5, 1.5))
    runtime.run_for(1.0)
    assert goal.status == GoalStatus.ACTIVE  # it waits
    runtime.run_for(2.0)
    assert goal.status == GoalStatus.ABORTED and "no map on /map within 2 s" in goal.text


def test_cancel_and_a_newer_goal_preempt():
    runtime, client = setup()
    first = client.send_goal(goal_msg(3.0, 3.5))
    runtime.run_for(0.5)
    assert first.status == GoalStatus.ACTIVE
    second = client.send_goal(goal_msg(1.0, 3.5))
    runtime.run_for(0.5)
    assert first.status == GoalStatus.PREEMPTED and first.text == "preempted by a newer goal"
    second.cancel()
    runtime.run_for(0.5)
    assert second.status == GoalStatus.PREEMPTED and second.text == "cancelled by the client"


def test_drives_to_a_goal_in_the_simulator_and_succeeds_within_tolerance():
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, subsim.world_path("room"), seed=1, record=False)  # the true map -> odom
    module = runtime.add_module(MoveBase, "move_base", remap=REMAP, params={"costmap_publish_frequency": 1.0})
    seen: dict[str, list] = {"plan": [], "costmap": [], "cmd": []}
    listener = runtime.node("listener")
    listener.subscribe("/move_base/plan", Path, seen["plan"].append)
    listener.subscribe("/move_base/global_costmap/costmap", OccupancyGrid, seen["costmap"].append)
    listener.subscribe("/cmd_vel", Twist, seen["cmd"].append)
    simple = listener.publisher("/move_base_simple/goal", PoseStamped)  # rviz's 2D Nav Goal
    runtime.run_for(1.0)
    target = PoseStamped()
    target.header.frame_id = "map"
    target.pose = pose_msg(np.array([4.5, 2.5, math.pi / 2]))
    simple.publish(target)
    for _ in range(60):
        runtime.run_for(1.0)
        if not module.server.active_goals():
            break
    goals = list(module.server.goals.values())
    assert len(goals) == 1 and goals[0].status == GoalStatus.SUCCEEDED, goals[0].text
    robot = next(iter(bridge.sim.robots.values()))
    assert math.hypot(robot.x - 4.5, robot.y - 2.5) <= 0.1 + 0.01  # the simulator's truth
    assert abs((robot.theta - math.pi / 2 + math.pi) % (2 * math.pi) - math.pi) <= 0.1 + 0.01
    assert bridge.collisions()[robot.name] == 0
    assert seen["plan"] and seen["plan"][0].header.frame_id == "map" and len(seen["plan"][0].poses) >= 2
    assert seen["costmap"] and seen["costmap"][0].header.frame_id == "map"
    assert any(abs(c.linear.x) > 0.2 for c in seen["cmd"]) and seen["cmd"][-1].linear.x == 0.0


def test_scans_that_come_late_hold_the_robot_still_and_then_abort_the_goal(caplog):
    """A loaded graph's depth pipeline fell seconds behind and the local planner drove on what it saw 4.6 s before:
    a scan older than max_scan_age (by its stamp) holds the robot still; one fresh again lets it drive on."""
    runtime = LocalRuntime()
    subsim.local.attach(runtime, subsim.world_path("room"), seed=1, record=False)
    runtime.add_module(MoveBase, "move_base", remap={**REMAP, "scan": "/late_scan"},
                       params={"max_scan_age": 1.0, "wait_for_map": 3.0})
    lag = [0.0]
    relay = runtime.node("relay")
    late = relay.publisher("/late_scan", LaserScan)

    def forward(scan: LaserScan) -> None:  # the simulator's scan, stamped `lag` s before it was taken
        copy = LaserScan(header=copy_header(scan.header), angle_min=scan.angle_min, angle_max=scan.angle_max,
                         angle_increment=scan.angle_increment, range_min=scan.range_min, range_max=scan.range_max,
                         ranges=scan.ranges)
        copy.header.stamp = genpy.Time.from_sec(scan.header.stamp.to_sec() - lag[0])
        late.publish(copy)

    relay.subscribe("/scan", LaserScan, forward)
    cmds: list[Twist] = []
    relay.subscribe("/cmd_vel", Twist, cmds.append)
    client = ActionClient(runtime.node("client"), "/move_base", MoveBaseAction)
    runtime.run_for(3.0)
    goal = client.send_goal(goal_msg(4.5, 2.5))
    runtime.run_for(1.5)
    assert any(c.linear.x > 0.1 for c in cmds)  # fresh scans: it drives
    lag[0] = 2.0  # from now on every scan is 2 s old: the newest steers until it is max_scan_age old
    with caplog.at_level(logging.WARNING, logger="subsumption.local"):
        runtime.run_for(1.1)
        before = len(cmds)
        runtime.run_for(1.0)
    held = cmds[before:]
    assert len(held) >= 8 and all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in held)
    assert goal.status == GoalStatus.ACTIVE and any("s old (max_scan_age" in r.getMessage() for r in caplog.records)
    lag[0] = 0.0
    runtime.run_for(1.0)
    assert any(c.linear.x > 0.1 for c in cmds[before + len(held):])  # fresh again: on it drives
    lag[0] = 2.0
    runtime.run_for(5.5)
    assert goal.status == GoalStatus.ABORTED and "no scan" in goal.text, goal.text


def copy_header(header):
    return type(header)(seq=header.seq, stamp=header.stamp, frame_id=header.frame_id)


def test_a_stuck_robot_gives_way_to_something_off_the_map_and_not_to_a_wall():
    """Where a stuck robot steps aside to: away from a person it sees and to one side, out of the line she came
    along (a walker may be waiting for it to move; straight away is further along her way), or out of the line a
    walker was tracked walking along when there is one; no stepping aside for the map's own walls, nor for a
    person too far away to be waiting for it."""
    runtime = LocalRuntime()
    StillRobot(runtime)  # standing at (1, 1) facing +x
    move_base = runtime.add_module(MoveBase, "move_base", remap=REMAP)
    runtime.run_for(0.5)
    pose = move_base.pose()
    angles = np.linspace(-0.6, 0.6, 15)

    def person_at(x: float, y: float) -> np.ndarray:  # the near side of a 0.2 m person, robot frame
        centre = np.array([x, y])
        facing = math.atan2(-y, -x)
        return centre + 0.2 * np.column_stack((np.cos(facing + angles), np.sin(facing + angles)))

    def out_of_her_way(point: np.ndarray | None, person: tuple[float, float]) -> bool:
        """0.6 m from the robot, further from her, and 0.45 m (the radii) off the line through her and it."""
        if point is None:
            return False
        her = pose[:2] + np.array(person)  # the robot faces +x: its frame is the map's, shifted
        line = (pose[:2] - her) / np.hypot(*(pose[:2] - her))
        rel = point[:2] - her
        return abs(math.hypot(*(point[:2] - pose[:2])) - 0.6) < 0.01 and \
            math.hypot(*rel) > math.hypot(*(pose[:2] - her)) and abs(line[0] * rel[1] - line[1] * rel[0]) > 0.45

    for person in ((0.5, 0.0), (-0.5, 0.0), (-0.4, 0.4), (0.0, 0.5)):
        move_base.obstacles_base = person_at(*person)
        assert out_of_her_way(move_base._give_way_point(pose), person), person
    # she was seen walking down along x = 1.5 and stands 0.5 m to the robot's side of it: off her line, 0.6 m
    move_base.obstacles_base = person_at(0.5, 0.3)
    move_base.tracker.tracks = [Track(np.array([1.6, 1.3]), np.zeros(2), np.zeros((1, 2)), move_base.now(), 5,
                                      heading=np.array([0.0, -1.0]))]
    point = move_base._give_way_point(pose)
    assert point is not None and point[0] <= 0.9 + 1e-6 and math.hypot(point[0] - 1.6, point[1] - 1.3) > 0.6
    move_base.tracker.tracks = []
    move_base.obstacles_base = np.column_stack((np.full(15, -0.95), np.linspace(-0.3, 0.3, 15)))  # the wall x=0.05
    assert move_base._give_way_point(pose) is None
    move_base.obstacles_base = person_at(1.6, 0.0)  # too far to be waiting for this robot
    assert move_base._give_way_point(pose) is None



def control_params(move_base: MoveBase, goal, pose: np.ndarray, now: float):
    """The local planner's parameters of a control cycle at `now`: the creep state watched, then read."""
    move_base._watch_creep(goal, pose, now)
    return move_base._control_params(goal)


def test_a_walker_lost_just_ahead_caps_the_speed_the_local_planner_chooses_among():
    """tracking_lost_slow: while a walker the scan lost moments ago is just ahead, the local planner is given
    creep_vel_x as its top speed, so it picks among arcs checked at that speed (not a faster arc's turn rate driven
    slower); behind the robot, or lost too long ago, the walker changes nothing."""
    from types import SimpleNamespace

    runtime = LocalRuntime()
    StillRobot(runtime)  # standing at (1, 1) facing +x; odometry = map
    move_base = runtime.add_module(MoveBase, "move_base", remap=REMAP, params={"tracking_lost_slow": 3.0,
                                                                             "creep_face": 0.0})
    runtime.run_for(0.5)
    goal = SimpleNamespace(creeping=False, facing_since=None, lost_side=None, plan=None)
    pose = np.array([1.0, 1.0, 0.0])
    top = control_params(move_base, goal, pose, move_base.now()).max_vel_x
    assert top > move_base.creep_vel_x

    def lost_walker(x: float, seen_ago: float) -> Track:
        return Track(np.array([x, 1.0]), np.zeros(2), np.zeros((1, 2)), move_base.now() - seen_ago, 5,
                     heading=np.array([1.0, 0.0]))

    move_base.tracker.tracks = [lost_walker(1.7, 1.0)]  # 0.7 m ahead, out of sight for 1 s
    assert control_params(move_base, goal, pose, move_base.now()).max_vel_x == move_base.creep_vel_x
    move_base.tracker.tracks = [lost_walker(0.3, 1.0)]  # behind
    assert control_params(move_base, goal, pose, move_base.now()).max_vel_x == top
    move_base.tracker.tracks = [lost_walker(1.7, 4.0)]  # lost longer than tracking_lost_slow ago
    assert control_params(move_base, goal, pose, move_base.now()).max_vel_x == top


def test_when_the_creep_for_a_lost_walker_ends_the_robot_first_turns_to_face_a_plan_that_turns_her_way():
    """The short level-4 scene on the ROS graph: the target stopped beside the robot, out of its view, to let it
    pass; once tracking_lost_slow's creep was over, the robot curved towards the plan at full speed and ran into her
    side. With creep_face, when the creep ends with her out of sight and the plan turns to her side, the local
    planner turns on the spot towards the plan from creep_face off it (not from rotate_in_place_above), for at
    most 2 s, so the robot looks where it will drive before it speeds up. A plan that turns away from her, or a
    creep that ends because she is in sight again, changes nothing."""
    from types import SimpleNamespace

    runtime = LocalRuntime()
    StillRobot(runtime)  # standing at (1, 1) facing +x
    move_base = runtime.add_module(MoveBase, "move_base", remap=REMAP, params={"tracking_lost_slow": 3.0,
                                                                             "creep_face": 0.15})
    runtime.run_for(0.5)
    pose = np.array([1.0, 1.0, 0.0])
    to_the_left = SimpleNamespace(points=np.array([[1.0, 1.0], [1.5, 1.0], [1.5, 4.0]]))
    to_the_right = SimpleNamespace(points=np.array([[1.0, 1.0], [1.5, 1.0], [1.5, -2.0]]))

    def creep_then_run_out(plan) -> tuple[SimpleNamespace, float]:
        goal = SimpleNamespace(creeping=False, facing_since=None, lost_side=None, plan=plan)
        now = move_base.now()
        walker = Track(np.array([1.6, 1.5]), np.zeros(2), np.zeros((1, 2)), now - 1.0, 5,
                       heading=np.array([1.0, 0.0]))  # 0.6 m ahead, 0.5 m to the left, lost 1 s ago
        move_base.tracker.tracks = [walker]
        assert control_params(move_base, goal, pose, now).max_vel_x == move_base.creep_vel_x and goal.creeping
        walker.seen = now - 3.5  # the creep has run out (the track not yet dropped by a scan)
        return goal, now

    usual = control_params(move_base, SimpleNamespace(creeping=False, facing_since=None, lost_side=None,
                                                      plan=to_the_left), pose, move_base.now()).rotate_in_place_above
    assert usual > 0.15
    goal, now = creep_then_run_out(to_the_left)
    params = control_params(move_base, goal, pose, now)
    assert params.rotate_in_place_above == 0.15 and params.max_vel_x > move_base.creep_vel_x
    assert goal.facing_since == now
    assert control_params(move_base, goal, pose, now + 1.9).rotate_in_place_above == 0.15
    assert control_params(move_base, goal, pose, now + 2.1).rotate_in_place_above == usual  # 2 s at most
    assert goal.facing_since is None
    goal, now = creep_then_run_out(to_the_right)  # the plan turns away from her
    assert control_params(move_base, goal, pose, now).rotate_in_place_above == usual and goal.facing_since is None
    goal, now = creep_then_run_out(to_the_left)
    move_base.tracker.tracks[0].seen = now  # in sight again: the robot knows where she is
    assert control_params(move_base, goal, pose, now).rotate_in_place_above == usual and goal.facing_since is None


def test_a_turn_on_the_spot_keeps_its_direction_for_turn_commit():
    """Near a person the local planner's reasons can alternate each cycle (turning towards the plan, turning away
    from what is near) with opposite turns, and the robot turned back and forth where it stood (office, seed 2:
    4 such spells in its first minute). move_base keeps a turn on the spot going the way the one before went,
    within turn_commit s; an arc ends that, and the final turn to the goal's heading is never reversed."""
    from types import SimpleNamespace

    from navigation.local_planner import TURNING_TO_PLAN, Command

    runtime = LocalRuntime()
    StillRobot(runtime)
    move_base = runtime.add_module(MoveBase, "move_base", remap=REMAP)
    goal = SimpleNamespace(turn=None)
    towards_plan = Command(0.0, 1.5, True, TURNING_TO_PLAN)
    away = Command(0.0, -1.5, True, "turning away from what is near")
    assert move_base._kept_turn(goal, towards_plan, 10.0) == 1.5
    assert move_base._kept_turn(goal, away, 10.1) == 1.5  # kept going the same way
    assert move_base._kept_turn(goal, away, 10.2) == 1.5
    assert move_base._kept_turn(goal, away, 10.8) == -1.5  # 0.6 s after the last: its own way
    assert move_base._kept_turn(goal, Command(0.2, 0.5, True, "following the plan"), 10.9) == 0.5
    assert move_base._kept_turn(goal, towards_plan, 11.0) == 1.5  # an arc in between: free again
    at_goal = Command(0.0, -0.4, True, "turning to the goal's heading", latched=True)
    assert move_base._kept_turn(goal, at_goal, 11.1) == -0.4
    move_base.turn_commit = 0.0
    assert move_base._kept_turn(goal, away, 11.2) == -1.5


def test_landmarks_are_built_in_line_in_process_and_aside_on_a_clock_that_runs_on(monkeypatch):
    """In-process the clock waits for the plan, so the build that a plan starts is done by the time it returns
    (runs stay reproducible); on a clock that runs on (ROS) the plan only starts it in a thread."""
    from navigation.costmap import INSCRIBED
    from navigation.planner import LANDMARKS, PlannerParams

    for in_line in (True, False):
        runtime, client = setup()
        module = runtime.modules["/move_base"]
        if not in_line:
            monkeypatch.setattr(module.node, "clock_waits_for_callbacks", False)
        goal = client.send_goal(goal_msg(3.0, 3.5))
        runtime.run_for(0.3)
        assert goal.status == GoalStatus.ACTIVE
        key = (module.costmap, module.costmap.static_costs, module.cost_factor, INSCRIBED, PlannerParams().landmarks)
        state, landmarks = LANDMARKS.get(*key)
        assert landmarks is None and state.builder is None
        state.closed = 10 ** 9  # as if the searches had cost a build already: the next plan starts it
        runtime.run_for(1.5)  # a replan (planner_frequency 1 Hz)
        state, landmarks = LANDMARKS.get(*key)
        if in_line:
            assert landmarks is not None and state.builder is None
        else:
            assert state.builder is not None
            state.builder.join(30.0)
            assert LANDMARKS.get(*key)[1] is not None


def test_a_scan_is_placed_with_the_odometry_of_its_own_instant():
    """The simulator sends a scan before the odometry of the same instant. Placed with the odometry before it (0.1 s
    of turning at 1 rad/s), a wall point 1 m ahead is remembered 10 cm to one side: frontier exploration with the
    depth scan brushed box corners the robot had turned away from. It is placed where the robot was when it saw."""
    runtime = LocalRuntime()
    mb = runtime.add_module(MoveBase, "move_base", remap=REMAP, params={"hit_memory": 20.0})
    node = runtime.node("robot")
    odom_out, scan_out = node.publisher("/odom", Odometry), node.publisher("/scan", LaserScan)

    def odometry(t: float, yaw: float) -> None:
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = genpy.Time.from_sec(t), "odom", "base_link"
        msg.pose.pose = pose_msg(np.array([0.0, 0.0, yaw]))
        odom_out.publish(msg)
        runtime.run_for(0.0)

    def scan(t: float) -> None:  # one wall point 1 m straight ahead
        msg = LaserScan(angle_min=-0.01, angle_max=0.01, angle_increment=0.01, range_min=0.45, range_max=4.0,
                        ranges=[math.inf, 1.0, math.inf])
        msg.header.stamp, msg.header.frame_id = genpy.Time.from_sec(t), "base_link"
        scan_out.publish(msg)
        runtime.run_for(0.0)

    odometry(1.0, 0.0)
    scan(1.1)  # taken at 1.1 s, when the robot had turned to 0.1 rad: its odometry comes next
    odometry(1.1, 0.1)
    odometry(1.2, 0.2)
    assert len(mb.hits.points) == 1
    np.testing.assert_allclose(mb.hits.points[0], [math.cos(0.1), math.sin(0.1)], atol=1e-6)


def test_a_robot_that_does_not_move_runs_the_recovery_rounds_then_aborts_naming_them():
    """The recovery behaviours in order, on a robot whose wheels turn nothing (its odometry stands still at (1, 1)
    whatever it is told): each round clears the scan's obstacles and turns all round (2 pi s at 1 rad/s), every
    second round first backs off (0.15 m/s for 1.5 s, the rear being clear), a turn to where it can drive follows
    when it has a plan; after max_recoveries rounds the goal is ABORTED, the text naming them."""
    runtime = LocalRuntime()
    StillRobot(runtime)
    scanner = runtime.node("scanner")
    scans = scanner.publisher("/scan", LaserScan)

    def scan() -> None:  # nothing near: the way is open, the robot just does not get anywhere
        msg = LaserScan(angle_min=-1.0, angle_max=1.0, angle_increment=0.1, range_min=0.1, range_max=8.0,
                        ranges=[float("inf")] * 21)
        msg.header.stamp, msg.header.frame_id = genpy.Time.from_sec(runtime.now()), "base_link"
        scans.publish(msg)

    scanner.call_every(0.1, scan)
    runtime.add_module(MoveBase, "move_base", remap=REMAP, params={"oscillation_timeout": 2.0, "max_recoveries": 2})
    cmds: list[tuple[float, float, float]] = []
    scanner.subscribe("/cmd_vel", Twist, lambda c: cmds.append((runtime.now(), c.linear.x, c.angular.z)))
    client = ActionClient(runtime.node("client"), "/move_base", MoveBaseAction)
    runtime.run_for(0.5)
    goal = client.send_goal(goal_msg(3.0, 1.0))
    for _ in range(60):
        runtime.run_for(1.0)
        if goal.status != GoalStatus.ACTIVE:
            break
    assert goal.status == GoalStatus.ABORTED and "after 2 recovery rounds" in goal.text, goal.text
    rotating = [t for t, v, w in cmds if v == 0.0 and w == 1.0]
    backing = [t for t, v, w in cmds if v == -0.15 and w == 0.0]
    assert any(v > 0.1 for _, v, _ in cmds)  # it tried to drive first
    # two turns all round (2 pi s each, at the command rate), the back-off only in round 2 and before its turn
    assert len(rotating) * 0.1 >= 2 * 2 * math.pi * 0.9, len(rotating)
    assert backing and 1.2 <= backing[-1] - backing[0] + 0.1 <= 1.7 and backing[0] > rotating[0]
    assert min(t for t in rotating if t > backing[-1]) - backing[-1] < 0.5
