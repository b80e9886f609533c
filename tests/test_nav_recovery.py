"""navigation.recovery on its own: the steps of a round, the rear check and the turn to leave (move_base drives them:
tests/test_nav_move_base.py runs the rounds on a robot that cannot move, and the give-way point among people)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from navigation.recovery import (BACK_OFF_TIME, GIVE_WAY_TIME, GIVE_WAY_WAIT, LEAVE_TIME, ROTATE_SPEED,
                                 give_way_point, leave_turn_rate, rear_clear, recovery_round)

PLAN = np.array([[0.0, 0.0], [2.0, 0.0]])
TURN_S = 2 * math.pi / ROTATE_SPEED


def test_a_round_gives_way_and_waits_when_there_is_somewhere_to_go():
    point = np.array([1.0, 0.5, 0.3])
    steps = recovery_round(10.0, 1, point, may_back_off=True, leave_plan=PLAN)
    assert [s.name for s in steps] == ["give way", "wait"]
    assert steps[0].target is point and steps[0].until == 10.0 + GIVE_WAY_TIME
    assert steps[1].until == 10.0 + GIVE_WAY_TIME + GIVE_WAY_WAIT and steps[1].v == steps[1].w == 0.0


def test_even_rounds_back_off_first_then_every_round_turns_round_and_to_where_it_can_drive():
    odd = recovery_round(10.0, 1, None, may_back_off=True, leave_plan=PLAN)
    assert [s.name for s in odd] == ["rotate", "turn to leave"]
    assert odd[0].until == pytest.approx(10.0 + TURN_S) and odd[0].w == ROTATE_SPEED
    assert odd[1].until == pytest.approx(odd[0].until + LEAVE_TIME) and odd[1].leave_plan is PLAN
    even = recovery_round(10.0, 2, None, may_back_off=True, leave_plan=None)
    assert [s.name for s in even] == ["back off", "rotate"]
    assert even[0].until == 10.0 + BACK_OFF_TIME and even[0].v < 0
    assert even[1].until == pytest.approx(10.0 + BACK_OFF_TIME + TURN_S)
    assert [s.name for s in recovery_round(10.0, 2, None, may_back_off=False, leave_plan=None)] == ["rotate"]


def test_the_rear_is_clear_unless_something_is_close_behind_within_the_robot_s_width():
    radius = 0.2
    assert rear_clear(np.zeros((0, 2)), radius)
    assert rear_clear(np.array([[0.3, 0.0], [-1.0, 0.0]]), radius)  # ahead, and far behind
    assert not rear_clear(np.array([[-0.4, 0.1]]), radius)           # 0.2 m behind its back
    assert rear_clear(np.array([[-0.4, 0.5]]), radius)               # behind, but beside its path


def test_the_turn_to_leave_slows_near_the_heading_and_stops_there():
    assert leave_turn_rate(0.05, 0.0) is None
    assert leave_turn_rate(2.0, 0.0) == 1.0 and leave_turn_rate(-2.0, 0.0) == -1.0
    assert leave_turn_rate(0.15, 0.0) == pytest.approx(0.3)
    assert leave_turn_rate(-3.0, 3.0) == pytest.approx(1.5 * (2 * math.pi - 6.0))  # the short way, through pi


def test_no_give_way_point_with_nothing_near_or_nowhere_free():
    pose = np.array([1.0, 1.0, 0.0])
    assert give_way_point(pose, np.zeros((0, 2)), [], lambda x, y: True) is None
    person = np.array([[0.5, 0.0]])
    assert give_way_point(pose, person, [], lambda x, y: False) is None
    point = give_way_point(pose, person, [], lambda x, y: True)
    assert point is not None and point[0] < pose[0]  # away from the person ahead
