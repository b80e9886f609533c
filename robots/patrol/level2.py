"""Level 2, explore: along the corridors round the table (the paper's Fig. 7(c)).

The wander robot's explore (integrate, whenlook, pathplan) drives it; only ``look`` is the TurtleBot's own. The
wander robot's look heads for ground it has not been near, which suits a sonar ring that sees all round; the
TurtleBot's depth camera sees 57 degrees ahead, so from a corner it sees one wall and nothing of the way on.
``corridor`` keeps to the way it is going instead: the farthest clear place ahead, preferring the straightest,
and when the way ahead is blocked (a wall at the end of a corridor) a quarter turn, always to the same side.
In a room with a table in the middle that takes it round and round the table along the corridors between the
table and the walls; elsewhere it follows the walls on one side, as a left-hand (or right-hand) rule does.
"""
from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Pose2D
from sensor_msgs.msg import LaserScan

from subsumption.planar import wrap
from robots.wander.level2 import Look
from subsumption import Param


class Corridor(Look):
    """On startlook, the place to travel to along the corridor it is in (odometry frame). It keeps a course (a
    heading in the odometry frame: the way the corridor goes). Among the directions in the scan that are clear,
    a corridor `width` wide, for at least `min_travel` beyond the `margin`, it takes the one scoring best on
    `reach_weight` per metre clear less `turn_weight` per radian off the course, and the course follows that
    direction by at most `bend`; a direction further off the course than that (a way round a thing in the way)
    is travelled `lead` metres at most before the next look. When no direction is clear, the course turns a quarter to the `side` (+1 left: round the room
    counter-clockwise, -1 right); when the course is not in view (avoiding something turned the robot away, or
    the course just turned), the place is `lead` metres along the course, so the robot turns back to it and
    looks again. A direction the robot failed to make way in at the last look (it hardly moved since) is not
    chosen again (wander's ``blocked``)."""

    turn_weight = Param(4.0, "score lost per radian off the course (wander's look: 1, off straight ahead)")
    side = Param(1.0, "+1: turn left when the way ahead is blocked; -1: turn right")
    turn_angle = Param(math.pi / 2, "rad the course turns when the way ahead is blocked", min=0.1, max=math.pi)
    bend = Param(0.15, "rad the course follows the direction taken, at most, per look (a bending corridor; "
                       "not a doorway or a thing in the way)", min=0.0)
    lead = Param(1.5, "m along the course to the place sent while the course is out of view; the longest "
                      "detour", min=0.1)

    def setup(self) -> None:
        super().setup()
        self.course: float | None = None

    def choose(self, scan: LaserScan, pose: Pose2D) -> tuple[float, float]:
        if self.course is None:
            self.course = pose.theta
        angles, free = self.reachable(scan)
        off_course = np.abs(wrap(pose.theta + angles - self.course))
        half_view = max(abs(scan.angle_min), abs(scan.angle_max))
        if abs(wrap(self.course - pose.theta)) <= half_view:
            reach = np.minimum(free - self.margin, self.max_travel)
            value = self.reach_weight * reach - self.turn_weight * off_course
            score = np.where((reach >= self.min_travel) & ~self.blocked(pose, angles), value, -np.inf)
            best = int(np.argmax(score))
            if np.isfinite(score[best]):
                heading = wrap(pose.theta + angles[best])
                off = wrap(heading - self.course)
                self.course = wrap(self.course + min(self.bend, max(-self.bend, off)))
                distance = reach[best] if abs(off) <= self.bend else min(reach[best], self.lead)  # a detour: short
                return pose.x + distance * math.cos(heading), pose.y + distance * math.sin(heading)
            self.course = wrap(self.course + math.copysign(self.turn_angle, self.side))
        return pose.x + self.lead * math.cos(self.course), pose.y + self.lead * math.sin(self.course)
