"""move_base's recovery behaviours, as steps: what a stuck robot does before it plans again.

A round is chosen when the robot is stuck (:func:`recovery_round`): with something off the map near (a person, a
robot: it may be waiting for this robot), step aside to a point out of its way (:func:`give_way_point`) and wait
for it to pass; otherwise clear the scan's obstacles, back off (every other round, only with the rear clear and
nobody near), rotate once on the spot and turn to a heading from which the robot can drive towards its old plan.
:class:`navigation.move_base.MoveBase` drives the steps one after the other, each until its time is up (or the
robot stands at its give-way point, or faces the way out), then replans. Everything here works in the robot's
frame on points the caller gives; nothing here reads a topic.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from subsumption.planar import wrap

from .local_planner import bearing_away_from

GIVE_WAY_NEAR = 1.0  # m: something off the map this near when the robot is stuck makes it give way
GIVE_WAY_DISTANCE = 0.6  # m it steps aside
GIVE_WAY_TIME = 6.0  # s at most to get there
GIVE_WAY_WAIT = 3.0  # s it then waits for the other to pass before it replans
# rad off "straight away from it" it steps to, tried pair by pair: 1.1 rad first, 0.5 m to the side of the line
# through it and the robot, out of the way of a walker (0.45 m of radii) that was coming along that line
GIVE_WAY_TURNS = ((1.1, -1.1), (0.6, -0.6), (1.5, -1.5), (0.0,))
LEAVE_TIME = 5.0  # s at most a recovery's turn to where the robot can drive takes
BACK_OFF_TIME = 1.5  # s the robot backs off ...
BACK_OFF_SPEED = -0.15  # ... at this speed (m/s)
ROTATE_SPEED = 1.0  # rad/s of the full turn on the spot
REAR_CLEARANCE = 0.35  # m behind its back that must be free for backing off


@dataclass
class RecoveryStep:
    """One step of a recovery round, held until `until` (s): drive at (`v`, `w`), or to `target` (x, y, yaw: a
    give-way point, over once the robot stands near it), or, given `leave_plan` (the plan when the robot got
    stuck), turn to the heading from which it can drive towards that plan (`leave_yaw`, map frame: chosen when
    the step starts); `name` is what the log and a reader call it."""
    until: float
    name: str
    v: float = 0.0
    w: float = 0.0
    target: np.ndarray | None = None
    leave_plan: np.ndarray | None = None
    leave_yaw: float | None = None


def recovery_round(now: float, number: int, give_way_to: np.ndarray | None, may_back_off: bool,
                   leave_plan: np.ndarray | None) -> list[RecoveryStep]:
    """The steps of recovery round `number` (1, 2, ...) starting at `now`: to `give_way_to` and a wait there
    when the caller found a give-way point; else back off (even rounds, when `may_back_off`), one full turn on
    the spot, and, given `leave_plan`, a turn to where the robot can drive towards it.

    Why the turn to leave after the full one: facing a desk inside the camera's blind range, a full turn ends
    facing the desk again; the caller gives no `leave_plan` with anything that moves near (it may stand where
    the scan does not look)."""
    if give_way_to is not None:
        # a walker waits while the robot is in its way, and the robot waits for the walker to leave the plan:
        # rotating on the spot would keep both waiting, so the robot steps aside and lets it pass
        return [RecoveryStep(now + GIVE_WAY_TIME, "give way", target=give_way_to),
                RecoveryStep(now + GIVE_WAY_TIME + GIVE_WAY_WAIT, "wait")]
    steps = []
    if number % 2 == 0 and may_back_off:
        steps.append(RecoveryStep(now + BACK_OFF_TIME, "back off", v=BACK_OFF_SPEED))
    turn = 2 * math.pi / ROTATE_SPEED
    steps.append(RecoveryStep(now + (BACK_OFF_TIME if steps else 0.0) + turn, "rotate", w=ROTATE_SPEED))
    if leave_plan is not None:
        steps.append(RecoveryStep(steps[-1].until + LEAVE_TIME, "turn to leave", leave_plan=leave_plan))
    return steps


def give_way_point(pose: np.ndarray, dynamic: np.ndarray, walkers: list[tuple[np.ndarray, np.ndarray]],
                   free: Callable[[float, float], bool]) -> np.ndarray | None:
    """Where to step aside to (x, y, yaw in the map frame) when something off the map (`dynamic`, robot frame)
    is within GIVE_WAY_NEAR m: GIVE_WAY_DISTANCE m away from it, at a point `free` says the footprint may stand
    on, and out of the line a walker came along; None when nothing is that near or no such point exists.
    `walkers`: the (position, heading) of tracks seen walking near, robot frame.

    Which way: a walker stopped by the robot stands on her own line, so "straight away" from her is further along
    it, and she walks on and stops against the robot again. With a walker near (standing now or not), the point
    furthest from its line (up to 0.6 m off it), then from it; without one, away and to one side
    (GIVE_WAY_TURNS), 0.5 m off the line through it and the robot."""
    away = bearing_away_from(dynamic, GIVE_WAY_NEAR)
    if away is None:
        return None
    turns = [t for pair in GIVE_WAY_TURNS for t in pair]
    ends = np.array([[GIVE_WAY_DISTANCE * math.cos(away + t), GIVE_WAY_DISTANCE * math.sin(away + t)]
                     for t in turns])  # robot frame
    order = list(range(len(turns)))
    if walkers:  # off every walker's line as far as 0.6 m, then as far from them as can be
        lateral = np.min([np.abs(h[0] * (ends[:, 1] - q[1]) - h[1] * (ends[:, 0] - q[0])) for q, h in walkers],
                         axis=0)
        apart = np.min([np.hypot(*(ends - q).T) for q, _ in walkers], axis=0)
        order = sorted(order, key=lambda i: (-round(min(float(lateral[i]), 0.6), 2), -float(apart[i])))
    c, s = math.cos(pose[2]), math.sin(pose[2])
    for i in order:
        point = pose[:2] + np.array([c * ends[i, 0] - s * ends[i, 1], s * ends[i, 0] + c * ends[i, 1]])
        if free(float(point[0]), float(point[1])):
            return np.array([point[0], point[1], pose[2] + away + turns[i]])
    return None


def rear_clear(obstacles: np.ndarray, robot_radius: float) -> bool:
    """Nothing of `obstacles` (robot frame) within REAR_CLEARANCE m behind the robot's back, in a band as wide as
    the robot."""
    behind = obstacles[(obstacles[:, 0] < 0) & (np.abs(obstacles[:, 1]) < robot_radius + 0.05)]
    return not len(behind) or float(np.min(-behind[:, 0])) > robot_radius + REAR_CLEARANCE


def leave_turn_rate(leave_yaw: float, yaw: float) -> float | None:
    """The turn rate (rad/s) from heading `yaw` to `leave_yaw`: proportional, between 0.3 and 1.0 rad/s; None
    once within 0.1 rad of it."""
    error = float(wrap(leave_yaw - yaw))
    if abs(error) < 0.1:
        return None
    return math.copysign(min(1.0, max(0.3, 1.5 * abs(error))), error)
