"""The profiles' adapters on hand-made inputs: a laser as a ring of sonars read from the rim (the LDS's 0.0 as no
return, a narrow sensor's memory), and the Kobuki's bumper events as the bumper bitmask."""
from __future__ import annotations

import math

import pytest
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from robots.adapters import KobukiBumper, ScanRing
from subsumption import kobuki
from subsumption.testing import Harness


def lds(ranges: dict[int, float]) -> LaserScan:
    """A TurtleBot 3 LDS-01 scan: 360 beams from 0 rad, 0.0 where nothing returned."""
    values = [0.0] * 360
    for degree, value in ranges.items():
        values[degree] = value
    return LaserScan(angle_min=0.0, angle_max=2 * math.pi, angle_increment=math.radians(1.0), range_min=0.12,
                     range_max=3.5, ranges=values)


def test_scan_ring_reads_from_the_rim_per_sector_and_ignores_no_return():
    h = Harness(ScanRing, {"radius": 0.1})
    h.feed("scan", lds({0: 1.0, 5: 0.8, 90: 0.5, 200: 3.4, 300: 0.05}))
    ring = h.sent("sonar")[-12:]
    assert [m.header.frame_id for m in ring] == [f"sonar_{i}" for i in range(12)]
    ranges = [m.range for m in ring]
    assert ranges[0] == pytest.approx(0.7)  # the nearest in the cone ahead (0.8 at 5 deg), from the rim
    assert ranges[3] == pytest.approx(0.4)  # 90 deg: sonar 3
    assert ranges[7] == math.inf  # 3.4 m at 200 deg: beyond a sonar's 3 m
    assert ranges[10] == math.inf  # 0.05 is below the LDS's range_min: no reading, not an obstacle
    assert ranges[1] == ranges[6] == math.inf  # nothing returned
    clean = h.sent("clean")[-1]
    assert clean.ranges[1] == math.inf and clean.ranges[0] == 1.0  # 0.0 becomes REP 117's +inf


def test_scan_ring_remembers_what_a_narrow_sensor_saw():
    """A wall seen ahead, then the robot turns 90 degrees left in place: the narrow scan no longer sees it, the
    memory puts it on the right-hand sonar."""
    narrow = dict(angle_min=-0.5, angle_max=0.5, angle_increment=0.1, range_min=0.45, range_max=4.0)
    h = Harness(ScanRing, {"radius": 0.18, "memory": 10.0})
    odom = Odometry()
    odom.pose.pose.orientation.w = 1.0
    h.feed("odom", odom)
    h.feed("scan", LaserScan(ranges=[0.8] * 11, **narrow))
    assert h.sent("sonar")[-12].range == pytest.approx(0.62, abs=0.01)
    odom = Odometry()
    odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = math.sin(math.pi / 4), math.cos(math.pi / 4)
    h.feed("odom", odom)
    h.run_for(0.5)
    h.feed("scan", LaserScan(ranges=[math.nan] * 11, **narrow))
    ring = [m.range for m in h.sent("sonar")[-12:]]
    assert ring[9] == pytest.approx(0.62, abs=0.01) and ring[0] == math.inf  # now on the right (270 deg)
    without = Harness(ScanRing, {"radius": 0.18})
    without.feed("scan", LaserScan(ranges=[math.nan] * 11, **narrow))
    assert all(m.range == math.inf for m in without.sent("sonar"))


def test_kobuki_bumper_events_become_the_bitmask_repeated_while_pressed():
    h = Harness(KobukiBumper)
    h.feed("events", kobuki.BumperEvent(bumper=kobuki.BumperEvent.LEFT, state=kobuki.BumperEvent.PRESSED))
    h.feed("events", kobuki.BumperEvent(bumper=kobuki.BumperEvent.CENTER, state=kobuki.BumperEvent.PRESSED))
    assert [m.data for m in h.sent("bumper")] == [1, 3]
    h.run_for(0.35)
    assert [m.data for m in h.sent("bumper")][-1] == 3 and len(h.sent("bumper")) >= 5  # repeated while pressed
    h.feed("events", kobuki.BumperEvent(bumper=kobuki.BumperEvent.LEFT, state=kobuki.BumperEvent.RELEASED))
    h.feed("events", kobuki.BumperEvent(bumper=kobuki.BumperEvent.CENTER, state=kobuki.BumperEvent.RELEASED))
    count = len(h.sent("bumper"))
    h.run_for(0.5)
    assert h.sent("bumper")[-1].data == 0 and len(h.sent("bumper")) == count  # released: one 0, then quiet


def test_kobuki_cliff_events_are_contacts_on_their_side():
    """A cliff under the Kobuki's right cliff sensor is a contact on the right (4) for level 0/1, held while the
    sensor sees it (with a bumper press on top: both), released when the floor is back."""
    h = Harness(KobukiBumper)
    C, F = kobuki.CliffEvent.CLIFF, kobuki.CliffEvent.FLOOR
    h.feed("cliff", kobuki.CliffEvent(sensor=kobuki.CliffEvent.RIGHT, state=C, bottom=0))
    h.feed("events", kobuki.BumperEvent(bumper=kobuki.BumperEvent.LEFT, state=kobuki.BumperEvent.PRESSED))
    h.feed("events", kobuki.BumperEvent(bumper=kobuki.BumperEvent.LEFT, state=kobuki.BumperEvent.RELEASED))
    assert [m.data for m in h.sent("bumper")] == [4, 5, 4]
    h.run_for(0.35)
    assert h.sent("bumper")[-1].data == 4 and len(h.sent("bumper")) >= 5  # repeated while over the cliff
    h.feed("cliff", kobuki.CliffEvent(sensor=kobuki.CliffEvent.RIGHT, state=F, bottom=0))
    count = len(h.sent("bumper"))
    h.run_for(0.5)
    assert h.sent("bumper")[-1].data == 0 and len(h.sent("bumper")) == count
