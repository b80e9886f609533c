"""Level 2, explore: when the robot is not busy, look for a distant open place and head there.

whenlook -> startlook -> {look, I 75 on wander's heading}; look (laser) -> travel -> pathplan -> heading (S 15 at
avoid, in place of wander's) and busy -> whenlook; integrate (odometry) -> integral -> {look, pathplan}.
"""
from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PointStamped, Pose2D
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, Empty, Float64

from subsumption import AFSM, ConditionalDispatch, EventDispatch, Input, Module, Output, OutputState, Param
from subsumption.planar import wrap, yaw_of


class Integrate(Module):
    """Integrates the robot's motion (odometry) into its pose in the odometry frame, for look and pathplan."""

    odom = Input(Odometry)
    integral = Output(Pose2D, "x, y (m) and theta (rad) in the odometry frame")

    def on_odom(self, msg: Odometry) -> None:
        pose = msg.pose.pose
        self.integral.publish(Pose2D(x=pose.position.x, y=pose.position.y, theta=yaw_of(pose.orientation)))


class Whenlook(AFSM):
    """Every `idle` seconds, starts a look unless pathplan says the robot is busy travelling; after a look it
    gives look and pathplan `cooldown` seconds before it checks again.

    A look that pathplan never takes up (no busy after it) means a part of level 2 is gone: look, pathplan or
    integrate died. After `misses` such looks in a row whenlook backs off, starting a look only every `retry`
    seconds, doubling up to `max_retry`: each look inhibits wander's heading (I 75), and without the back-off a
    dead look would hold wander down for good and stop the robot. Level 1 wanders on meanwhile, and level 2
    takes over again by itself when the dead part comes back (a respawned node): its first answer ends the
    back-off."""

    busy = Input(Bool, "pathplan: travelling to a place")
    startlook = Output(Empty)
    idle = Param(0.5, "s between checks")
    cooldown = Param(1.0, "s after a look before the next check")
    misses = Param(3, "looks in a row that pathplan did not take up before whenlook backs off", min=1)
    retry = Param(10.0, "s between looks once backing off (doubles each unanswered look)", min=0.0)
    max_retry = Param(160.0, "s: the longest wait between looks while backing off", min=0.0)

    states = [
        EventDispatch("wait", timeout="idle", on_timeout="check"),
        ConditionalDispatch("check", "holds_off", then="wait", otherwise="look"),
        OutputState("look", "startlook", "start_message", next="cooldown"),
        EventDispatch("cooldown", timeout="cooldown", on_timeout="wait"),
    ]

    def setup(self) -> None:
        self._pending = False      # a look was started and pathplan has not said busy since
        self._missed = 0           # unanswered looks in a row
        self._last_look = -math.inf

    def on_busy(self, msg: Bool) -> None:
        if msg.data:
            if self._missed >= self.misses:
                self.log(f"level 2 answers again after {self._missed} unanswered looks: looking as usual")
            self._pending, self._missed = False, 0

    def is_busy(self) -> bool:
        return bool(self.registers.busy and self.registers.busy.data)

    def holds_off(self) -> bool:
        """Busy travelling, or backing off because the last looks went unanswered."""
        if self._pending:
            self._pending = False
            self._missed += 1
            if self._missed == self.misses:
                self.log(f"{self._missed} looks in a row not taken up by pathplan (look, pathplan or integrate "
                         f"gone?): backing off, wander leads", "warn")
        if self._missed >= self.misses:
            wait = min(self.retry * 2.0 ** (self._missed - self.misses), self.max_retry)
            if self.now() - self._last_look < wait:
                return True
        return self.is_busy()

    def start_message(self) -> Empty:
        self._pending, self._last_look = True, self.now()
        return Empty()


class Look(Module):
    """On startlook, picks the most open reachable direction in the laser scan and sends the place to travel to
    (in the odometry frame). A direction is reachable as far as a corridor of the robot's width is free. Among
    the reachable directions it prefers the one whose way crosses the most ground the robot has not been near
    yet (a coarse grid of where it has been, fed by integrate), then the farther, then the less turning; and if
    the robot has hardly moved since the last look, not the way to the last place (see `blocked`). With nothing
    new in view (a room it has covered), it goes back along its own path, to the earliest point of it in view
    (see `way_back`): out by the doorway it came in, to where new ground shows again."""

    startlook = Input(Empty)
    scan = Input(LaserScan)
    integral = Input(Pose2D)
    travel = Output(PointStamped, "the place to go to, odometry frame")
    width = Param(0.6, "m: corridor width that must be free (robot diameter plus margin)")
    margin = Param(1.0, "m kept short of the first obstacle")
    max_travel = Param(8.0, "m: furthest place sent")
    min_travel = Param(1.0, "m: nearer than this is not worth going to")
    cell = Param(0.5, "m: side of a cell of the memory of where the robot has been")
    near = Param(1.0, "m: ground this close to the robot's path counts as been")
    reach_weight = Param(0.25, "score per metre of free way, against one metre of new ground")
    turn_weight = Param(1.0, "score lost per radian the robot must turn to face the place")
    min_new = Param(1.0, "m of new ground in view below which the robot goes back along its path (or turns round)")
    stuck = Param(0.5, "m: moved less than this since the last look means the last place was out of reach")
    blocked_angle = Param(0.5, "rad either side of an out-of-reach place's direction not chosen again")
    crumb = Param(0.5, "m between the remembered points of the robot's own path (its way back)")
    frame_id = Param("odom", "frame of the travel point")

    MEMORY_CELLS = 512  # the memory spans MEMORY_CELLS * cell metres, centred on where the robot started

    def setup(self) -> None:
        self._been = np.zeros((self.MEMORY_CELLS, self.MEMORY_CELLS), dtype=bool)
        self._last_look: tuple[float, float, float, float] | None = None  # robot x, y and place x, y
        self._pairs_key: tuple[float, float, int] | None = None  # the scan geometry _pairs was computed for
        self._pairs: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 0)), np.zeros((0, 0)))
        self._crumbs: list[tuple[float, float]] = []  # the robot's path, a point every `crumb` metres
        r = int(math.ceil(self.near / self.cell))
        dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
        self._disc = [(int(i), int(j)) for i, j in zip(dy.ravel(), dx.ravel())
                      if math.hypot(i, j) * self.cell <= self.near]

    def _index(self, x: np.ndarray | float, y: np.ndarray | float):
        half = self.MEMORY_CELLS // 2
        return (np.floor(np.asarray(y) / self.cell).astype(int) + half,
                np.floor(np.asarray(x) / self.cell).astype(int) + half)

    def on_integral(self, pose: Pose2D) -> None:
        if not self._crumbs or math.hypot(pose.x - self._crumbs[-1][0], pose.y - self._crumbs[-1][1]) >= self.crumb:
            self._crumbs.append((pose.x, pose.y))
        row, col = self._index(pose.x, pose.y)
        for dr, dc in self._disc:
            if 0 <= row + dr < self.MEMORY_CELLS and 0 <= col + dc < self.MEMORY_CELLS:
                self._been[row + dr, col + dc] = True

    def on_startlook(self, msg: Empty) -> None:
        scan, pose = self.registers.scan, self.registers.integral
        if scan is None or pose is None:
            return
        point = PointStamped()
        point.header.stamp = scan.header.stamp
        point.header.frame_id = self.frame_id
        point.point.x, point.point.y = self.choose(scan, pose)
        self._last_look = (pose.x, pose.y, point.point.x, point.point.y)
        self.travel.publish(point)

    def reachable(self, scan: LaserScan) -> tuple[np.ndarray, np.ndarray]:
        """(angles, free distance) per beam: how far a corridor `width` wide along the beam is clear."""
        ranges = np.asarray(scan.ranges, dtype=float)
        ranges = np.where(np.isfinite(ranges), ranges, np.where(ranges > 0, scan.range_max, 0.0))
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
        # Beam j blocks the corridor along beam i if its hit point lies within width/2 of the line of beam i,
        # in front of the robot: lateral offset r_j*sin(a_j-a_i) < width/2 and along-distance r_j*cos(...) > 0.
        cos_delta, sin_delta = self._beam_pairs(scan.angle_min, scan.angle_increment, len(ranges))
        along = ranges[None, :] * cos_delta
        blocks = (ranges[None, :] * sin_delta < self.width / 2) & (along > 0)
        free = np.where(blocks, along, scan.range_max).min(axis=1)
        return angles, free

    def _beam_pairs(self, angle_min: float, increment: float, count: int) -> tuple[np.ndarray, np.ndarray]:
        """cos and |sin| of the angle between every two beams, computed once per scan geometry: the trigonometry
        of a 541-beam scan's 290,000 pairs was most of a look's time."""
        key = (angle_min, increment, count)
        if self._pairs_key != key:
            angles = angle_min + increment * np.arange(count)
            delta = angles[None, :] - angles[:, None]
            self._pairs_key, self._pairs = key, (np.cos(delta), np.abs(np.sin(delta)))
        return self._pairs

    def new_ground(self, pose: Pose2D, angles: np.ndarray, reach: np.ndarray) -> np.ndarray:
        """Metres of each straight way (beam direction, up to its reach) that pass ground not yet been near."""
        steps = np.arange(self.cell / 2, self.max_travel, self.cell)
        heading = pose.theta + angles
        xs = pose.x + steps[None, :] * np.cos(heading)[:, None]
        ys = pose.y + steps[None, :] * np.sin(heading)[:, None]
        rows, cols = self._index(xs, ys)
        inside = (rows >= 0) & (rows < self.MEMORY_CELLS) & (cols >= 0) & (cols < self.MEMORY_CELLS)
        been = np.zeros_like(inside)
        been[inside] = self._been[rows[inside], cols[inside]]
        on_the_way = steps[None, :] <= reach[:, None]
        return ((~been) & on_the_way).sum(axis=1) * self.cell

    def blocked(self, pose: Pose2D, angles: np.ndarray) -> np.ndarray:
        """Beams towards the place of the last look, if the robot has hardly moved since: pathplan gave up on it
        (the sonars' push and the pull towards it cancel out), so choosing it again would only repeat that."""
        if self._last_look is None:
            return np.zeros(len(angles), dtype=bool)
        x, y, goal_x, goal_y = self._last_look
        if math.hypot(pose.x - x, pose.y - y) >= self.stuck:
            return np.zeros(len(angles), dtype=bool)
        towards = math.atan2(goal_y - pose.y, goal_x - pose.x) - pose.theta
        return np.abs(wrap(angles - towards)) < self.blocked_angle  # wrap works elementwise on arrays

    def choose(self, scan: LaserScan, pose: Pose2D) -> tuple[float, float]:
        angles, free = self.reachable(scan)
        reach = np.minimum(free - self.margin, self.max_travel)
        fresh = self.new_ground(pose, angles, reach)
        value = fresh + self.reach_weight * reach - self.turn_weight * np.abs(angles)
        score = np.where((reach >= self.min_travel) & ~self.blocked(pose, angles), value, -np.inf)
        best = int(np.argmax(score))
        if not np.isfinite(score[best]) or fresh[reach >= self.min_travel].max(initial=0.0) < self.min_new:
            # Nothing new (or nothing reachable) in view: go back the way the robot came, as far back as it can
            # see, which leads out of a room it has covered by the doorway it came in; with no such place in
            # view, turn round, so that the next look sees what the laser cannot see now, behind it.
            back = self.way_back(pose, angles, free)
            if back is not None:
                return back
            return (pose.x - self.min_travel * math.cos(pose.theta), pose.y - self.min_travel * math.sin(pose.theta))
        heading = pose.theta + angles[best]
        return pose.x + reach[best] * math.cos(heading), pose.y + reach[best] * math.sin(heading)


    def way_back(self, pose: Pose2D, angles: np.ndarray, free: np.ndarray) -> tuple[float, float] | None:
        """The earliest point of the robot's own path that it can reach in a straight line from here (in the
        laser's view, a corridor of `width` clear up to it) and that is at least `min_travel` away."""
        if not self._crumbs:
            return None
        crumbs = np.asarray(self._crumbs)
        dx, dy = crumbs[:, 0] - pose.x, crumbs[:, 1] - pose.y
        distance = np.hypot(dx, dy)
        bearing = wrap(np.arctan2(dy, dx) - pose.theta)
        index = np.rint((bearing - angles[0]) / (angles[1] - angles[0])).astype(int)
        seen = (index >= 0) & (index < len(angles))
        clear = np.zeros(len(crumbs), dtype=bool)
        clear[seen] = free[index[seen]] >= distance[seen] + self.width / 2
        candidates = np.flatnonzero(clear & (distance >= self.min_travel) & ~self.blocked(pose, bearing))
        if len(candidates) == 0:
            return None
        x, y = crumbs[candidates[0]]
        return float(x), float(y)


class Pathplan(Module):
    """Heads for the place look chose: sends the relative heading to it at every pose update, and busy while
    travelling; gives up when there, or when it has not got `progress` metres closer for `patience` seconds
    (the place may be out of reach: obstacles push the robot away from it)."""

    travel = Input(PointStamped)
    integral = Input(Pose2D)
    heading = Output(Float64)
    busy = Output(Bool)
    arrive = Param(0.6, "m from the place that counts as there")
    progress = Param(0.3, "m closer that counts as progress")
    patience = Param(4.0, "s allowed without progress")

    def setup(self) -> None:
        self._goal: tuple[float, float] | None = None
        self._best = math.inf
        self._improved_at = 0.0

    def on_travel(self, msg: PointStamped) -> None:
        self._goal = (msg.point.x, msg.point.y)
        self._best = math.inf
        self._improved_at = self.now()

    def on_integral(self, pose: Pose2D) -> None:
        if self._goal is None:
            self.busy.publish(Bool(False))
            return
        dx, dy = self._goal[0] - pose.x, self._goal[1] - pose.y
        distance = math.hypot(dx, dy)
        if distance < self._best - self.progress:
            self._best, self._improved_at = distance, self.now()
        if distance < self.arrive or self.now() - self._improved_at > self.patience:
            self._goal = None
            self.busy.publish(Bool(False))
            return
        self.heading.publish(Float64(wrap(math.atan2(dy, dx) - pose.theta)))
        self.busy.publish(Bool(True))
