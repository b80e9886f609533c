"""move_base's job as a subsumption module: drive the robot to a goal pose on the map and say honestly how it went.

Interfaces a ROS user knows: the action ``move_base`` (``move_base_msgs/MoveBaseAction``: goal, cancel, status,
feedback, result; see :mod:`subsumption.actions`) and the topic ``move_base_simple/goal``
(``geometry_msgs/PoseStamped``, rviz's "2D Nav Goal"), which becomes an action goal as in move_base. Out:
``cmd_vel`` (Twist), ``plan`` (nav_msgs/Path, frame map), ``global_costmap/costmap`` and
``local_costmap/costmap`` (OccupancyGrid, rviz's costmap colours).

The robot's pose is what localization says: ``map -> odom`` from ``/tf`` (AMCL's, or SLAM's) composed with the
odometry message's pose; the module never sees the truth. The global plan (:mod:`navigation.planner`) runs on
the static map plus the latest scan's obstacles, inflated (:mod:`navigation.costmap`), every
1/``planner_frequency`` s; the local planner (:mod:`navigation.local_planner`) turns it into a command every
1/``controller_frequency`` s from the scan as it is now.

Results:

* SUCCEEDED only when the estimate is within ``xy_goal_tolerance`` and ``yaw_goal_tolerance`` of the goal;
* ABORTED at once, with the reason as the status text, for a goal off the map, in (or within the robot's
  radius of) a wall, in an unknown frame, with no path on the map; ABORTED after ``wait_for_map`` s when no map
  or no localization has come; ABORTED when the recovery behaviours (:mod:`navigation.recovery`: clear the scan's
  obstacles and replan, rotate, back off; step aside for something off the map that is near) leave the robot
  still stuck;
* PREEMPTED on cancel or when a new goal arrives (the new one takes over).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import genpy
import numpy as np
from geometry_msgs.msg import PoseStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from nav_msgs.srv import GetPlan, GetPlanResponse
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header
from std_srvs.srv import Empty, EmptyResponse
from tf2_msgs.msg import TFMessage

from subsumption import Input, Module, Output, Param
from subsumption.actions import ActionServer, ServerGoal
from subsumption.mapfile import OccupancyMap

from .costmap import INSCRIBED, LETHAL, NO_INFORMATION, Costmap, InflationParams, costmap_msg
from .grid_messages import GridMessageError, grid_of
from .local_planner import (AT_GOAL, BLIND_SPOT_CARE, TURNING_TO_PLAN, Command, LocalParams, carrot, compute_command,
                            heading_to_leave)
from .moving_obstacles import MovingObstacles, ObstacleTracker, TrackerParams
from .obstacle_memory import ObstacleMemory
from .planner import Plan, PlanError, PlannerParams, plan as make_plan, warm_up as warm_up_planner
from .recovery import GIVE_WAY_NEAR, RecoveryStep, give_way_point, leave_turn_rate, rear_clear, recovery_round
from .scan_geometry import MountListener, beams_of
from .scan_sync import ScanOdometrySync
from subsumption.planar import compose, from_pose_msg, pose_msg, transform_points, wrap, yaw_of
from .seen_space import SeenSpace


HIT_MEMORY_REACH = 2.0  # m: remembered hits further from the robot are forgotten (the local planner looks 2 m)
HIT_MEMORY_CELL = 0.03  # m: one remembered hit per cell this size
CREEP_FACE_S = 2.0  # s at most the robot turns to face the plan after tracking_lost_slow's creep (creep_face)


def cell_corners(cells: np.ndarray, first_row: int, first_col: int, origin: tuple[float, float],
                 resolution: float) -> np.ndarray:
    """(n, 2) the corners of the true cells of `cells` (a window of a grid whose top-left cell is (first_row,
    first_col)), each corner once, without the corners inside a block (all four cells round them true): the
    points nearest to which a round robot's rim comes first when it passes a cell (its centre is up to half a
    diagonal further). Four shifted ORs of the window, no sort: this runs every control cycle."""
    cells = np.asarray(cells, dtype=bool)
    height, width = cells.shape
    touched = np.zeros((height + 1, width + 1), dtype=bool)
    inside = np.ones((height + 1, width + 1), dtype=bool)
    inside[0, :] = inside[-1, :] = False
    inside[:, 0] = inside[:, -1] = False
    for i in (0, 1):
        for j in (0, 1):
            touched[i:i + height, j:j + width] |= cells
            inside[i:i + height, j:j + width] &= cells
    rows, cols = np.nonzero(touched & ~inside)
    return np.column_stack((origin[0] + (cols + first_col) * resolution, origin[1] + (rows + first_row) * resolution))


@dataclass
class _Goal:
    handle: ServerGoal
    target: np.ndarray | None  # (x, y, yaw) in the global frame; None until it could be read (waiting for tf)
    received: float
    plan: Plan | None = None
    last_plan: float = -math.inf
    plan_failing_since: float | None = None
    blocked_since: float | None = None
    progress_at: float = 0.0
    progress_pose: np.ndarray | None = None
    recoveries: int = 0
    recovery: list[RecoveryStep] = field(default_factory=list)  # the steps being executed, the current first
    start_pose: np.ndarray | None = None
    latched: bool = False
    turn: tuple[float, float] | None = None  # (direction +1/-1, when) of the last turn on the spot, until it drives
    creeping: bool = False  # tracking_lost_slow held the robot to creep_vel_x last cycle
    facing_since: float | None = None  # when that creep ended, while the robot turns to face the plan (creep_face)
    lost_side: float | None = None  # +1 left, -1 right: the side of the walker that made it creep
    waiting_since: float | None = None  # when the map or the pose went missing (None: both there)
    scan_stale_since: float | None = None  # when the newest scan became too old to steer by (None: fresh)


class MoveBase(Module):
    """Drives to goal poses on a map (move_base's job): the ``move_base`` action and ``move_base_simple/goal``
    in; ``cmd_vel``, the plan and the costmaps out; honest SUCCEEDED / ABORTED (with the reason) / PREEMPTED."""

    scan = Input(LaserScan, "range scan, any frame mounted on the robot in /tf_static")
    odom = Input(Odometry, "odometry: the base frame's pose in the odom frame, and its velocity")
    map = Input(OccupancyGrid, "the map to plan on (latched: map server, simulator or SLAM)")
    cmd_vel = Output(Twist, "velocity command for the base")
    plan = Output(Path, "the global plan, frame map")
    global_costmap = Output(OccupancyGrid, "the global costmap (costmap_2d values)", name="global_costmap/costmap")
    local_costmap = Output(OccupancyGrid, "the costmap around the robot", name="local_costmap/costmap")

    controller_frequency = Param(10.0, "Hz: local planner and command rate", min=1.0, max=100.0)
    planner_frequency = Param(1.0, "Hz: global replanning rate (0: only when a goal comes or the plan fails)",
                              min=0.0)
    planner_patience = Param(5.0, "s the planner may fail (scan obstacles blocking) before recovery", min=0.0)
    controller_patience = Param(3.0, "s without an admissible command before recovery", min=0.0)
    oscillation_timeout = Param(10.0, "s without moving oscillation_distance before recovery", min=0.0)
    oscillation_distance = Param(0.2, "m the robot must move to count as progress", min=0.0)
    turn_commit = Param(0.5, "s within which a turn on the spot keeps the direction of the one before it (a round "
                             "robot turning comes no nearer to anything; turning back and forth gets nowhere). The "
                             "last turn to the goal's heading is left as it is (0: off)", min=0.0)
    recovery_behavior_enabled = Param(True, "rotate and back off when stuck (else abort)")
    max_recoveries = Param(4, "recovery rounds before a goal is aborted as stuck", min=0)
    xy_goal_tolerance = Param(0.1, "m: success only within this distance of the goal", min=0.01,
                              aliases=("TrajectoryPlannerROS/xy_goal_tolerance",))
    yaw_goal_tolerance = Param(0.1, "rad: and within this heading", min=0.01,
                               aliases=("TrajectoryPlannerROS/yaw_goal_tolerance",))
    robot_radius = Param(0.18, "m: radius of the round footprint", min=0.01,
                         aliases=("global_costmap/robot_radius", "local_costmap/robot_radius"))
    footprint_padding = Param(0.04, "m kept free around the footprint by the local planner", min=0.0,
                              aliases=("local_costmap/footprint_padding", "global_costmap/footprint_padding"))
    inflation_radius = Param(0.55, "m: costs reach this far from obstacles", min=0.0,
                             aliases=("global_costmap/inflation_layer/inflation_radius",
                                      "global_costmap/inflation_radius"))
    cost_scaling_factor = Param(10.0, "1/m: decay of the inflation cost", min=0.0,
                                aliases=("global_costmap/inflation_layer/cost_scaling_factor",
                                         "global_costmap/cost_scaling_factor"))
    cost_factor = Param(3.0, "how much an inflated cell's cost lengthens the plan through it", min=0.0)
    allow_unknown = Param(True, "plan through unknown cells (needed to explore)", aliases=("NavfnROS/allow_unknown",))
    obstacle_range = Param(3.0, "m: scan hits further than this do not mark the global costmap", min=0.0,
                           aliases=("global_costmap/obstacle_layer/obstacle_range", "global_costmap/obstacle_range"))
    max_vel_x = Param(0.5, "m/s: fastest forward speed", min=0.01, aliases=("TrajectoryPlannerROS/max_vel_x",))
    min_vel_x = Param(-0.1, "m/s (negative: the local planner may back up a little)",
                      aliases=("TrajectoryPlannerROS/min_vel_x",))
    max_vel_theta = Param(1.5, "rad/s: fastest turn", min=0.01, aliases=("TrajectoryPlannerROS/max_vel_theta",))
    acc_lim_x = Param(1.5, "m/s^2: forward acceleration limit of the arcs tried", min=0.01,
                      aliases=("TrajectoryPlannerROS/acc_lim_x",))
    acc_lim_theta = Param(5.0, "rad/s^2: angular acceleration limit of the arcs tried", min=0.01,
                          aliases=("TrajectoryPlannerROS/acc_lim_theta",))
    sim_time = Param(1.5, "s of each trajectory the local planner rolls out", min=0.1,
                     aliases=("TrajectoryPlannerROS/sim_time",))
    vx_samples = Param(7, "number of forward speeds the local planner tries", min=2,
                       aliases=("TrajectoryPlannerROS/vx_samples",))
    vth_samples = Param(21, "number of turn rates the local planner tries", min=3,
                        aliases=("TrajectoryPlannerROS/vtheta_samples",))
    lookahead = Param(0.8, "m along the plan to the point the local planner steers at", min=0.1)
    wait_for_map = Param(30.0, "s a goal waits for a map and localization before it is aborted (a whole graph "
                               "starting on a loaded machine takes seconds)", min=0.0)
    costmap_publish_frequency = Param(0.5, "Hz: costmap publication (0: never)", min=0.0,
                                      aliases=("global_costmap/publish_frequency",))
    global_frame = Param("map", "frame of the map and of plans", aliases=("global_costmap/global_frame",))
    transform_timeout = Param(5.0, "s a map -> odom transform stays usable after its stamp (a localizer on a "
                                   "loaded machine publishes late); older counts as lost: the robot stops and the "
                                   "goal waits, aborted after wait_for_map s without it (0: never stale)", min=0.0)
    dynamic_padding = Param(0.1, "m the local planner keeps beyond footprint_padding from what the scan sees "
                                 "off the map (people and robots move)", min=0.0)
    prediction_horizon = Param(1.5, "s ahead the local planner predicts what the scan sees moving off the map "
                                    "(tracked from scan to scan, constant velocity; 0: no prediction)", min=0.0)
    creep_vel_x = Param(0.1, "m/s the robot may still creep at where even braking cannot keep clear of a walker's "
                              "predicted path (a walker stops for a robot in the way)", min=0.0)
    tracking_cluster_tolerance = Param(0.2, "m: off-map hits this close are one moving obstacle", min=0.01)
    tracking_gate = Param(0.6, "m a cluster may be from a track's predicted position to continue it", min=0.01)
    tracking_min_speed = Param(0.15, "m/s below which a tracked obstacle counts as standing", min=0.0)
    tracking_max_speed = Param(1.8, "m/s: a faster apparent motion is a mismatch, not a walk", min=0.1)
    tracking_timeout = Param(0.6, "s a track is kept while its obstacle is not seen", min=0.0)
    tracking_lost_keep = Param(0.0, "s a walker whose predicted place the scan cannot see (out of a narrow view, "
                                    "too near) is kept, predicted and circled by a growing uncertainty, as an "
                                    "obstacle for the local planner (0: dropped after tracking_timeout)", min=0.0)
    tracking_lost_slow = Param(0.0, "s after a walker went out of the scan's sight that the robot keeps to "
                                     "creep_vel_x while the walker, where last seen or where predicted, is ahead "
                                     "of it within tracking_lost_slow_reach (0: off)", min=0.0)
    creep_face = Param(0.15, "rad: when tracking_lost_slow's creep ends with the walker still out of sight and the "
                             "plan turns to her side, the robot first turns on the spot until it faces the plan "
                             "within this (for at most 2 s), and only then speeds up: it looks where it will drive, "
                             "where she may stand (0: off)", min=0.0)
    tracking_lost_slow_reach = Param(1.0, "m (centre to centre) within which a walker out of sight slows the "
                                          "robot, see tracking_lost_slow", min=0.0)
    tracking_blind_range = Param(0.0, "m from the scan's origin it sees nothing, if more than its range_min says "
                                      "(a depth camera's minimum, which blindspot's filled scan lowers): tracking "
                                      "and seen_keep's ground count a beam with no return as seen only beyond it",
                                 min=0.0)
    max_scan_age = Param(2.0, "s: a scan older than this by its stamp is no sight (the costmap's "
                              "expected_update_rate idea): with a goal, the robot is held still until a fresher one "
                              "comes, and the goal aborted after wait_for_map s without one (0: never stale; "
                              "before the first scan the map alone steers)",
                         min=0.0)
    obstacle_memory = Param(0.0, "s a hit off the map is remembered while the scan cannot see its place (a narrow "
                                 "scan: navigation.obstacle_memory; 0: the latest scan only)", min=0.0)
    hit_memory = Param(0.0, "s every scan hit (on the map or off it) is remembered, in the odometry frame, while "
                            "the scan cannot see its place (nearer than its minimum range, out of its view): the "
                            "local planner keeps off it as off the scan. A narrow scan with a blind range (a depth "
                            "camera's) otherwise knows what is beside it or within 0.45 m only from the map, placed "
                            "by the localization's estimate, which may be centimetres off; recovery keeps these "
                            "(0: off)",
                       min=0.0)
    map_cell_corners = Param(False, "the local planner keeps off the corners of the map's wall cells (true) or their "
                                    "centres (false). From a centre, a rim passing a box's corner cell at robot_radius "
                                    "+ footprint_padding is 0.005 m from the corner: harmless where the scan sees the "
                                    "box (its hits lie on the surface), not within a depth camera's blind range "
                                    "beside and before the robot. Corners narrow a door by up to 0.07 m")
    seen_keep = Param(0.0, "s: the robot drives only onto ground its scan saw free within this time (a narrow "
                           "scan: navigation.seen_space; turning on the spot is free; 0: anywhere the scan and map "
                           "leave free)", min=0.0)
    seen_reach = Param(0.0, "m from the robot within which seen_keep's unseen ground counts (0: as far as an arc "
                            "reaches, lookahead + max_vel_x * sim_time). A camera sees ahead what the robot drives "
                            "onto, beyond its blind range: only the ground beside and just ahead, which it may "
                            "never have seen, needs keeping off", min=0.0)

    hold_near = Param(0.0, "m: while every trajectory or plan is blocked and a track seen walking (a person, a "
                           "robot) is this near, a zero command every cycle holds the motor line (the robot waits), "
                           "instead of one zero that leaves it to the lower levels (0: never)", min=0.0)

    def setup(self) -> None:
        self.grid: OccupancyMap | None = None
        self.costmap: Costmap | None = None
        self.mounts = MountListener(self.node)
        self.map_to_odom: np.ndarray | None = None
        self.map_to_odom_stamp = -math.inf
        self.odom_frame = ""
        self.base_frame = ""
        self.odom_pose: np.ndarray | None = None
        # a scan is placed with the odometry of its own instant: the simulator sends the scan before that instant's
        # odometry, and hits placed with the pose of the period before (0.1 s of turning at 1 rad/s: 10 cm at 1 m)
        # put a box's corner beside the robot 6 cm off in its memory (frontier exploration, depth scan: contacts)
        self.scan_sync = ScanOdometrySync(self._on_scan_at)
        self.velocity = (0.0, 0.0)
        self.obstacles_base = np.zeros((0, 2))
        self.scan_stamp = -math.inf  # the newest scan's stamp (its arrival when unstamped)
        self.memory = ObstacleMemory(self.obstacle_memory, self.obstacle_range)
        self.hits = ObstacleMemory(self.hit_memory, HIT_MEMORY_REACH, HIT_MEMORY_CELL)
        self.tracker = ObstacleTracker(self._tracker_params())
        self.seen = SeenSpace(footprint=self.robot_radius)
        self.current: _Goal | None = None
        self._stopped = True
        # the planner's numba kernels compiled (or loaded from numba's cache) now, before the simulation runs: at
        # the first goal they held the node for a second or more while lower levels drove the robot off it
        warm_up_planner(self._planner_params())
        self.node.subscribe("/tf", TFMessage, self._on_tf)
        self.server = ActionServer(self.node, "move_base", MoveBaseAction, self._on_goal, on_cancel=self._on_cancel,
                                   single_goal=True, on_preempt=lambda old, new: self._end(old))
        self._simple = self.node.publisher("move_base/goal", MoveBaseActionGoal)
        self.node.subscribe("move_base_simple/goal", PoseStamped, self._on_simple_goal)
        self.every(1.0 / self.controller_frequency, self._control)
        if self.costmap_publish_frequency > 0:
            self.every(1.0 / self.costmap_publish_frequency, self._publish_costmaps)
        # move_base's services, private as move_base has them: /move_base/make_plan, /move_base/clear_costmaps
        self.node.service("~make_plan", GetPlan, self._make_plan)
        self.node.service("~clear_costmaps", Empty, self._clear_costmaps)

    def _make_plan(self, request) -> GetPlanResponse:
        """move_base's ``make_plan``: a global plan from `start` (the robot's pose when its frame_id is empty) to
        `goal`, in the map frame, without moving the robot. No path (a goal off the map, in an obstacle, cut off)
        is an empty plan, as move_base answers, and the reason is logged. `tolerance` is not used."""
        if self.costmap is None:
            raise ValueError(f"no map on {self.node.resolve('map')} yet")
        for which in (request.start, request.goal):
            frame = which.header.frame_id.lstrip("/")
            if frame and frame != self.global_frame:
                raise ValueError(f"pose in frame {which.header.frame_id!r}: plans are made in {self.global_frame!r}")
        if request.start.header.frame_id:
            start = from_pose_msg(request.start.pose)
        else:
            start = self.pose()
            if start is None:
                raise ValueError("no start given and the robot's pose is not known yet")
        goal = from_pose_msg(request.goal.pose)
        try:
            found = make_plan(self.costmap, (start[0], start[1]), (goal[0], goal[1]), self._planner_params(),
                              static_only=True)
        except PlanError as error:
            self.log(f"make_plan: {error}", "warn")
            return GetPlanResponse(Path(header=self._header()))
        return GetPlanResponse(Path(header=self._header(), poses=[
            PoseStamped(header=self._header(), pose=pose_msg(np.array([p[0], p[1], 0.0]))) for p in found.points]))

    def _clear_costmaps(self, _request) -> EmptyResponse:
        """move_base's ``clear_costmaps``: forget what the scans marked (the static map stays), as its recovery
        does: the latest scan's obstacles, the remembered ones, and the obstacles it was tracking."""
        if self.costmap is not None:
            self.costmap.set_scan_points(np.zeros((0, 2)))
        self.memory.clear()
        self.hits.clear()
        self.tracker = ObstacleTracker(self._tracker_params())
        self.log("costmaps cleared (clear_costmaps)")
        return EmptyResponse()

    def on_reconfigure(self, changed: dict) -> None:
        """Only the parameters read per use change; the map, the goal and the subscriptions stay."""
        if any(name.startswith("tracking_") for name in changed):
            self.tracker.params = self._tracker_params()
        if self.grid is not None and {"robot_radius", "inflation_radius", "cost_scaling_factor"} & set(changed):
            self.costmap = Costmap(self.grid, self._inflation())

    # Parameters as the planners take them ---------------------------------------------------------------
    def _inflation(self) -> InflationParams:
        return InflationParams(self.robot_radius, max(self.inflation_radius, self.robot_radius),
                               self.cost_scaling_factor, track_unknown_space=False)

    def _tracker_params(self) -> TrackerParams:
        return TrackerParams(cluster_tolerance=self.tracking_cluster_tolerance, gate=self.tracking_gate,
                             max_speed=self.tracking_max_speed, min_speed=self.tracking_min_speed,
                             timeout=self.tracking_timeout, lost_keep=self.tracking_lost_keep,
                             lost_slow=self.tracking_lost_slow,
                             robot_radius=self.robot_radius)

    @property
    def _build_aside(self) -> bool:
        """Build the planner's landmarks in a thread of their own (0.5-1.5 s on a 1000 x 1000 map, during which
        this node's control loop would not run), except where the clock waits for this node (in-process): there
        the build costs no time, and building in line keeps runs reproducible to the bit."""
        return not self.node.clock_waits_for_callbacks

    def _planner_params(self) -> PlannerParams:
        return PlannerParams(cost_factor=self.cost_factor, allow_unknown=self.allow_unknown)

    def _local_params(self) -> LocalParams:
        return LocalParams(max_vel_x=self.max_vel_x, min_vel_x=self.min_vel_x, max_vel_theta=self.max_vel_theta,
                           acc_lim_x=self.acc_lim_x, acc_lim_theta=self.acc_lim_theta, sim_time=self.sim_time,
                           vx_samples=self.vx_samples, vth_samples=self.vth_samples, robot_radius=self.robot_radius,
                           footprint_padding=self.footprint_padding, lookahead=self.lookahead,
                           xy_goal_tolerance=self.xy_goal_tolerance, yaw_goal_tolerance=self.yaw_goal_tolerance,
                           dynamic_padding=self.dynamic_padding, prediction_horizon=self.prediction_horizon,
                           creep_vel_x=self.creep_vel_x, unseen_clearance=self.seen.rim_clearance(self.robot_radius))

    # Inputs ---------------------------------------------------------------------------------------
    def on_map(self, msg: OccupancyGrid) -> None:
        """Take a new static map for the global costmap (a malformed grid is logged and ignored)."""
        try:
            grid = grid_of(msg, self.node.resolve("map"))
        except GridMessageError as error:
            self.log(f"map ignored: {error}", "error")
            return
        self.grid = grid
        self.costmap = Costmap(grid, self._inflation())
        if self.current is not None:
            self.current.last_plan = -math.inf  # replan on the new map

    def on_odom(self, msg: Odometry) -> None:
        """Keep the odometry pose, frames and velocity, and pass the message on for pairing with scans."""
        self.odom_pose = from_pose_msg(msg.pose.pose)
        self.odom_frame = msg.header.frame_id
        self.base_frame = msg.child_frame_id
        self.velocity = (msg.twist.twist.linear.x, msg.twist.twist.angular.z)
        self.scan_sync.on_odom(msg)

    def _on_tf(self, msg: TFMessage) -> None:
        for t in msg.transforms:
            if t.header.frame_id.lstrip("/") == self.global_frame and self.odom_frame and \
                    t.child_frame_id.lstrip("/") == self.odom_frame.lstrip("/"):
                tr = t.transform
                self.map_to_odom = np.array([tr.translation.x, tr.translation.y, yaw_of(tr.rotation)])
                self.map_to_odom_stamp = t.header.stamp.to_sec()

    def on_scan(self, msg: LaserScan) -> None:
        """Place the scan with the odometry of its own stamp (an unstamped one with the latest odometry)."""
        if self.odom_frame == "":
            return
        if msg.header.stamp.to_sec() <= 0:  # unstamped: no instant to look up, the latest odometry it is
            self._on_scan_at(msg, self.odom_pose)
        else:
            self.scan_sync.on_scan(msg)

    def _on_scan_at(self, msg: LaserScan, odom: np.ndarray) -> None:
        """One scan with the odometry pose at its stamp: the obstacles the planners avoid, and what is remembered
        of them in the odometry frame."""
        mount = self.mounts.mount(self.base_frame, msg.header.frame_id)
        if mount is None:
            return
        beams = beams_of(msg, mount)
        self.obstacles_base = beams.hits()
        stamp = msg.header.stamp.to_sec()
        self.scan_stamp = max(self.scan_stamp, stamp if stamp > 0 else self.now())
        pose = self.pose(odom)
        located = self.costmap is not None and pose is not None
        # the hits off the map, found once per scan for both their users below
        off_map = self._dynamic(pose) if located and (self.prediction_horizon > 0 or self.obstacle_memory > 0) \
            else None
        if self.prediction_horizon > 0 and off_map is not None:
            blind = max(float(msg.range_min), self.tracking_blind_range)
            self.tracker.update(self.now(), odom, off_map,
                                lambda points: ~ObstacleMemory.in_view(points, beams, blind))
        if self.seen_keep > 0:
            self.seen.footprint, self.seen.blind = self.robot_radius, self.tracking_blind_range
            self.seen.update(self.now(), odom, beams)
        if self.obstacle_memory > 0 and off_map is not None:
            self.memory.keep = self.obstacle_memory
            remembered = self.memory.update(self.now(), odom, beams, msg.range_min, off_map)
            if len(remembered):
                self.obstacles_base = np.concatenate([self.obstacles_base, remembered])
        if self.hit_memory > 0:
            self.hits.keep = self.hit_memory
            blind = max(float(msg.range_min), self.tracking_blind_range)
            remembered = self.hits.update(self.now(), odom, beams, blind, beams.hits())
            if len(remembered):
                self.obstacles_base = np.concatenate([self.obstacles_base, remembered])
        if self.costmap is not None and pose is not None:
            near = self.obstacles_base[np.hypot(*self.obstacles_base.T) <= self.obstacle_range] \
                if len(self.obstacles_base) else self.obstacles_base
            self.costmap.set_scan_points(transform_points(pose, near) if len(near) else near)

    def pose(self, odom: np.ndarray | None = None) -> np.ndarray | None:
        """The robot in the global frame, as localization says, or None when it has not said: now, or where
        odometry said `odom` (a scan's instant)."""
        odom = self.odom_pose if odom is None else odom
        if self.map_to_odom is None or odom is None:
            return None
        if self.transform_timeout > 0 and self.now() - self.map_to_odom_stamp > self.transform_timeout:
            return None
        return compose(self.map_to_odom, odom)

    # Goals ----------------------------------------------------------------------------------------
    def _on_simple_goal(self, msg: PoseStamped) -> None:
        action_goal = MoveBaseActionGoal(header=Header(0, genpy.Time.from_sec(max(self.now(), 0.0)), ""))
        action_goal.goal.target_pose = msg
        self._simple.publish(action_goal)

    def _on_goal(self, handle: ServerGoal) -> None:
        handle.accept()
        goal = _Goal(handle, None, self.now())
        self.current = goal
        if self._read_target(goal) and self.costmap is not None and self.pose() is not None:
            self._check_and_plan(goal)

    def _read_target(self, goal: _Goal) -> bool:
        """Puts the goal's pose into the global frame; aborts a goal that can never be read. False while it
        cannot be read yet (its frame is odom and localization has not said where odom is)."""
        target = goal.handle.goal.target_pose
        q = target.pose.orientation
        norm = math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)
        values = [target.pose.position.x, target.pose.position.y, q.x, q.y, q.z, q.w]
        if not all(math.isfinite(v) for v in values) or norm < 1e-6:
            self._abort(goal, "target_pose is not a valid pose (NaN, inf or a zero quaternion)")
            return False
        pose = from_pose_msg(target.pose)
        frame = target.header.frame_id.lstrip("/")
        if frame in ("", self.global_frame):
            goal.target = pose
            return True
        if self.odom_frame and frame == self.odom_frame.lstrip("/"):
            if self.map_to_odom is None:
                return False
            goal.target = compose(self.map_to_odom, pose)
            return True
        self._abort(goal, f"target_pose.header.frame_id {target.header.frame_id!r} is neither "
                          f"{self.global_frame!r} nor the odometry frame {self.odom_frame!r}")
        return False

    def _check_and_plan(self, goal: _Goal) -> None:
        """Validates the goal on the static map (aborting at once with the reason) and makes the first plan."""
        assert self.costmap is not None and goal.target is not None
        x, y = goal.target[:2]
        if not self.costmap.contains(x, y):
            x0, x1, y0, y1 = self.grid.extent()
            self._abort(goal, f"goal ({x:.2f}, {y:.2f}) is off the map (x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f})")
            return
        cost = self.costmap.cost_at(x, y, static_only=True)
        blocked = self._unreachable_because(cost)
        if blocked:
            self._abort(goal, f"goal ({x:.2f}, {y:.2f}) is {blocked}")
            return
        if cost == NO_INFORMATION and not self.allow_unknown:
            self._abort(goal, f"goal ({x:.2f}, {y:.2f}) is in unknown space and allow_unknown is false")
            return
        pose = self.pose()
        goal.start_pose = pose
        goal.progress_pose, goal.progress_at = pose, self.now()
        # a goal the robot already stands within xy_goal_tolerance of: its position is reached (only the heading
        # is left), as base_local_planner judges it. The local planner latches a position it drives to only within
        # half the tolerance; applied to a goal that comes to a robot standing 0.11 m from it, that turned the
        # robot round to face a point behind it, crept 7 cm and turned back: 5.2 s for the patrol's first goal
        # (the start corner) in-process against 0.04 s on ROS, where the robot had not yet been driven off it
        goal.latched = math.hypot(x - pose[0], y - pose[1]) <= self.xy_goal_tolerance
        try:
            make_plan(self.costmap, (pose[0], pose[1]), (x, y), self._planner_params(), static_only=True,
                      background=self._build_aside)
        except PlanError as error:
            self._abort(goal, f"no path to ({x:.2f}, {y:.2f}) on the map: {error}")
            return
        self._replan(goal, pose)

    def _goal_now_blocked(self, goal: _Goal) -> bool:
        """Aborts a goal that a newer map (SLAM's, growing) shows inside an obstacle or within the robot's radius
        of one, as it would have been aborted on arrival: driving on to it takes the robot's rim to the obstacle
        (frontier exploration with a depth scan: a goal 0.17 m from a box that was unknown when it was sent,
        touched with the estimate 0.12 m off)."""
        x, y = goal.target[:2]
        inside = self.costmap.contains(x, y)
        blocked = self._unreachable_because(self.costmap.cost_at(x, y, static_only=True)) if inside else ""
        if not blocked:
            return False
        self._abort(goal, f"goal ({x:.2f}, {y:.2f}) is now {blocked} on the map")
        return True

    def _unreachable_because(self, cost: int) -> str:
        """Why a goal on a cell of this static cost cannot be reached ("": it can): one rule for a new goal and
        for a goal under way when the map changes."""
        if cost == LETHAL:
            return "inside an obstacle"
        if cost == INSCRIBED:
            return f"closer to an obstacle than the robot's radius ({self.robot_radius:g} m)"
        return ""

    def _replan(self, goal: _Goal, pose: np.ndarray) -> None:
        goal.last_plan = self.now()
        try:
            goal.plan = make_plan(self.costmap, (pose[0], pose[1]), (goal.target[0], goal.target[1]),
                             self._planner_params(), background=self._build_aside)
            goal.plan_failing_since = None
        except PlanError:
            if goal.plan_failing_since is None:
                goal.plan_failing_since = self.now()
            return
        self.plan.publish(Path(header=self._header(), poses=[
            PoseStamped(header=self._header(), pose=pose_msg(np.array([p[0], p[1], 0.0]))) for p in goal.plan.points]))

    def _on_cancel(self, handle: ServerGoal) -> None:
        if self.current is not None and self.current.handle is handle:
            self._end(handle)
        handle.cancelled(MoveBaseResult(), "cancelled by the client")

    def _end(self, handle: ServerGoal) -> None:
        """Stop working on `handle` (the result is set by whoever calls this)."""
        if self.current is not None and self.current.handle is handle:
            self.current = None
            self._stop()

    def _abort(self, goal: _Goal, why: str) -> None:
        self.log(f"goal {goal.handle.id} aborted: {why}", "warn")
        if self.current is goal:
            self.current = None
            self._stop()
        if goal.handle.active:
            goal.handle.abort(MoveBaseResult(), why)

    def _succeed(self, goal: _Goal, pose: np.ndarray) -> None:
        self.current = None
        self._stop()
        d = math.hypot(*(goal.target[:2] - pose[:2]))
        goal.handle.succeed(MoveBaseResult(), f"reached: {d:.3f} m and "
                                              f"{abs(float(wrap(goal.target[2] - pose[2]))):.3f} rad from the goal")

    # Control loop ---------------------------------------------------------------------------------
    def _control(self) -> None:
        goal = self.current
        if goal is None:
            return
        now = self.now()
        if goal.target is None and not self._read_target(goal):
            if self.current is goal and now - goal.received > self.wait_for_map:
                self._abort(goal, f"no map -> odom transform (localization) within {self.wait_for_map:g} s")
            return
        pose = self.pose()
        if self.costmap is None or pose is None:
            # waiting counts from the goal's arrival, or from when the pose was lost during the goal
            goal.waiting_since = goal.waiting_since if goal.waiting_since is not None else now
            if now - (goal.received if goal.start_pose is None else goal.waiting_since) > self.wait_for_map:
                missing = f"no map on {self.node.resolve('map')}" if self.costmap is None else \
                    f"no localization ({self.global_frame} -> {self.odom_frame or 'odom'} on /tf)"
                self._abort(goal, f"{missing} within {self.wait_for_map:g} s")
            elif self.current is goal:
                self._hold()
            return
        goal.waiting_since = None
        if goal.start_pose is None:
            self._check_and_plan(goal)
            if self.current is not goal:
                return
        if goal.recovery:
            self._run_recovery(goal, pose, now)
            return
        if goal.plan is None or (self.planner_frequency > 0 and now - goal.last_plan >= 1.0 / self.planner_frequency):
            if self._goal_now_blocked(goal):
                return
            self._replan(goal, pose)
        if goal.plan is None:
            if goal.plan_failing_since is not None and now - goal.plan_failing_since > self.planner_patience:
                self._stuck(goal, pose, "no plan around the obstacles the scan sees")
            self._blocked(pose)
            return
        if goal.plan_failing_since is not None and now - goal.plan_failing_since > self.planner_patience:
            self._stuck(goal, pose, "no plan around the obstacles the scan sees")
            return
        if self._scan_stale(goal, now):
            return
        lost = self._lost()
        self._watch_creep(goal, pose, now)
        command = compute_command(pose, self.velocity, goal.plan.points, goal.target,
                                  np.concatenate([self._obstacles(pose), lost]), self._control_params(goal),
                                  goal.latched, np.concatenate([self._dynamic(pose), lost]), self._moving(),
                                  self._unseen())
        goal.latched = command.latched
        if goal.facing_since is not None and command.why != TURNING_TO_PLAN:
            goal.facing_since = None  # it faces the plan (or cannot turn there): it drives on as the planner says
        if command.why == AT_GOAL:
            self._succeed(goal, pose)
            return
        if not command.ok:
            goal.blocked_since = goal.blocked_since if goal.blocked_since is not None else now
            self._blocked(pose)
            if now - goal.blocked_since > self.controller_patience:
                self._stuck(goal, pose, command.why)
            return
        goal.blocked_since = None
        self._send(command.v, self._kept_turn(goal, command, now))
        near_goal = math.hypot(*(goal.target[:2] - pose[:2])) <= self.xy_goal_tolerance * 2
        if near_goal or math.hypot(*(pose[:2] - goal.progress_pose[:2])) >= self.oscillation_distance:
            goal.progress_pose, goal.progress_at = pose, now
        elif self.oscillation_timeout > 0 and now - goal.progress_at > self.oscillation_timeout:
            self._stuck(goal, pose, f"moved less than {self.oscillation_distance:g} m in "
                                    f"{self.oscillation_timeout:g} s")
            return
        goal.handle.feedback(MoveBaseFeedback(base_position=PoseStamped(header=self._header(), pose=pose_msg(pose))))

    def _obstacles(self, pose: np.ndarray) -> np.ndarray:
        """The scan's hits and the static map's walls within 2 m, in the robot's frame; a wall cell as its centre,
        or with `map_cell_corners` as the corners of its square (frontier exploration with a depth scan touched box
        corners at 0.219-0.224 m from their cells' centres)."""
        points = [self.obstacles_base]
        grid = self.costmap.grid
        row, col = grid.cell_of(pose[0], pose[1])
        reach = int(math.ceil(2.0 / grid.resolution))
        r0, c0 = max(row - reach, 0), max(col - reach, 0)
        window = self.costmap.static[r0: row + reach + 1, c0: col + reach + 1]
        if window.any():
            if self.map_cell_corners:
                world = cell_corners(window, r0, c0, grid.origin, grid.resolution)
            else:
                rows, cols = np.nonzero(window)
                world = self.costmap.centres_of(rows + r0, cols + c0)
            c, s = math.cos(pose[2]), math.sin(pose[2])
            d = world - pose[:2]
            points.append(np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1])))
        return np.concatenate(points) if len(points) > 1 else points[0]

    def _dynamic(self, pose: np.ndarray) -> np.ndarray:
        """The scan's hits that are not on the map (more than 0.15 m from its walls: people, robots, things
        moved), in the robot's frame."""
        hits = self.obstacles_base
        if not len(hits) or self.dynamic_padding <= 0:
            return np.zeros((0, 2))
        rows, cols = self.costmap.cells_of(transform_points(pose, hits))
        height, width = self.costmap.shape
        inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
        far = np.ones(len(hits), dtype=bool)
        far[inside] = self.costmap.wall_distance[rows[inside], cols[inside]] > 0.15
        return hits[far]

    def _lost(self) -> np.ndarray:
        """Points round the walkers that went out of the scan's sight (robot frame), see tracking_lost_keep."""
        if self.tracking_lost_keep <= 0 or self.odom_pose is None:
            return np.zeros((0, 2))
        return self.tracker.lost(self.now(), self.odom_pose)

    def _watch_creep(self, goal: _Goal, pose: np.ndarray, now: float) -> None:
        """Once per control cycle, before the local planner: whether tracking_lost_slow holds the robot to
        creep_vel_x (a walker the scan lost is just ahead), and whether the robot is to turn to face the plan
        first (creep_face): when a creep ends with the walker still out of sight (lost too long ago, or no longer
        ahead) and the plan turns to her side, for at most CREEP_FACE_S.

        Why the turn: a walker who stopped beside the robot, out of its view, to let it pass is still there once
        the creep is over; curving towards the plan at full speed, the robot ran into her side (the short level-4
        scene on the ROS graph); turned to face the plan first, it sees her. A plan that turns the other way curves
        away from her, and a walker in sight again is where the robot knows: no need to stop and look."""
        if self.max_vel_x <= self.creep_vel_x or self.odom_pose is None:
            goal.creeping, goal.facing_since = False, None
            return
        if self.tracker.lost_near(now, self.odom_pose, self.tracking_lost_slow_reach):
            self.log_every("lost_walker", 5.0, "a walker out of sight just ahead: creeping")
            near = self.tracker.walked_near(self.odom_pose, self.tracking_lost_slow_reach)
            if near:  # the side she is on (robot frame: + left), by the nearest walker
                goal.lost_side = math.copysign(1.0, float(min(near, key=lambda w: np.hypot(*w[0]))[0][1]))
            goal.creeping, goal.facing_since = True, None
            return
        if goal.creeping:
            goal.creeping = False
            unseen = not self.tracker.walked_near(self.odom_pose, self.tracking_lost_slow_reach, now,
                                                  self.tracking_timeout)
            towards = goal.lost_side is not None and goal.plan is not None and \
                self._plan_bearing(goal, pose) * goal.lost_side > 0
            goal.facing_since = now if self.creep_face > 0 and unseen and towards else None
        if goal.facing_since is not None and now - goal.facing_since > CREEP_FACE_S:
            goal.facing_since = None

    def _control_params(self, goal: _Goal) -> LocalParams:
        """The local planner's parameters for this cycle, as _watch_creep left `goal`: at most creep_vel_x while
        creeping, so that the planner picks among the arcs it can check at that speed; while turning to face the
        plan, a turn on the spot towards it from creep_face off it (not from rotate_in_place_above)."""
        params = self._local_params()
        if goal.creeping:
            return replace(params, max_vel_x=self.creep_vel_x)
        if goal.facing_since is not None:
            return replace(params, rotate_in_place_above=min(params.rotate_in_place_above, self.creep_face))
        return params

    def _plan_bearing(self, goal: _Goal, pose: np.ndarray) -> float:
        """rad, robot frame (+ left): the bearing of the local planner's carrot on the plan."""
        target, _, _ = carrot(goal.plan.points, pose[:2], self.lookahead)
        return float(wrap(math.atan2(target[1] - pose[1], target[0] - pose[0]) - pose[2]))

    def _kept_turn(self, goal: _Goal, command: Command, now: float) -> float:
        """The command's turn rate, reversed when it turns on the spot the other way from the turn on the spot just
        before (within turn_commit s). Where the local planner's reasons alternate near a person (turning towards
        the plan, turning away from what is near: the nearest hit either side of the safety radius) or a bearing
        lies straight behind, each cycle's own best direction flips, and the robot turns back and forth where it
        is; kept, the turn completes one way. Only on-the-spot turns are changed, which for a round robot are
        clear either way; arcs and the final turn to the goal's heading are not."""
        if command.v != 0.0:
            goal.turn = None
            return command.w
        if command.w == 0.0 or command.latched or self.turn_commit <= 0:
            return command.w
        w = command.w
        recent = goal.turn is not None and now - goal.turn[1] <= self.turn_commit
        if recent and math.copysign(1.0, w) != goal.turn[0]:
            w = -w
        goal.turn = (math.copysign(1.0, w), now)
        return w

    def _unseen(self) -> np.ndarray | None:
        """The ground near the robot its scan has not seen free for seen_keep s, robot frame (None: not kept)."""
        if self.seen_keep <= 0 or self.odom_pose is None:
            return None
        return self.seen.unseen(self.now(), self.odom_pose, self.seen_keep,
                                self.seen_reach or self.lookahead + self.max_vel_x * self.sim_time)

    def _moving(self) -> MovingObstacles | None:
        """The tracked obstacles predicted to now, in the robot's frame (None: prediction off or no odometry)."""
        if self.prediction_horizon <= 0 or self.odom_pose is None:
            return None
        return self.tracker.moving(self.now(), self.odom_pose)

    # Recovery -------------------------------------------------------------------------------------
    def _stuck(self, goal: _Goal, pose: np.ndarray, why: str) -> None:
        if not self.recovery_behavior_enabled or goal.recoveries >= self.max_recoveries:
            self._abort(goal, f"stuck: {why}" + (f" (after {goal.recoveries} recovery rounds)" if goal.recoveries else ""))
            return
        goal.recoveries += 1
        now = self.now()
        # with a narrow scan's memory (obstacle_memory), giving way alternates with turning round: a turn looks all
        # round (the scan sees again what it remembered near, and forgets what is gone: a person blindspot kept at
        # the rim after she had left held office seed 1 at a door for 120 s through four give-way rounds that never
        # got under way). A scan that sees all round has nothing to refresh: it gives way every round (alternating,
        # the laser robot reached 40 of 50 goals in the office with people walking, against 45 without)
        remembers = self.obstacle_memory > 0
        escape = self._give_way_point(pose) if not remembers or goal.recoveries % 2 == 1 else None
        if escape is not None:
            self.log(f"goal {goal.handle.id}: {why}; recovery {goal.recoveries}: something that moves is near: "
                     f"give way to ({escape[0]:.2f}, {escape[1]:.2f}), wait, replan")
        else:
            self.log(f"goal {goal.handle.id}: {why}; recovery {goal.recoveries}: clear the scan's obstacles, "
                     f"{'back off and ' if goal.recoveries % 2 == 0 else ''}rotate, replan")
        people_near = self._people_near(pose)
        may_back_off = escape is None and goal.recoveries % 2 == 0 and self._rear_clear(pose) and not people_near
        # the turn to leave only with nothing that moves near: it may stand where the scan does not look
        leave = goal.plan.points if goal.plan is not None and not people_near and not len(self._lost()) else None
        steps = recovery_round(now, goal.recoveries, escape, may_back_off, leave)
        self.costmap.set_scan_points(np.zeros((0, 2)))
        self.memory.clear()
        goal.recovery = steps
        goal.plan = None
        goal.blocked_since = None
        goal.plan_failing_since = None

    def _give_way_point(self, pose: np.ndarray) -> np.ndarray | None:
        """Where to step aside to (recovery.give_way_point) from what the scan sees off the map and the walkers
        tracked near, on a cell the static map leaves free for the footprint."""
        walkers = self.tracker.walked_near(self.odom_pose, GIVE_WAY_NEAR + 0.5) if self.odom_pose is not None \
            else []

        def free(x: float, y: float) -> bool:
            return self.costmap.contains(x, y) and \
                self.costmap.cost_at(x, y, static_only=True) not in (LETHAL, INSCRIBED, NO_INFORMATION)

        return give_way_point(pose, self._dynamic(pose), walkers, free)

    def _people_near(self, pose: np.ndarray) -> bool:
        """Something off the map (it may move) within BLIND_SPOT_CARE: backing up could meet it unseen."""
        dynamic = self._dynamic(pose)
        return bool(len(dynamic)) and float(np.hypot(*dynamic.T).min()) < BLIND_SPOT_CARE

    def _rear_clear(self, pose: np.ndarray) -> bool:
        """Nothing (scan or map) close behind the robot's back (recovery.rear_clear)."""
        obstacles = self._obstacles(pose)
        unseen = self._unseen()
        if unseen is not None and len(unseen):  # ground not seen lately behind counts as taken: it may be
            obstacles = np.concatenate([obstacles, unseen])
        return rear_clear(obstacles, self.robot_radius)

    def _run_recovery(self, goal: _Goal, pose: np.ndarray, now: float) -> None:
        """Drive the first recovery step still to do: steps run out by time, by the robot having stepped aside,
        or (a turn to leave) by facing the way out already; with none left, plan again from here."""
        while goal.recovery:
            step = goal.recovery[0]
            if now >= step.until or self._stepped_aside(step, pose):
                goal.recovery.pop(0)
                continue
            w = self._turn_to_leave(goal, step, pose) if step.leave_plan is not None else step.w
            if w is None:  # already faces the way out
                goal.recovery.pop(0)
                continue
            break
        if not goal.recovery:
            self._stop()
            goal.last_plan = -math.inf
            goal.progress_pose, goal.progress_at = pose, now
            return
        v, target = step.v, step.target
        if step.leave_plan is None and target is not None:
            # the local planner drives there, keeping off everything the scan sees
            lost = self._lost()
            command = compute_command(pose, self.velocity, np.array([pose[:2], target[:2]]), target,
                                      np.concatenate([self._obstacles(pose), lost]), self._local_params(), False,
                                      np.concatenate([self._dynamic(pose), lost]), self._moving(), self._unseen())
            v, w = (command.v, command.w) if command.ok else (0.0, 0.0)
        self._send(v, w)

    def _turn_to_leave(self, goal: _Goal, step: RecoveryStep, pose: np.ndarray) -> float | None:
        """The turn rate towards the heading from which the robot can drive (local_planner.heading_to_leave, on
        the plan it had when stuck and what the scan has shown since), chosen once; None when it faces it (within
        0.1 rad), when the robot's own heading will do, or there is none."""
        if step.leave_yaw is None:
            lost = self._lost()
            heading = heading_to_leave(pose, step.leave_plan, np.concatenate([self._obstacles(pose), lost]),
                                       self._local_params(), self._unseen())
            if heading is None or abs(heading) < 0.1:
                return None
            step.leave_yaw = float(pose[2] + heading)
            self.log(f"goal {goal.handle.id}: turning {math.degrees(heading):+.0f} degrees, to where it can drive")
        return leave_turn_rate(step.leave_yaw, float(pose[2]))

    def _stepped_aside(self, step: RecoveryStep, pose: np.ndarray) -> bool:
        """A give-way step is over once the robot stands near its point (the heading does not matter)."""
        target = step.target
        return target is not None and math.hypot(*(target[:2] - pose[:2])) <= 2 * self.xy_goal_tolerance

    # Outputs --------------------------------------------------------------------------------------
    def _header(self) -> Header:
        return Header(0, genpy.Time.from_sec(max(self.now(), 0.0)), self.global_frame)

    def _send(self, v: float, w: float) -> None:
        msg = Twist()
        msg.linear.x, msg.angular.z = float(v), float(w)
        self.cmd_vel.publish(msg)
        self._stopped = False

    def _stop(self) -> None:
        """One zero command, then the motor line is free for whoever else drives: when a goal ends, and while
        something the scan sees blocks every trajectory or every plan. A person walking at a robot that move_base
        held still with zeros was touched, because the suppressor above level 0 kept its backing away off the
        motors. In-process in the office, that took seed 1 from 0 contacts to 1-4 and from 16/17 goals to
        5-11."""
        if not self._stopped:
            self.cmd_vel.publish(Twist())
            self._stopped = True

    def _blocked(self, pose: np.ndarray) -> None:
        """Every trajectory or plan blocked: one zero and the line is free for the lower levels (see _stop), unless
        a track seen walking is within hold_near: then the robot waits, held (see _hold). In the office with
        walkers that walk (seed 1, 89 s) the robot stood between two people waiting for it, move_base let go, and
        level 1's forward drove it into one of them, who stood in the camera's blind range. Only walkers: held
        for anything off the map near, the robot stood for good in a doorway by a door jamb that blindspot had
        put at its rim (office seed 1, 43-68 s), where the lower levels had moved it on."""
        if self.hold_near > 0 and self.odom_pose is not None and self.tracker.walked_near(self.odom_pose,
                                                                                          self.hold_near):
            self._hold()
        else:
            self._stop()

    def _hold(self) -> None:
        """A zero command every control cycle while a goal is under way but cannot see where it is or what is
        near: no pose, or no fresh scan. ROS's move_base publishes zero velocity then. A single zero left
        the line silent, the suppressor above the lower levels gave it back after its time constant, and they
        drove the robot (on the ROS graph 16% of a patrol run) away from the goal it was about to declare stuck."""
        self.cmd_vel.publish(Twist())
        self._stopped = True

    def _scan_stale(self, goal: _Goal, now: float) -> bool:
        """Whether the newest scan is too old to steer by (held still then; the goal aborted after wait_for_map s
        of it). On a loaded ROS graph the depth pipeline fell seconds behind, and the local planner drove at
        0.4 m/s among obstacles seen 4.6 s before."""
        age = now - self.scan_stamp
        if self.max_scan_age <= 0 or age <= self.max_scan_age or self.scan_stamp == -math.inf:
            # (no scan yet at all: the map alone steers, as in a network that wires no scan)
            goal.scan_stale_since = None
            return False
        goal.scan_stale_since = goal.scan_stale_since if goal.scan_stale_since is not None else now
        if now - goal.scan_stale_since > self.wait_for_map:
            self._abort(goal, f"no scan on {self.node.resolve('scan')} newer than {self.max_scan_age:g} s "
                              f"within {self.wait_for_map:g} s")
            return True
        self.log_every("stale scan", 5.0, f"the newest scan is {age:.1f} s old (max_scan_age {self.max_scan_age:g} "
                                          f"s): holding still until a fresher one comes", "warn")
        self._hold()
        return True

    def _publish_costmaps(self) -> None:
        if self.costmap is None:
            return
        costs = self.costmap.costs
        self.global_costmap.publish(costmap_msg(costs, self.costmap.grid, self.now(), self.global_frame))
        pose = self.pose()
        if pose is None:
            return
        grid = self.costmap.grid
        row, col = grid.cell_of(pose[0], pose[1])
        half = int(round(2.0 / grid.resolution))
        r0, c0 = max(row - half, 0), max(col - half, 0)
        window = costs[r0: row + half, c0: col + half]
        if window.size == 0:
            return
        origin = (grid.origin[0] + c0 * grid.resolution, grid.origin[1] + r0 * grid.resolution)
        local = OccupancyMap(np.zeros(window.shape, dtype=np.int8), grid.resolution, origin, grid.source)
        self.local_costmap.publish(costmap_msg(window, local, self.now(), self.global_frame))
