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

from .geometry import wrap, yaw_of


class Integrate(Module):
    """Integrates the robot's motion (odometry) into its pose in the odometry frame, for look and pathplan."""

    odom = Input(Odometry)
    integral = Output(Pose2D, "x, y (m) and theta (rad) in the odometry frame")

    def on_odom(self, msg: Odometry) -> None:
        pose = msg.pose.pose
        self.integral.publish(Pose2D(x=pose.position.x, y=pose.position.y, theta=yaw_of(pose.orientation)))


class Whenlook(AFSM):
    """Every `idle` seconds, starts a look unless pathplan says the robot is busy travelling; after a look it
    gives look and pathplan `cooldown` seconds before it checks again."""

    busy = Input(Bool, "pathplan: travelling to a place")
    startlook = Output(Empty)
    idle = Param(0.5, "s between checks")
    cooldown = Param(1.0, "s after a look before the next check")

    states = [
        EventDispatch("wait", timeout="idle", on_timeout="check"),
        ConditionalDispatch("check", "is_busy", then="wait", otherwise="look"),
        OutputState("look", "startlook", "start_message", next="cooldown"),
        EventDispatch("cooldown", timeout="cooldown", on_timeout="wait"),
    ]

    def is_busy(self) -> bool:
        return bool(self.registers.busy and self.registers.busy.data)

    def start_message(self) -> Empty:
        return Empty()


class Look(Module):
    """On startlook, picks the most open reachable direction in the laser scan and sends the place to travel to
    (in the odometry frame). A direction is reachable as far as a corridor of the robot's width is free; among
    them it prefers far places away from where the robot has already been (a coarse memory of its path)."""

    startlook = Input(Empty)
    scan = Input(LaserScan)
    integral = Input(Pose2D)
    travel = Output(PointStamped, "the place to go to, odometry frame")
    width = Param(0.6, "m: corridor width that must be free (robot diameter plus margin)")
    margin = Param(1.0, "m kept short of the first obstacle")
    max_travel = Param(8.0, "m: furthest place sent")
    min_travel = Param(1.0, "m: nearer than this is not worth going to")
    novelty_weight = Param(2.0, "weight of distance-from-visited-places against free distance")
    turn_weight = Param(1.0, "m of score lost per radian the robot must turn to face the place")
    memory_spacing = Param(0.5, "m between remembered path points")
    frame_id = Param("odom", "frame of the travel point")

    def setup(self) -> None:
        self._visited: list[tuple[float, float]] = []

    def on_integral(self, pose: Pose2D) -> None:
        if not self._visited or math.dist(self._visited[-1], (pose.x, pose.y)) >= self.memory_spacing:
            self._visited.append((pose.x, pose.y))

    def on_startlook(self, msg: Empty) -> None:
        scan, pose = self.registers.scan, self.registers.integral
        if scan is None or pose is None:
            return
        point = PointStamped()
        point.header.stamp = scan.header.stamp
        point.header.frame_id = self.frame_id
        point.point.x, point.point.y = self.choose(scan, pose)
        self._visited.append((point.point.x, point.point.y))  # a place chosen once is not new next time
        self.travel.publish(point)

    def reachable(self, scan: LaserScan) -> tuple[np.ndarray, np.ndarray]:
        """(angles, free distance) per beam: how far a corridor `width` wide along the beam is clear."""
        ranges = np.asarray(scan.ranges, dtype=float)
        ranges = np.where(np.isfinite(ranges), ranges, np.where(ranges > 0, scan.range_max, 0.0))
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
        # Beam j blocks the corridor along beam i if its hit point lies within width/2 of the line of beam i,
        # in front of the robot: lateral offset r_j*sin(a_j-a_i) < width/2 and along-distance r_j*cos(...) > 0.
        delta = angles[None, :] - angles[:, None]
        along = ranges[None, :] * np.cos(delta)
        across = np.abs(ranges[None, :] * np.sin(delta))
        blocks = (across < self.width / 2) & (along > 0)
        free = np.where(blocks, along, scan.range_max).min(axis=1)
        return angles, free

    def choose(self, scan: LaserScan, pose: Pose2D) -> tuple[float, float]:
        angles, free = self.reachable(scan)
        reach = np.minimum(free - self.margin, self.max_travel)
        heading = pose.theta + angles
        xs = pose.x + reach * np.cos(heading)
        ys = pose.y + reach * np.sin(heading)
        if self._visited:
            visited = np.asarray(self._visited)
            novelty = np.sqrt(((xs[:, None] - visited[None, :, 0]) ** 2 +
                               (ys[:, None] - visited[None, :, 1]) ** 2).min(axis=1))
        else:
            novelty = np.zeros_like(xs)
        value = reach + self.novelty_weight * novelty - self.turn_weight * np.abs(angles)
        score = np.where(reach >= self.min_travel, value, -np.inf)
        best = int(np.argmax(score))
        if not np.isfinite(score[best]):
            # Nothing reachable in view: go back the way the robot came (the laser cannot see behind it,
            # but it has just been there).
            return (pose.x - self.min_travel * math.cos(pose.theta), pose.y - self.min_travel * math.sin(pose.theta))
        return float(xs[best]), float(ys[best])


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
