"""Modules drop messages with NaN or inf in a scalar field, count them, and log the first of each input.

Before: a NaN force reached runaway's atan2 and a NaN heading became a NaN turn rate on the motors' line.
Runs in-process (subsumption.testing.Harness); the ROS node's side is in test_fuzz_messages.py.
"""
from __future__ import annotations

import logging
import math

import pytest
from geometry_msgs.msg import Vector3, Vector3Stamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, Range
from std_msgs.msg import Float64

from subsumption import Input, Module, Output
from subsumption.examples.avoid import Avoid
from subsumption.examples.avoid_demo import Runaway, Turn
from subsumption.finite import non_finite_field
from subsumption.testing import Harness

BAD = [math.nan, math.inf, -math.inf]


def force(x: float, y: float) -> Vector3Stamped:
    return Vector3Stamped(vector=Vector3(x, y, 0.0))


@pytest.mark.parametrize("bad", BAD)
def test_a_non_finite_force_is_dropped_counted_and_never_reaches_the_register(bad, caplog):
    harness = Harness(Runaway)
    with caplog.at_level(logging.WARNING, logger="subsumption.local"):
        harness.feed("force", force(bad, 2.0))
        harness.feed("force", force(1.0, bad))
    assert harness.sent("heading") == []
    assert harness.module.registers.force is None
    assert harness.module.dropped["force"] == 2
    assert "vector.y" in harness.module.last_drop and "/in/force" in harness.module.last_drop
    warnings = [r.getMessage() for r in caplog.records if "NaN or inf" in r.getMessage()]
    assert len(warnings) == 1 and "vector.x" in warnings[0]  # the first only: a flood must not flood the log
    harness.feed("force", force(0.0, 2.0))  # a usable message goes through as before
    assert harness.sent("heading")[-1].data == pytest.approx(math.pi / 2)
    assert harness.module.dropped["force"] == 2


def test_an_afsm_never_sees_a_dropped_message():
    harness = Harness(Avoid)
    harness.feed("force", force(math.nan, 0.0))
    harness.feed("heading", Float64(math.inf))
    assert harness.module.state.name == "nil" and harness.module.transitions == 0
    assert dict(harness.module.dropped) == {"force": 1, "heading": 1}


def test_turn_never_makes_a_non_finite_command_of_a_heading():
    harness = Harness(Turn)
    for value in [*BAD, 0.5, *BAD]:
        harness.feed("heading", Float64(value))
    commands = harness.sent("cmd_vel")
    assert len(commands) == 1 and commands[0].angular.z == pytest.approx(0.5)


def test_nested_fields_are_checked_arrays_are_not():
    odom = Odometry()
    odom.twist.twist.angular.z = math.nan
    assert non_finite_field(odom) == "twist.twist.angular.z = nan"
    scan = LaserScan(angle_increment=0.1, ranges=[math.inf, math.nan, 1.0])  # REP 117: inf/NaN ranges are data
    assert non_finite_field(scan) is None
    scan.range_max = math.inf
    assert non_finite_field(scan) == "range_max = inf"


def test_range_may_be_infinite_as_rep_117_says_never_nan():
    assert non_finite_field(Range(range=math.inf)) is None  # nothing detected
    assert non_finite_field(Range(range=-math.inf)) is None  # too close
    assert non_finite_field(Range(range=math.nan)) == "range = nan"
    assert non_finite_field(Range(range=1.0, max_range=math.nan)) == "max_range = nan"


class Raw(Module):
    """Takes whatever comes (finite=False): its own code deals with NaN."""

    value = Input(Float64, finite=False)
    seen = Output(Float64)

    def on_value(self, msg: Float64) -> None:
        self.seen.publish(Float64(0.0 if math.isnan(msg.data) else msg.data))


def test_finite_false_lets_everything_through():
    harness = Harness(Raw)
    harness.feed("value", Float64(math.nan))
    assert [m.data for m in harness.sent("seen")] == [0.0] and not harness.module.dropped
    assert Raw.interface.inputs["value"].finite is False and Runaway.interface.inputs["force"].finite is True


def test_describe_says_which_inputs_pass_nan():
    assert "input  value: std_msgs/Float64 (NaN/inf passed)" in Raw.describe()
    assert "(NaN/inf passed)" not in Runaway.describe()
