"""The wander robot's doorway logic on hand-made inputs (no simulator): level 1's avoid lets the robot through a
doorway it heads for, and level 2's look leads it out of a room it has covered by the way it came in."""
from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Pose2D, Vector3Stamped
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Empty, Float64

from robots.wander.level0 import Feelforce
from robots.wander.level2 import Look
from subsumption.examples.avoid import Avoid
from subsumption.network import load
from subsumption.testing import Harness

NETWORK = "robots/wander/wander.yaml"
ROBOT_RADIUS = 0.18  # m, the simulator's default robot
SONAR_MIN, SONAR_MAX, SONAR_CONE, SONAR_RAYS = 0.3, 3.0, math.radians(30), 5


def sonar_in_front_of_a_doorway(ahead: float, door: float) -> LaserScan:
    """The 12-sonar map (sonars on the body edge, 30-degree cones of 5 rays, as the simulator has them) of a
    robot centred on a doorway `door` m wide in a wall `ahead` m in front of its centre, facing through it."""
    ranges = []
    for i in range(12):
        centre = i * math.radians(30)
        ox, oy = ROBOT_RADIUS * math.cos(centre), ROBOT_RADIUS * math.sin(centre)
        best = math.inf
        for k in range(SONAR_RAYS):
            a = centre + SONAR_CONE * (k / (SONAR_RAYS - 1) - 0.5)
            if math.cos(a) <= 1e-9:
                continue
            t = (ahead - ox) / math.cos(a)
            if t > 0 and abs(oy + t * math.sin(a)) > door / 2:  # hits the wall beside the gap
                best = min(best, t)
        ranges.append(math.inf if best > SONAR_MAX else max(best, SONAR_MIN))
    return LaserScan(angle_min=0.0, angle_increment=math.radians(30), angle_max=math.radians(330),
                     range_min=SONAR_MIN, range_max=SONAR_MAX, ranges=ranges)


def avoid_heading(scan: LaserScan, gain: float) -> Float64 | None:
    """What avoid sends for 'straight ahead' given feelforce's force on this sonar map (None: no direction)."""
    feel = Harness(Feelforce)
    feel.feed("map", scan)
    force: Vector3Stamped = feel.sent("force")[-1]
    avoid = Harness(Avoid, params={"gain": gain})
    avoid.feed("force", force)
    avoid.feed("heading", Float64(0.0))
    sent = avoid.sent("heading")
    return sent[-1] if sent else None


def laser(ranges: list[float]) -> LaserScan:
    """A 270-degree laser scan, one beam a degree, from -135 degrees."""
    increment = math.radians(270) / (len(ranges) - 1)
    return LaserScan(angle_min=-math.radians(135), angle_max=math.radians(135), angle_increment=increment,
                     range_min=0.0, range_max=8.0, ranges=ranges)


def network_gain() -> float:
    return float(load(NETWORK).module("avoid").params["gain"])


@pytest.mark.parametrize("door", [0.9, 1.2])
@pytest.mark.parametrize("ahead", [1.0, 0.6, 0.4, 0.25])
def test_avoid_keeps_heading_through_a_doorway_the_robot_fits(door, ahead):
    """At every distance on the way in, the shipped gain leaves a heading that still goes forward: the jambs'
    push (both sides cancel across, add up against) is weaker than the wish to go through."""
    heading = avoid_heading(sonar_in_front_of_a_doorway(ahead, door), network_gain())
    assert heading is not None and abs(heading.data) < math.pi / 2, heading


def test_with_the_old_gain_the_jambs_of_a_doorway_turned_the_robot_back():
    """The cause of the issue: with gain 1, a 1.2 m doorway half a metre ahead pushes harder than the robot wants
    to go, and avoid sends it back the way it came."""
    heading = avoid_heading(sonar_in_front_of_a_doorway(0.6, 1.2), 1.0)
    assert heading is not None and abs(heading.data) > math.pi / 2


def test_avoid_still_turns_away_from_a_wall_straight_ahead():
    """The smaller gain does not take safety away: a wall (no gap) 0.5 m ahead still turns the robot round."""
    heading = avoid_heading(sonar_in_front_of_a_doorway(0.5 + ROBOT_RADIUS, 0.0), network_gain())
    assert heading is None or abs(heading.data) > math.pi / 2


def covered_room_look(path: list[tuple[float, float]], opening: bool) -> Harness:
    """Look after the robot walked `path` to (0, 0), now facing +x, in a room 2 m round that it has seen all of,
    with (if `opening`) an opening at +78..+102 degrees (0.8 m wide at the walls)."""
    ranges = [2.0] * 271
    if opening:
        for i in range(213, 238):
            ranges[i] = 8.0
    harness = Harness(Look)
    for x, y in path:
        harness.feed("integral", Pose2D(x, y, 0.0))
    harness.feed("integral", Pose2D(0.0, 0.0, 0.0))
    harness.feed("scan", laser(ranges))
    return harness


def test_look_leads_out_of_a_covered_room_by_the_way_the_robot_came_in():
    came_in = [(0.0, 6.0 - 0.25 * k) for k in range(25)]  # down the y axis, through the opening, to (0, 0)
    harness = covered_room_look(came_in, opening=True)
    harness.feed("startlook", Empty())
    target = harness.sent("travel")[-1].point
    assert math.degrees(math.atan2(target.y, target.x)) == pytest.approx(90, abs=10)
    assert target.y > 4.0  # the earliest point of its path in view, out beyond the opening


def test_without_a_way_back_in_view_look_turns_round():
    """The robot came in from behind, where the laser does not see: it turns round to look."""
    harness = covered_room_look([(-6.0 + 0.25 * k, 0.0) for k in range(24)], opening=False)
    harness.feed("startlook", Empty())
    target = harness.sent("travel")[-1].point
    assert target.x == pytest.approx(-1.0) and target.y == pytest.approx(0.0, abs=1e-9)
