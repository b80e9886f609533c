"""Frontier exploration (explore_lite's job): drive the robot, through move_base, to the edge of what the map
knows until nothing reachable is left unknown.

A **frontier** cell is a known-free cell next to an unknown one (8-neighbourhood); frontier cells that touch
form a frontier, and one shorter than ``min_frontier_size`` m is noise (a cell the scan skipped). A frontier
counts only where the robot can stand: its cells at least ``robot_radius`` + ``goal_clearance`` m from any
occupied cell, reached from the robot through known-free cells that keep the robot's radius off the walls
(one Dijkstra from the robot, a numba kernel, gives every cell's travel distance). Among the reachable
frontiers the cheapest, ``potential_scale * distance - gain_scale * size`` (explore_lite's names), is the
target; the goal is its cell nearest the robot, facing the unknown cells around it, so that a narrow scan (a
depth camera's 58 degrees) looks into what is unknown when it gets there.

Every 1/``planner_frequency`` s the frontiers are computed again on the latest map: a goal that no frontier's
goal lies near any more (the scan has seen past it, or a wall appeared there) is replaced by the best current
one (move_base takes the new goal and preempts the old, as with explore_lite). A goal move_base aborts, or one
the robot does not get ``progress_distance`` m closer to (along the way there) within ``progress_timeout`` s,
is blacklisted (``blacklist_radius`` m around it); a goal reached is not sent again (half that radius: the
robot looked from there).
Exploration is **done** when the map has shown no reachable frontier (blacklisted ones aside) for
``done_delay`` s (SLAM publishes its map every few seconds; the last scans must be in it): ``~done``
(std_msgs/Bool, latched) turns true and no further goal is sent.

**Stuck is not unreachable.** A goal that fails (no progress, or move_base gives up on it as stuck) while the
robot has not moved ``stuck_distance`` m since the goal was sent says nothing about the frontier: the robot did
not move at all. After ``stuck_goals`` such failures in a row the robot is **stuck**: those goals leave the
blacklist again, failures are no longer blacklisted while it stays there (the best frontier is sent again, and
move_base tries again, with its recovery behaviours), and exploration is never declared done (two such failures
that leave no frontier make it stuck too). Once it has moved
``stuck_distance`` m it goes on as before; stuck for ``stuck_timeout`` s, exploration gives up and is not done:
``~gave_up`` (geometry_msgs/PointStamped, latched) says where the robot stands. Otherwise a robot trapped at one
spot would blacklist every frontier in turn and report the map complete while much of it is unseen.

**Back the way it came.** A goal that fails without the robot moving is followed by a goal ``escape_distance`` m
back along the robot's own path (its poses as it drove, kept every TRAIL_STEP m), before the next frontier: each
such failure in a row goes one ``escape_distance`` further back. That ground it drove over, so it was free and
seen, and a goal behind it gives move_base a plan out of where it stands when every frontier goal fails there.
A robot facing something inside its depth camera's blind range takes move_base's recovery turn to where it can
drive as well (navigation.move_base, local_planner.heading_to_leave).

**Look-around** (``look_around``, off by default): at the start and on reaching each frontier goal (or coming
within ``LOOK_REACH`` of one whose frontier the scan has seen past) the robot turns in place a full circle,
unless it looked around within ``look_around_spacing`` m already: ``LOOK_STEPS`` move_base goals at its own
position, each a third of a turn on (always the same way round), before the next frontier goal. A narrow scan
(a depth camera's 58 degrees) then sees structure in every direction from each stop, as a TurtleBot exploring
with its depth camera does. Measured on fresh runs (docs/mapping.md), the map's scores varied more from seed
to seed than with the turns, and in 300 s less was explored: so it is off unless asked for. A look-around goal
move_base does not reach ends the look-around (no blacklist: the spot was reached).

The robot's pose is localization's (``map -> odom`` on /tf composed with odometry), never the truth.
"""
from __future__ import annotations

import heapq
import math
from collections import deque
from dataclasses import dataclass

import genpy
import numba
import numpy as np
from geometry_msgs.msg import Point, PointStamped, PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry
from scipy.ndimage import binary_dilation, distance_transform_edt, label
from std_msgs.msg import Bool, Header
from tf2_msgs.msg import TFMessage

from subsumption import Input, Module, Output, Param
from subsumption.actions import ActionClient, ClientGoal, GoalStatus
from subsumption.mapfile import OCCUPIED, UNKNOWN, OccupancyMap

from .grid_messages import GridMessageError, grid_of
from subsumption.planar import compose, from_pose_msg, pose_msg, yaw_of

EIGHT = np.ones((3, 3), dtype=bool)
LOOK_REACH = 1.0  # m: a goal whose frontier vanished with the robot this near counts as reached (look around)
LOOK_STEPS = 3  # move_base goals per look-around turn: a third of a turn each, so the shorter way is always on
TRAIL_STEP = 0.1  # m between the kept poses of the robot's own path (the way back when it is stuck)
TRAIL_KEEP = 2000  # of them at most (200 m): the way back is never more than a few metres


@numba.njit(cache=True)
def _travel(passable: np.ndarray, start_r: int, start_c: int) -> np.ndarray:
    """Dijkstra on the 8-connected grid of `passable` cells from (start_r, start_c): metres in cells (inf where
    unreachable)."""
    rows, cols = passable.shape
    dist = np.full((rows, cols), np.inf)
    dist[start_r, start_c] = 0.0
    heap = [(0.0, start_r, start_c)]
    sq2 = math.sqrt(2.0)
    while len(heap) > 0:
        d, r, c = heapq.heappop(heap)
        if d > dist[r, c]:
            continue
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                if dr == 0 and dc == 0:
                    continue
                nr, nc = r + dr, c + dc
                if nr < 0 or nr >= rows or nc < 0 or nc >= cols or not passable[nr, nc]:
                    continue
                nd = d + (sq2 if dr != 0 and dc != 0 else 1.0)
                if nd < dist[nr, nc]:
                    dist[nr, nc] = nd
                    heapq.heappush(heap, (nd, nr, nc))
    return dist


@dataclass(frozen=True)
class FrontierParams:
    robot_radius: float = 0.18  # m: cells closer than this to a wall cannot hold the robot's centre
    goal_clearance: float = 0.17  # m beyond the radius a goal keeps from walls: more than move_base's local
    # planner keeps from what the scan sees (footprint_padding + dynamic_padding: a wall just seen is not on
    # the map yet), or the robot cannot get onto the goal
    min_frontier_size: float = 0.3  # m: shorter frontiers are noise
    potential_scale: float = 1.0  # cost per m of travel to a frontier
    gain_scale: float = 0.5  # benefit per m of frontier length


@dataclass(eq=False)
class Frontier:
    cells: np.ndarray  # (n, 2) rows, cols: the frontier's cells
    size_m: float  # its length: cells times the resolution
    goal_cell: tuple[int, int]  # the reachable cell of it the robot gets to first
    distance_m: float  # travel from the robot to goal_cell
    goal: np.ndarray  # (x, y, yaw) metres in the map frame, facing the unknown
    cost: float


def frontier_cells(grid: OccupancyMap) -> np.ndarray:
    """bool (rows, cols): known-free cells with an unknown 8-neighbour."""
    free = grid.occupancy == 0
    unknown = grid.occupancy == UNKNOWN
    return free & binary_dilation(unknown, structure=EIGHT)


def find_frontiers(grid: OccupancyMap, robot_xy: tuple[float, float], params: FrontierParams = FrontierParams(),
                   blacklist: list[tuple[float, float, float]] = ()) -> list[Frontier]:
    """The reachable frontiers of `grid` seen from a robot at `robot_xy`, cheapest first. `blacklist`: (x, y,
    radius) discs no goal may lie in."""
    occupied = grid.occupancy == OCCUPIED
    if occupied.any():
        wall_distance = distance_transform_edt(~occupied) * grid.resolution
    else:
        wall_distance = np.full(grid.shape, np.inf)
    free = grid.occupancy == 0
    passable = free & (wall_distance > params.robot_radius)
    row, col = grid.cell_of(*robot_xy)
    rows, cols = grid.shape
    if not (0 <= row < rows and 0 <= col < cols):
        return []
    # a robot standing in the inflation of a wall (or on a cell the map has not marked free yet) is let out
    window = (slice(max(row - 4, 0), row + 5), slice(max(col - 4, 0), col + 5))
    passable[window] |= ~occupied[window] & (wall_distance[window] > 0.5 * params.robot_radius)
    passable[row, col] = True
    travel = _travel(passable, row, col) * grid.resolution
    edge = frontier_cells(grid)
    labels, count = label(edge, structure=EIGHT)
    if count == 0:
        return []
    can_stand = passable & (wall_distance > params.robot_radius + params.goal_clearance) & np.isfinite(travel)
    for x, y, radius in blacklist:
        br, bc = grid.cell_of(x, y)
        reach = int(math.ceil(radius / grid.resolution))
        rr, cc = np.ogrid[max(br - reach, 0): br + reach + 1, max(bc - reach, 0): bc + reach + 1]
        disc = (rr - br) ** 2 + (cc - bc) ** 2 <= reach * reach
        can_stand[max(br - reach, 0): br + reach + 1, max(bc - reach, 0): bc + reach + 1] &= ~disc
    unknown = grid.occupancy == UNKNOWN
    found = []
    edge_rows, edge_cols = np.nonzero(edge)
    edge_labels = labels[edge_rows, edge_cols]
    order = np.argsort(edge_labels, kind="stable")
    edge_rows, edge_cols, edge_labels = edge_rows[order], edge_cols[order], edge_labels[order]
    bounds = np.searchsorted(edge_labels, np.arange(1, count + 2))
    for k in range(count):
        r_k, c_k = edge_rows[bounds[k]:bounds[k + 1]], edge_cols[bounds[k]:bounds[k + 1]]
        size = len(r_k) * grid.resolution
        if size < params.min_frontier_size:
            continue
        ok = can_stand[r_k, c_k]
        if not ok.any():
            continue
        d = travel[r_k[ok], c_k[ok]]
        i = int(np.argmin(d))
        goal_cell = (int(r_k[ok][i]), int(c_k[ok][i]))
        x, y = grid.centre_of(*goal_cell)
        yaw = _facing_unknown(unknown, goal_cell, grid, robot_xy)
        cost = params.potential_scale * float(d[i]) - params.gain_scale * size
        found.append(Frontier(np.column_stack((r_k, c_k)), size, goal_cell, float(d[i]),
                              np.array([x, y, yaw]), cost))
    found.sort(key=lambda f: f.cost)
    return found


def goal_clear(grid: OccupancyMap, xy: tuple[float, float], clearance: float) -> bool:
    """Whether the cell at `xy` is more than `clearance` m (centre to centre, as find_frontiers measures) from
    every occupied cell of `grid`: a goal chosen on an older map may not be any more."""
    row, col = grid.cell_of(*xy)
    cells = int(math.ceil(clearance / grid.resolution))
    r0, c0 = max(row - cells, 0), max(col - cells, 0)
    rows, cols = np.nonzero(grid.occupancy[r0: max(row + cells + 1, 0), c0: max(col + cells + 1, 0)] == OCCUPIED)
    if not len(rows):
        return True
    return bool(np.hypot(rows + r0 - row, cols + c0 - col).min() * grid.resolution > clearance)


def _facing_unknown(unknown: np.ndarray, cell: tuple[int, int], grid: OccupancyMap,
                    robot_xy: tuple[float, float]) -> float:
    """The heading from `cell` towards the mean of the unknown cells within 0.5 m (from the robot towards the
    cell when none is there)."""
    r, c = cell
    reach = max(2, int(round(0.5 / grid.resolution)))
    r0, c0 = max(r - reach, 0), max(c - reach, 0)
    ur, uc = np.nonzero(unknown[r0: r + reach + 1, c0: c + reach + 1])
    if len(ur):
        return math.atan2(float(np.mean(ur + r0 - r)), float(np.mean(uc + c0 - c)))
    x, y = grid.centre_of(r, c)
    return math.atan2(y - robot_xy[1], x - robot_xy[0])


class Explore(Module):
    """Frontier exploration: sends move_base goals at the nearest worthwhile edge of the known map until no
    reachable frontier is left, then says so on ``~done``."""

    map = Input(OccupancyGrid, "the map being built (SLAM's)")
    odom = Input(Odometry, "odometry: the robot's pose in the odom frame")
    done = Output(Bool, "true once no reachable frontier is left", latch=True)
    goal_pose = Output(PoseStamped, "the frontier goal being driven to (for rviz)", name="goal")
    gave_up_at = Output(PointStamped, "where the robot stood stuck when exploration gave up (stamped with when it "
                                      "last moved); never published while exploring", name="gave_up", latch=True)

    planner_frequency = Param(1.0, "Hz: how often frontiers are computed again", min=0.05)
    progress_timeout = Param(30.0, "s without getting progress_distance closer to the goal before it is "
                                   "blacklisted", min=1.0)
    progress_distance = Param(0.3, "m of progress that resets progress_timeout", min=0.0)
    min_frontier_size = Param(0.3, "m: shorter frontiers are ignored", min=0.0)
    potential_scale = Param(1.0, "cost per m of travel to a frontier", min=0.0)
    gain_scale = Param(0.5, "benefit per m of frontier length", min=0.0)
    robot_radius = Param(0.18, "m: the round footprint (as move_base's)", min=0.01)
    goal_clearance = Param(0.17, "m beyond the radius a goal keeps from walls (more than move_base's "
                                 "footprint_padding + dynamic_padding)", min=0.0)
    blacklist_radius = Param(0.5, "m around a failed goal where no goal is sent again", min=0.0)
    done_delay = Param(8.0, "s the map must show no reachable frontier before exploration is done (longer than "
                            "the map's update interval, so the last scans are in it)", min=0.0)
    look_around = Param(False, "turn in place a full circle at the start and on reaching each frontier goal "
                              "(so that a narrow scan sees every direction)")
    look_around_spacing = Param(2.0, "m: no look-around this close to an earlier one", min=0.0)
    stuck_distance = Param(0.3, "m the robot must move during a goal for its failure to count against the "
                                "frontier (less: the robot did not move, see stuck_goals)", min=0.0)
    stuck_goals = Param(3, "goals failed in a row without the robot moving stuck_distance that make it stuck: "
                           "they are not blacklisted, and exploration is not done while it stays", min=1)
    stuck_timeout = Param(180.0, "s stuck (not moved stuck_distance) before exploration gives up, not done "
                                 "(0: never)", min=0.0)
    escape_distance = Param(1.0, "m back along the robot's own path a goal goes to after a frontier goal failed "
                                 "without the robot moving (further back for each such failure in a row; 0: no "
                                 "such goal)", min=0.0)
    global_frame = Param("map", "frame of the map")
    move_base = Param("move_base", "the move_base action to send goals to")

    def setup(self) -> None:
        self.grid: OccupancyMap | None = None
        self.map_to_odom: np.ndarray | None = None
        self.odom_frame = ""
        self.odom_pose: np.ndarray | None = None
        self.client = ActionClient(self.node, self.move_base, MoveBaseAction)
        self.active: ClientGoal | None = None
        self.target: np.ndarray | None = None
        self.best_distance = math.inf
        self.progress_at = 0.0
        self.blacklist: list[tuple[float, float, float]] = []
        self.empty_since: float | None = None  # when the frontiers were first found empty
        self.finished = False
        self.goals_sent = 0
        self.look_headings: list[float] = []  # the look-around's headings still to turn to (map frame)
        self.looking: ClientGoal | None = None  # its move_base goal under way
        self.look_spots: list[tuple[float, float]] = []  # where the robot looked around (the first: the start)
        self.sent_at = 0.0  # when the frontier goal under way was sent
        self.moved_from: np.ndarray | None = None  # where the robot last stood after moving stuck_distance ...
        self.moved_at = 0.0  # ... and when
        self.still_failures: list[tuple[float, float, float]] = []  # blacklisted in a row without moving
        self.stuck_at: np.ndarray | None = None  # (x, y) while the robot is stuck (None: it is not)
        self.gave_up = False  # stuck for stuck_timeout s: exploration ended, not done
        self.trail: deque[tuple[float, float]] = deque(maxlen=TRAIL_KEEP)  # its own path, map frame, per TRAIL_STEP m
        self.escaping: ClientGoal | None = None  # the goal back along it under way
        self.escapes = 0  # such goals sent since the robot last moved stuck_distance
        _travel(np.ones((2, 2), dtype=bool), 0, 0)  # compiled (or loaded from numba's cache) now, not at the
        # first map, while a simulation may already be running on the ROS clock
        self.node.subscribe("/tf", TFMessage, self._on_tf)
        self.done.publish(Bool(False))
        self.every(1.0 / self.planner_frequency, self._tick)

    def on_reconfigure(self, changed: dict) -> None:
        """Thresholds are read per use; exploration's state (blacklist, goal) is kept."""

    def on_map(self, msg: OccupancyGrid) -> None:
        """Take SLAM's latest map (a malformed grid is logged and ignored)."""
        try:
            self.grid = grid_of(msg, self.node.resolve("map"))
        except GridMessageError as error:
            self.log(f"map ignored: {error}", "error")

    def on_odom(self, msg: Odometry) -> None:
        """Keep the latest odometry pose and its frame."""
        self.odom_pose = from_pose_msg(msg.pose.pose)
        self.odom_frame = msg.header.frame_id.lstrip("/")
        pose = self.pose()
        if pose is not None:
            self._keep_trail(pose)

    def _on_tf(self, msg: TFMessage) -> None:
        for t in msg.transforms:
            if t.header.frame_id.lstrip("/") == self.global_frame and self.odom_frame and \
                    t.child_frame_id.lstrip("/") == self.odom_frame:
                tr = t.transform
                self.map_to_odom = np.array([tr.translation.x, tr.translation.y, yaw_of(tr.rotation)])

    def pose(self) -> np.ndarray | None:
        """The robot's pose in the map frame (map -> odom composed with odometry), or None until both are known."""
        if self.map_to_odom is None or self.odom_pose is None:
            return None
        return compose(self.map_to_odom, self.odom_pose)

    def _frontier_params(self) -> FrontierParams:
        return FrontierParams(self.robot_radius, self.goal_clearance, self.min_frontier_size, self.potential_scale,
                              self.gain_scale)

    def _tick(self) -> None:
        if self.finished or self.gave_up or self.grid is None or not self.client.server_seen:
            return
        pose = self.pose()
        if pose is None:
            return
        if self._watch_stuck(pose):
            return
        if self.escaping is not None:
            return  # going back the way it came; the next frontier is chosen from where that ends
        if self.looking is not None:
            return  # turning round; the next frontier is chosen on the map the turn adds to
        if self.look_around and not self.look_spots:
            self._start_look_around(pose, "at the start")
            return
        now = self.now()
        frontiers = find_frontiers(self.grid, (pose[0], pose[1]), self._frontier_params(), self.blacklist)
        if self.active is not None and self.target is not None:
            same = [f for f in frontiers if math.hypot(*(f.goal[:2] - self.target[:2])) <= self.blacklist_radius]
            if same and not self._target_clear():
                # what the scan has seen since put something (a box's corner) near the goal: its frontier has a
                # goal elsewhere now, and move_base would drive right up to the old one (generated_31 seed 1 at
                # 59 s: a goal 0.2 m from a box that was unknown when it was chosen, touched)
                self.log(f"the frontier goal at ({self.target[0]:.2f}, {self.target[1]:.2f}) is now within "
                         f"{self.robot_radius + self.goal_clearance:.2f} m of an obstacle: replaced")
                same = []
            if same:  # the goal is still on a frontier the robot can stand at: keep driving there
                distance = min(f.distance_m for f in same)  # by the way there, not as the crow flies
                if distance < self.best_distance - self.progress_distance:
                    self.best_distance, self.progress_at = distance, now
                    return
                if now - self.progress_at <= self.progress_timeout:
                    return
                self._failed(f"no progress towards the frontier at ({self.target[0]:.2f}, {self.target[1]:.2f}) "
                             f"in {self.progress_timeout:g} s")
                if self.escaping is not None:
                    return
                frontiers = find_frontiers(self.grid, (pose[0], pose[1]), self._frontier_params(), self.blacklist)
            elif math.hypot(*(self.target[:2] - pose[:2])) <= LOOK_REACH and self._look_around_here(pose):
                # its frontier was seen past as the robot came near: the goal is as good as reached
                self.active, self.target = None, None  # the look-around's first goal preempts it at move_base
                self._start_look_around(pose, "near the frontier goal (its frontier seen)")
                return
        if not frontiers:
            if self.active is not None and self.target is not None and not self._target_clear():
                self.log(f"the frontier goal at ({self.target[0]:.2f}, {self.target[1]:.2f}) is now within "
                         f"{self.robot_radius + self.goal_clearance:.2f} m of an obstacle: given up", "warn")
                self._blacklist_current()
                return
            if self.active is not None:
                return  # let the last goal finish; its scans may open new frontiers
            if len(self.still_failures) >= min(2, self.stuck_goals):
                # the last frontiers, more than one, were blacklisted while the robot did not move: it is stuck,
                # they are not unreachable (office seed 1 reported the map complete so)
                self._become_stuck()
                return
            if self.empty_since is None:
                self.empty_since = now
            elif now - self.empty_since >= self.done_delay:
                self.finished = True
                self.log(f"exploration done: no reachable frontier left ({self.goals_sent} goals sent)")
                self.done.publish(Bool(True))
            return
        self.empty_since = None
        best = frontiers[0]
        self.log(f"frontier goal ({best.goal[0]:.2f}, {best.goal[1]:.2f}): {best.size_m:.1f} m of frontier, "
                 f"{best.distance_m:.1f} m away; {len(frontiers)} reachable frontiers")
        self._send(best.goal)

    def _target_clear(self) -> bool:
        """Whether the goal under way still keeps robot_radius + goal_clearance from every occupied cell of the
        latest map (as a new goal must)."""
        return goal_clear(self.grid, (float(self.target[0]), float(self.target[1])),
                          self.robot_radius + self.goal_clearance)

    def _send(self, goal: np.ndarray) -> None:
        msg = MoveBaseGoal()
        msg.target_pose.header = Header(0, genpy.Time.from_sec(max(self.now(), 0.0)), self.global_frame)
        msg.target_pose.pose = pose_msg(goal)
        self.target = goal
        self.best_distance, self.progress_at = math.inf, self.now()
        self.sent_at = self.now()
        self.goals_sent += 1
        self.active = self.client.send_goal(msg, done=self._on_done)
        self.goal_pose.publish(msg.target_pose)

    def _look_around_here(self, pose: np.ndarray) -> bool:
        """Whether to look around at `pose`: on, and no look-around yet within ``look_around_spacing``."""
        return bool(self.look_around) and all(math.hypot(pose[0] - x, pose[1] - y) > self.look_around_spacing
                                              for x, y in self.look_spots)

    def _start_look_around(self, pose: np.ndarray, where: str) -> None:
        self.look_spots.append((float(pose[0]), float(pose[1])))
        step = 2.0 * math.pi / LOOK_STEPS
        self.look_headings = [float(pose[2] + k * step) for k in range(1, LOOK_STEPS + 1)]
        self.log(f"look-around {where}: turning a full circle at ({pose[0]:.2f}, {pose[1]:.2f})")
        self._next_look()

    def _next_look(self) -> None:
        """Sends the look-around's next heading as a move_base goal at the robot's position now (the estimate
        may have moved while it turned), or ends the look-around."""
        pose = self.pose()
        if not self.look_headings or pose is None:
            self.look_headings, self.looking = [], None
            return
        msg = MoveBaseGoal()
        msg.target_pose.header = Header(0, genpy.Time.from_sec(max(self.now(), 0.0)), self.global_frame)
        msg.target_pose.pose = pose_msg(np.array([pose[0], pose[1], self.look_headings.pop(0)]))
        self.looking = self.client.send_goal(msg, done=self._on_look_done)

    def _on_look_done(self, handle: ClientGoal) -> None:
        if handle is not self.looking:
            return
        if handle.status != GoalStatus.SUCCEEDED:
            self.log(f"look-around ended early ({handle.text})", "warn")
            self.look_headings, self.looking = [], None
            return
        self._next_look()

    def _blacklist_current(self) -> None:
        if self.target is not None:
            self.blacklist.append((float(self.target[0]), float(self.target[1]), float(self.blacklist_radius)))
        if self.active is not None:
            self.active.cancel()
        self.active, self.target = None, None

    def _on_done(self, handle: ClientGoal) -> None:
        if handle is not self.active:
            return  # an older goal, preempted by a newer one
        if handle.status == GoalStatus.ABORTED:
            if handle.text.startswith("stuck"):  # move_base's recoveries left the robot where it was
                self._failed(f"frontier goal aborted ({handle.text})")
            else:  # the goal itself (in a wall now, no path to it): whether the robot moved or not
                self.log(f"frontier goal aborted ({handle.text}): blacklisted", "warn")
                self._blacklist_current()
            return
        self.still_failures = []  # reached or replaced: the robot is not stuck
        if handle.status == GoalStatus.SUCCEEDED and self.target is not None:
            # the robot stood there facing the unknown: what it could see from there it saw, so that spot is
            # not a goal again (other parts of the same frontier still are)
            self.blacklist.append((float(self.target[0]), float(self.target[1]), 0.5 * float(self.blacklist_radius)))
            self.active, self.target = None, None
            pose = self.pose()
            if pose is not None and self._look_around_here(pose):
                self._start_look_around(pose, "at the frontier goal")
            return
        self.active, self.target = None, None

    # Stuck --------------------------------------------------------------------------------------------
    def _watch_stuck(self, pose: np.ndarray) -> bool:
        """Keeps where and when the robot last moved stuck_distance; ends being stuck once it has, and gives up
        after stuck_timeout s stuck. True when exploration has given up."""
        now = self.now()
        if self.moved_from is None or math.hypot(*(pose[:2] - self.moved_from)) > self.stuck_distance:
            if self.stuck_at is not None:
                self.log(f"the robot moved from ({self.stuck_at[0]:.2f}, {self.stuck_at[1]:.2f}) again after "
                         f"{now - self.moved_at:.0f} s: exploring on")
            self.moved_from, self.moved_at = pose[:2].copy(), now
            self.stuck_at, self.still_failures = None, []
            if self.escaping is None:
                self.escapes = 0
            return False
        if self.stuck_at is not None and self.stuck_timeout > 0 and now - self.moved_at >= self.stuck_timeout:
            self.gave_up = True
            self.log(f"exploration given up, not done: the robot has been stuck at ({self.stuck_at[0]:.2f}, "
                     f"{self.stuck_at[1]:.2f}) for {now - self.moved_at:.0f} s", "error")
            for goal in (self.active, self.escaping):
                if goal is not None:
                    goal.cancel()
            self.active, self.target, self.escaping = None, None, None
            self.gave_up_at.publish(PointStamped(
                header=Header(stamp=genpy.Time.from_sec(self.moved_at), frame_id=self.global_frame),
                point=Point(x=float(self.stuck_at[0]), y=float(self.stuck_at[1]))))
            return True
        return False

    def _failed(self, why: str) -> None:
        """A frontier goal failed for want of progress: blacklisted if the robot moved during it; if not, counted
        (stuck_goals in a row make the robot stuck) and, once stuck, not blacklisted: the goal is sent again."""
        moved = self.moved_at > self.sent_at
        if self.stuck_at is not None:
            self.log(f"{why}, with the robot stuck at ({self.stuck_at[0]:.2f}, {self.stuck_at[1]:.2f}) for "
                     f"{self.now() - self.moved_at:.0f} s: not blacklisted, tried again", "warn")
            if self.active is not None:
                self.active.cancel()
            self.active, self.target = None, None
            self._escape()
            return
        self.log(f"{why}: blacklisted" + ("" if moved else " (the robot did not move meanwhile)"), "warn")
        entry = self.target
        self._blacklist_current()
        if moved:
            self.still_failures = []
            return
        if entry is not None:
            self.still_failures.append(self.blacklist[-1])
        if len(self.still_failures) >= self.stuck_goals:
            self._become_stuck()
        self._escape()

    # Back the way it came --------------------------------------------------------------------------
    def _keep_trail(self, pose: np.ndarray) -> None:
        """Adds the robot's position to its path once it is TRAIL_STEP m from the last one kept."""
        if not self.trail or math.hypot(pose[0] - self.trail[-1][0], pose[1] - self.trail[-1][1]) >= TRAIL_STEP:
            self.trail.append((float(pose[0]), float(pose[1])))

    def way_back(self, pose: np.ndarray, distance: float) -> np.ndarray | None:
        """The point of the robot's own path `distance` m of travel back from where it stands (x, y, and the yaw
        from the robot to it), on free ground of the latest map with the robot's radius clear of its walls and at
        least stuck_distance from the robot; the nearest such point further back when that one is not; None when
        the path has none (the robot has not driven)."""
        travelled = 0.0
        here = (float(pose[0]), float(pose[1]))
        for x, y in reversed(self.trail):
            travelled += math.hypot(x - here[0], y - here[1])
            here = (x, y)
            if travelled < distance or math.hypot(x - pose[0], y - pose[1]) <= self.stuck_distance:
                continue
            row, col = self.grid.cell_of(x, y)
            rows, cols = self.grid.shape
            if not (0 <= row < rows and 0 <= col < cols) or self.grid.occupancy[row, col] != 0:
                continue
            if goal_clear(self.grid, (x, y), self.robot_radius):
                return np.array([x, y, math.atan2(y - pose[1], x - pose[0])])
        return None

    def _escape(self) -> None:
        """After a frontier goal failed with the robot not moved: a goal back along its own path, one
        escape_distance further for each such goal since it last moved (none without a path or escape_distance)."""
        pose = self.pose()
        if self.escape_distance <= 0 or pose is None or self.grid is None:
            return
        point = self.way_back(pose, self.escape_distance * (self.escapes + 1))
        if point is None:
            return
        self.escapes += 1
        self.log(f"back the way it came: goal ({point[0]:.2f}, {point[1]:.2f}), "
                 f"{self.escape_distance * self.escapes:g} m back along its own path")
        msg = MoveBaseGoal()
        msg.target_pose.header = Header(0, genpy.Time.from_sec(max(self.now(), 0.0)), self.global_frame)
        msg.target_pose.pose = pose_msg(point)
        self.escaping = self.client.send_goal(msg, done=self._on_escape_done)
        self.goal_pose.publish(msg.target_pose)

    def _on_escape_done(self, handle: ClientGoal) -> None:
        if handle is not self.escaping:
            return
        self.escaping = None
        if handle.status != GoalStatus.SUCCEEDED:
            self.log(f"the way back ended short ({handle.text})", "warn")

    def _become_stuck(self) -> None:
        """The goals that failed while the robot did not move leave the blacklist: the robot is stuck."""
        for entry in self.still_failures:
            if entry in self.blacklist:
                self.blacklist.remove(entry)
        pose = self.pose()  # moved_from is set by _watch_stuck before any goal; the pose now if it was not
        self.stuck_at = (self.moved_from if self.moved_from is not None else pose[:2]).copy()
        self.log(f"the robot has not moved from ({self.stuck_at[0]:.2f}, {self.stuck_at[1]:.2f}) for "
                 f"{self.now() - self.moved_at:.0f} s through {len(self.still_failures)} frontier goals: it is stuck, "
                 f"they are not unreachable (taken off the blacklist; exploration is not done while it stays)",
                 "warn")
        self.still_failures = []
        self.empty_since = None
