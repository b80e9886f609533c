"""The moving bodies of a simulation and what they know about themselves: robots and scripted agents.

Both are circles. A :class:`Robot` follows velocity commands within its limits and keeps an odometry
estimate; an :class:`Agent` follows its script (waypoints or wandering). Neither knows about the map or the
others: :class:`~subsim.sim.Simulation` moves them and settles contacts, which keeps this module free of
geometry and easy to read.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from subsumption.planar import wrap

from .world import AgentSpec, RobotSpec


SIDESTEP = math.radians(90.0)  # a walker blocked by another agent turns its step this far (right, then left)
LANE_LOOKAHEAD = 0.5  # m along its lane ahead of where it is that a walker off its lane (after a sidestep) aims at
PATIENCE = 2.0  # s a walker waits for a robot (or a walker it cannot pass) in its way before it gives way
GIVE_WAY = 2.5  # m at most a walker giving way walks back along its lane (to the leg's start: the corridor)
GIVE_WAY_PAUSE = 4.0  # s it then stands aside before it walks on (time for the other to come through)


def arc(x: float, y: float, th: float, ds: float, dth: float) -> tuple[float, float, float]:
    """Pose after moving `ds` along an arc that turns by `dth` (exact for constant v and w)."""
    if abs(dth) < 1e-9:
        return x + ds * math.cos(th), y + ds * math.sin(th), th
    radius = ds / dth
    return (x + radius * (math.sin(th + dth) - math.sin(th)),
            y - radius * (math.cos(th + dth) - math.cos(th)),
            th + dth)


def _approach(value: float, target: float, max_change: float) -> float:
    return value + min(max(target - value, -max_change), max_change)


@dataclass
class Body:
    """What robots and agents share: a circle with a pose and the spec it came from."""

    spec: RobotSpec | AgentSpec
    x: float
    y: float
    theta: float

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def radius(self) -> float:
        return self.spec.radius

    def pose(self) -> tuple[float, float, float]:
        return self.x, self.y, self.theta


@dataclass
class Robot(Body):
    """A differential-drive robot: true pose, velocities, command, odometry and contact bookkeeping."""

    spec: RobotSpec
    v: float = 0.0
    w: float = 0.0
    cmd_v: float = 0.0
    cmd_w: float = 0.0
    cmd_time: float = -math.inf  # simulated time of the last command
    odom: tuple[float, float, float] = (0.0, 0.0, 0.0)  # pose in the odom frame (its origin: the start pose)
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    in_contact: bool = False
    bumper: int = 0
    collisions: int = 0
    lifted: bool = False  # held up off the floor (the world's robots[].lifted): wheels dropped, no motion
    fallen: bool = False  # its centre went over a cliff: it lies at the bottom and moves no more
    collision_points: list[tuple[float, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.start = (self.x, self.y, self.theta)

    def command(self, v: float, w: float, now: float) -> None:
        """Take a new command; a non-finite value (a NaN from a broken controller) means stop."""
        lim = self.spec.limits
        v, w = (float(v), float(w)) if math.isfinite(v) and math.isfinite(w) else (0.0, 0.0)
        self.cmd_v = min(max(float(v), -lim.max_v), lim.max_v)
        self.cmd_w = min(max(float(w), -lim.max_w), lim.max_w)
        self.cmd_time = now

    def accelerate(self, now: float, dt: float) -> None:
        """Move the velocities toward the command (zero once it is older than the timeout), within limits."""
        lim = self.spec.limits
        fresh = now - self.cmd_time <= lim.cmd_timeout + 1e-9
        target_v, target_w = (self.cmd_v, self.cmd_w) if fresh else (0.0, 0.0)
        self.v = _approach(self.v, target_v, lim.acc_v * dt)
        self.w = _approach(self.w, target_w, lim.acc_w * dt)

    def update_odometry(self, ds: float, dth: float, rng: np.random.Generator | None) -> None:
        """Dead-reckon the true displacement, scaled by seeded wheel-slip noise if the spec asks for it (the turn
        by `odom_turn_noise` if given: a base whose heading comes from a gyro errs less in turns)."""
        turn_noise = self.spec.odom_noise if self.spec.odom_turn_noise is None else self.spec.odom_turn_noise
        if (self.spec.odom_noise > 0 or turn_noise > 0) and rng is not None:
            ds *= 1.0 + self.spec.odom_noise * rng.standard_normal()
            dth *= 1.0 + turn_noise * rng.standard_normal()
        x, y, th = self.odom
        x, y, th = arc(x, y, th, ds, dth)
        self.odom = (x, y, wrap(th))


@dataclass
class Agent(Body):
    """A body driven by a script: visit waypoints in order (looping or not), or wander."""

    spec: AgentSpec
    target: int = 0  # index of the waypoint being walked to
    done: bool = False
    started: bool = False  # its wait is over and its cue (if any) given: it follows its script from now on

    lane_from: tuple[float, float] | None = None  # where the leg being walked started (its lane: from here to target)
    waited: float = 0.0  # s it has stood held up (see hold)
    giving_way: float = 0.0  # m it has still to walk back along its lane to let the other through
    pausing: float = 0.0  # s it has still to stand where it gave way

    def proposal(self, dt: float) -> tuple[float, float, float]:
        """Where the script wants the agent after dt (the simulation accepts it only if it is free).

        A walker aims along its lane (the segment from the waypoint it left to the one it walks to), a little
        ahead of where it is, not straight at the waypoint: after stepping aside it comes back to the lane, which
        the world's author drew clear of walls, instead of cutting a corner into a door jamb. One giving way walks
        back along the lane towards the waypoint it came from, then stands for GIVE_WAY_PAUSE s.
        """
        step = self.spec.speed * dt
        if self.spec.motion == "wander" or self.done:
            if self.done:
                return self.x, self.y, self.theta
            return self.x + step * math.cos(self.theta), self.y + step * math.sin(self.theta), self.theta
        if self.lane_from is None:
            self.lane_from = (self.x, self.y)
        if self.giving_way > 0:
            bx, by = self.lane_from
            back = math.hypot(bx - self.x, by - self.y)
            if back > step:
                heading = math.atan2(by - self.y, bx - self.x)
                return self.x + step * math.cos(heading), self.y + step * math.sin(heading), heading
            self.giving_way, self.pausing = 0.0, GIVE_WAY_PAUSE  # back where the leg began
        if self.pausing > 0:
            self.pausing = max(0.0, self.pausing - dt)
            return self.x, self.y, self.theta
        gx, gy = self.spec.waypoints[self.target]
        dx, dy = gx - self.x, gy - self.y
        dist = math.hypot(dx, dy)
        if dist <= step:
            self._next_waypoint()
            return gx, gy, self.theta if dist < 1e-9 else math.atan2(dy, dx)
        ax, ay = self.lane_point(LANE_LOOKAHEAD)
        heading = math.atan2(ay - self.y, ax - self.x)
        return self.x + step * math.cos(heading), self.y + step * math.sin(heading), heading

    def lane_point(self, ahead: float) -> tuple[float, float]:
        """The point `ahead` m beyond the walker's foot on its lane (at most the waypoint it walks to)."""
        fx, fy = self.lane_from if self.lane_from is not None else (self.x, self.y)
        gx, gy = self.spec.waypoints[self.target]
        length = math.hypot(gx - fx, gy - fy)
        if length < 1e-9:
            return gx, gy
        ux, uy = (gx - fx) / length, (gy - fy) / length
        along = min(max((self.x - fx) * ux + (self.y - fy) * uy, 0.0) + ahead, length)
        return fx + along * ux, fy + along * uy

    def moved(self, x: float, y: float, theta: float) -> None:
        """The simulation accepted a step: take it (a walker giving way counts it off, then pauses)."""
        if self.giving_way > 0:
            self.giving_way = max(0.0, self.giving_way - math.hypot(x - self.x, y - self.y))
            if self.giving_way == 0:
                self.pausing = GIVE_WAY_PAUSE
        self.x, self.y, self.theta = x, y, theta

    def hold(self, held: bool, dt: float) -> None:
        """Whether something the walker cannot step round (a robot; an agent, with no room to pass) stood in its
        way during the last dt s: after PATIENCE s of that in a row, it gives way.

        Why: in a doorway neither can pass the other; a walker that waits for ever for a robot that waits for it
        (or cannot see it) was the office patrol's deadlock, and two walkers met at a door waited for each other
        for ever too. People wait a moment, then step back to let the other through.
        """
        self.waited = self.waited + dt if held else 0.0
        if self.waited >= PATIENCE and self.spec.motion == "waypoints" and not self.done:
            self.giving_way, self.waited = GIVE_WAY, 0.0

    def _next_waypoint(self) -> None:
        self.lane_from = self.spec.waypoints[self.target]
        if self.target + 1 < len(self.spec.waypoints):
            self.target += 1
        elif self.spec.loop:
            self.target = 0
        else:
            self.done = True

    def sidesteps(self, x: float, y: float) -> list[tuple[float, float, float]]:
        """Where a walker may step instead of (x, y) when another agent is in its way: the same step turned
        SIDESTEP to its right, then to its left, facing where it was going.

        Why: two walkers who wait for each other's way to clear wait for ever when they meet face to face (the
        office's two people did from 56 s on). Real people keep right and pass; turning the step (not its
        length) moves them apart sideways until the way ahead is free, with no random draw.
        """
        dx, dy = x - self.x, y - self.y
        step, heading = math.hypot(dx, dy), math.atan2(dy, dx)
        if self.spec.motion != "waypoints" or self.done or step < 1e-12:
            return []
        return [(self.x + step * math.cos(heading + turn), self.y + step * math.sin(heading + turn), heading)
                for turn in (-SIDESTEP, SIDESTEP)]

    def to_lane(self, x: float, y: float) -> tuple[float, float, float] | None:
        """The step to (x, y) turned straight back towards the walker's lane, when a wall is in its way.

        Why: a walker that stepped aside near a door can find the door's jamb between it and the lane ahead; the
        lane itself is clear, so the way back to it is (None: on its lane already, or not a walker).
        """
        if self.spec.motion != "waypoints" or self.done:
            return None
        step = math.hypot(x - self.x, y - self.y)
        fx, fy = self.lane_point(0.0)
        off = math.hypot(fx - self.x, fy - self.y)
        if off < 1e-6 or step < 1e-12:
            return None
        k = min(step, off) / off
        return self.x + k * (fx - self.x), self.y + k * (fy - self.y), self.theta

    def blocked(self, rng: np.random.Generator) -> None:
        """The way is not free: a wanderer picks a new heading (seeded), a walker waits for the way to clear."""
        if self.spec.motion == "wander":
            self.theta = wrap(self.theta + rng.uniform(0.5 * math.pi, 1.5 * math.pi))


def start_pose_of_agent(spec: AgentSpec) -> tuple[float, float, float]:
    """A walker starts at its first waypoint facing the second one; a wanderer at its start pose."""
    if spec.start is not None:
        return spec.start
    (x, y), nxt = spec.waypoints[0], spec.waypoints[1 % len(spec.waypoints)]
    return x, y, math.atan2(nxt[1] - y, nxt[0] - x) if nxt != (x, y) else 0.0
