"""Each wander module's logic on hand-made inputs (no simulator, no ROS)."""
from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Point, PointStamped, Pose2D, Quaternion, Twist, Vector3Stamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, Range
from std_msgs.msg import Bool, Empty, Float64

from robots.wander.level0 import Collide, Feelforce, Forward, Runaway, Sonar, Turn
from robots.wander.level1 import Wander
from robots.wander.level2 import Look, Pathplan, Whenlook
from subsumption.testing import Harness

INF = math.inf


def sonar_map(readings: dict[int, float]) -> LaserScan:
    """A 12-beam sonar map (beam i at i*30 degrees) with nothing seen except `readings`."""
    scan = LaserScan(angle_min=0.0, angle_increment=math.radians(30), angle_max=math.radians(330),
                     range_min=0.3, range_max=3.0)
    scan.ranges = [readings.get(i, INF) for i in range(12)]
    return scan


def force_of(readings: dict[int, float]) -> tuple[float, float]:
    harness = Harness(Feelforce)
    harness.feed("map", sonar_map(readings))
    vector = harness.sent("force")[-1].vector
    return vector.x, vector.y


def test_sonar_collects_a_full_sweep_into_a_map_and_reads_too_close_as_the_minimum():
    harness = Harness(Sonar)
    for i in range(12):
        reading = {0: 1.5, 3: -INF}.get(i, INF)
        harness.feed("ranges", _range(f"sonar_{i}", reading))
        assert len(harness.sent("map")) == (1 if i == 11 else 0)
    scan = harness.sent("map")[0]
    assert scan.ranges[0] == 1.5 and scan.ranges[3] == 0.3 and scan.ranges[6] == INF
    assert scan.header.frame_id == "base_link"
    assert scan.angle_increment == pytest.approx(math.radians(30))


def test_sonar_joined_mid_sweep_keeps_in_step_with_the_ring():
    """A node that missed the start of a sweep (a late subscriber, a bag starting mid-burst) publishes the
    same maps, at the same readings, as one that heard every sonar: a sweep ends with the ring's last sonar."""
    sweeps = [[1.0 + 0.1 * s + 0.01 * i for i in range(12)] for s in range(3)]
    whole, joined = Harness(Sonar), Harness(Sonar)
    for s, sweep in enumerate(sweeps):
        for i, value in enumerate(sweep):
            whole.feed("ranges", _range(f"sonar_{i}", value))
            if s > 0 or i >= 5:
                joined.feed("ranges", _range(f"sonar_{i}", value))
    assert len(whole.sent("map")) == 3 and len(joined.sent("map")) == 2  # the first, partial sweep: no map
    assert [m.ranges for m in joined.sent("map")] == [m.ranges for m in whole.sent("map")[1:]]


def _range(frame: str, value: float) -> Range:
    msg = Range(radiation_type=Range.ULTRASOUND, min_range=0.3, max_range=3.0, range=value)
    msg.header.frame_id = frame
    return msg


def test_feelforce_on_a_wall_to_the_left_points_right():
    fx, fy = force_of({2: 1.2, 3: 1.0, 4: 1.2})  # 60, 90, 120 degrees: the left side
    assert fy < 0 and abs(fx) < 1e-9
    assert -fy == pytest.approx(1.0 + 2 * math.sin(math.radians(60)) / 1.44)


def test_feelforce_is_inverse_square_and_ignores_out_of_range():
    assert force_of({0: 1.0})[0] == pytest.approx(-1.0)
    assert force_of({0: 2.0})[0] == pytest.approx(-0.25)
    assert force_of({0: INF}) == (0.0, 0.0)


def test_collide_halts_on_an_obstacle_straight_ahead_at_0_3_m_but_not_at_45_degrees():
    ahead = Harness(Collide)
    ahead.feed("map", sonar_map({0: 0.3}))
    assert len(ahead.sent("halt")) == 1
    beside = Harness(Collide)
    scan = LaserScan(angle_min=math.radians(-135), angle_increment=math.radians(45), range_min=0.3, range_max=3.0,
                     ranges=[INF, INF, 0.3, INF, INF, INF, INF])  # beam 2 at -45 degrees
    beside.feed("map", scan)
    beside.feed("map", sonar_map({1: 0.3, 11: 0.3}))  # 30 degrees either side: not straight ahead either
    assert beside.sent("halt") == []


def test_runaway_only_on_a_significant_force_and_away_from_it():
    harness = Harness(Runaway)
    weak, strong = Vector3Stamped(), Vector3Stamped()
    weak.vector.x = -0.4
    strong.vector.x = -2.0
    harness.feed("force", weak)
    assert harness.sent("heading") == []
    harness.feed("force", strong)
    assert harness.sent("heading")[0].data == pytest.approx(math.pi)


def test_turn_rotates_towards_the_heading_and_allows_speed_only_when_facing_it():
    harness = Harness(Turn)
    for heading in (0.0, 0.2, -3.0):
        harness.feed("heading", Float64(heading))
    straight, slight, behind = harness.sent("encoders")
    assert straight.angular.z == 0 and straight.linear.x == 1.0
    assert slight.angular.z == pytest.approx(0.4) and slight.linear.x == pytest.approx(math.cos(0.2) ** 2)
    assert behind.linear.x == 0.0
    assert behind.angular.z == 1.0, "a heading behind keeps the way the robot was turning (left), no dithering"
    fresh = Harness(Turn)
    fresh.feed("heading", Float64(-3.0))
    assert fresh.sent("encoders")[0].angular.z == -1.0


def test_forward_drives_on_fresh_commands_stops_forward_on_halt_and_stands_still_without_commands():
    harness = Harness(Forward)
    command = Twist()
    command.linear.x, command.angular.z = 1.0, 0.3
    harness.run_for(0.15)
    assert harness.sent("cmd_vel")[-1].linear.x == 0.0          # nothing to do yet
    harness.feed("encoders", command)
    harness.run_for(0.1)
    assert harness.sent("cmd_vel")[-1].linear.x == 0.5
    harness.feed("halt", Empty())
    harness.run_for(0.1)
    assert harness.sent("cmd_vel")[-1].linear.x == 0.0 and harness.sent("cmd_vel")[-1].angular.z == 0.3
    harness.run_for(1.0)
    last = harness.sent("cmd_vel")[-1]
    assert (last.linear.x, last.angular.z) == (0.0, 0.0)        # the command went stale


def odometry(x: float, y: float, yaw: float) -> Odometry:
    msg = Odometry()
    msg.pose.pose.position = Point(x, y, 0.0)
    msg.pose.pose.orientation = Quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    return msg


def test_wander_keeps_a_direction_for_its_interval_and_it_is_reproducible():
    runs = []
    for _ in range(2):
        harness = Harness(Wander, params={"seed": 3})
        harness.feed("odom", odometry(0, 0, 0.5))
        harness.run_for(12.0)
        runs.append([m.data for m in harness.sent("heading")])
    assert runs[0] == runs[1]
    headings = runs[0]
    assert len(headings) == pytest.approx(120, abs=1)
    assert all(abs(h) <= math.pi for h in headings)
    assert len({round(h, 9) for h in headings}) == 3  # a new direction at 0, 5 and 10 s


def test_wander_draws_from_the_whole_circle_unless_its_spread_is_narrowed():
    def headings(params: dict) -> list[float]:
        harness = Harness(Wander, params={"seed": 5, "interval": 1.0, **params})
        harness.feed("odom", odometry(0, 0, 0.0))
        harness.run_for(200.0)
        return sorted({round(m.data, 9) for m in harness.sent("heading")})

    aimless = headings({})
    assert len(aimless) > 150 and aimless[0] < -2.5 and aimless[-1] > 2.5, "Brooks' wander: any direction"
    narrow = headings({"spread": 0.5})
    assert all(abs(h) <= 0.5 for h in narrow)


def laser(ranges: list[float], angle_min: float = -math.radians(135)) -> LaserScan:
    increment = math.radians(270) / (len(ranges) - 1)
    return LaserScan(angle_min=angle_min, angle_max=angle_min + increment * (len(ranges) - 1),
                     angle_increment=increment, range_min=0.0, range_max=8.0, ranges=ranges)


def test_look_picks_the_open_direction_a_robot_can_get_through():
    ranges = [1.5] * 271                  # walls 1.5 m around ...
    for i in range(200, 241):             # ... an opening from +65 to +105 degrees (1 m wide at the walls)
        ranges[i] = 8.0
    ranges[60] = 8.0                      # and a single open beam, too narrow to pass, at -75 degrees
    harness = Harness(Look)
    harness.feed("integral", Pose2D(0.0, 0.0, 0.0))
    harness.feed("scan", laser(ranges))
    harness.feed("startlook", Empty())
    target = harness.sent("travel")[0].point
    angle = math.degrees(math.atan2(target.y, target.x))
    assert 70 < angle < 100 and math.hypot(target.x, target.y) > 3.0


def test_look_does_not_send_the_robot_again_where_it_could_not_get_to():
    ranges = [1.5] * 271                  # walls 1.5 m around, two openings: +90 and -90 degrees
    for i in list(range(210, 241)) + list(range(30, 61)):
        ranges[i] = 8.0
    harness = Harness(Look)
    harness.feed("integral", Pose2D(0.0, 0.0, 0.0))
    harness.feed("scan", laser(ranges))
    harness.feed("startlook", Empty())
    first = harness.sent("travel")[-1].point
    harness.feed("integral", Pose2D(0.1, 0.0, 0.0))   # pathplan gave up: the robot hardly moved
    harness.feed("startlook", Empty())
    second = harness.sent("travel")[-1].point
    assert math.copysign(1, first.y) != math.copysign(1, second.y), (first, second)
    harness.feed("integral", Pose2D(1.0, 0.0, 0.0))   # the robot got on (1 m): nothing counts as blocked
    harness.feed("startlook", Empty())
    assert math.copysign(1, harness.sent("travel")[-1].point.y) == math.copysign(1, first.y)


def test_pathplan_heads_for_the_place_and_is_busy_until_there():
    harness = Harness(Pathplan)
    goal = PointStamped()
    goal.point.x, goal.point.y = 2.0, 2.0
    harness.feed("travel", goal)
    harness.feed("integral", Pose2D(0.0, 0.0, 0.0))
    assert harness.sent("heading")[-1].data == pytest.approx(math.pi / 4)
    assert harness.sent("busy")[-1].data is True
    harness.feed("integral", Pose2D(1.8, 1.9, 0.0))
    assert harness.sent("busy")[-1].data is False


def test_whenlook_starts_a_look_only_when_not_busy():
    harness = Harness(Whenlook)
    harness.feed("busy", Bool(True))
    harness.run_for(5.0)
    assert harness.sent("startlook") == []
    harness.feed("busy", Bool(False))
    harness.run_for(1.01)
    assert len(harness.sent("startlook")) == 1
