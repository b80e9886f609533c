"""The pocket trap of frontier exploration (issue 31): a robot that no arc ahead may take turns, in move_base's
recovery, to a heading from which one can, and leaves over floor it has seen.

Office, seed 1, frontier exploration: the robot stood in the pocket between the west wall and a desk, facing the
desk 0.34 m away (within the depth camera's 0.45 m blind range), its plan leaving to the left. Every arc ahead came
nearer a sliver of floor before the desk that no beam ever reaches (each is cut short by the desk), so none was
admissible; the recovery's full turn ended facing the desk again, and the robot stood there until exploration gave
up. The pocket is rebuilt here from what move_base saw then (the map's wall and desk edges, the cells not seen
lately) and driven closed-loop with a perfect base: the local planner alone does not get out (it is unchanged);
turned as local_planner.heading_to_leave says, it does, keeping its distance from everything."""
from __future__ import annotations

import math

import numpy as np

from navigation.local_planner import LocalParams, compute_command, heading_to_leave
from subsumption.planar import inverse, transform_points

PLAN = np.array([[0.66, 10.37], [0.67, 10.68], [0.97, 10.98], [8.02, 10.48]])  # north round the desk, then east
GOAL = np.array([8.03, 10.48, 0.0])
SAFE = 0.18 + 0.04
PARAMS = LocalParams(dynamic_padding=0.1, unseen_clearance=0.18 + 0.05 + 0.1 * math.sqrt(0.5))  # move_base's


def pocket() -> tuple[np.ndarray, np.ndarray]:
    """Obstacle points (the west wall's face at x 0.17, the desk x 1.0-1.7, y 9.6-10.45) and the centres of the
    cells not seen lately (the wall's, and the desk's with the sliver of floor along its face), map frame."""
    wall = np.column_stack((np.full(60, 0.17), np.linspace(9.5, 11.3, 60)))
    face = np.column_stack((np.full(18, 1.0), np.linspace(9.6, 10.45, 18)))
    top = np.column_stack((np.linspace(1.0, 1.7, 15), np.full(15, 10.45)))
    bottom = np.column_stack((np.linspace(1.0, 1.7, 15), np.full(15, 9.6)))
    xs, ys = np.arange(-0.04, 1.8, 0.1), np.arange(9.54, 11.3, 0.1)
    cells = np.column_stack([a.ravel() for a in np.meshgrid(xs, ys)])
    desk = (cells[:, 0] > 0.8) & (cells[:, 0] < 1.4) & (cells[:, 1] > 9.7) & (cells[:, 1] < 10.4)
    return np.vstack((wall, face, top, bottom)), cells[desk | (cells[:, 0] < 0.2)]


def drive(seconds: float, pose: np.ndarray) -> tuple[np.ndarray, float]:
    """Closed loop at 10 Hz, the base doing what it is told: the end pose and the least clearance."""
    obstacles, unseen = pocket()
    velocity, least = (0.0, 0.0), math.inf
    for _ in range(int(round(seconds / 0.1))):
        to_robot = inverse(pose)
        command = compute_command(pose, velocity, PLAN, GOAL, transform_points(to_robot, obstacles), PARAMS,
                                  unseen=transform_points(to_robot, unseen))
        v, w = (command.v, command.w) if command.ok else (0.0, 0.0)
        heading = pose[2] + 0.05 * w
        pose = np.array([pose[0] + 0.1 * v * math.cos(heading), pose[1] + 0.1 * v * math.sin(heading),
                         pose[2] + 0.1 * w])
        velocity = (v, w)
        least = min(least, float(np.hypot(*(obstacles - pose[:2]).T).min()))
    return pose, least


def test_facing_the_desk_the_local_planner_alone_stays_in_the_pocket():
    start = np.array([0.66, 10.37, 0.0])
    end, least = drive(6.0, start)
    assert np.hypot(*(end[:2] - start[:2])) < 0.2 and least > SAFE


def test_turned_to_where_it_can_drive_the_robot_leaves_the_pocket_keeping_clear():
    start = np.array([0.66, 10.37, 0.0])
    obstacles, unseen = pocket()
    to_robot = inverse(start)
    heading = heading_to_leave(start, PLAN, transform_points(to_robot, obstacles), PARAMS,
                               transform_points(to_robot, unseen))
    assert heading is not None and heading > 0.5  # to the left, round towards the way it came in (north)
    end, least = drive(4.0, np.array([start[0], start[1], start[2] + heading]))
    assert np.hypot(*(end[:2] - start[:2])) > 0.5  # out of the pocket
    assert least > SAFE


def test_no_heading_when_every_way_is_walled_or_unseen():
    """Ringed in at 0.27 m (no arc anywhere), or with all ground round it unseen: no heading, no turn."""
    around = np.linspace(-math.pi, math.pi, 90, endpoint=False)
    ring = 0.27 * np.column_stack((np.cos(around), np.sin(around)))
    plan = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert heading_to_leave(np.zeros(3), plan, ring, PARAMS) is None
    xs = np.arange(-1.0, 1.05, 0.1)
    cells = np.column_stack([a.ravel() for a in np.meshgrid(xs, xs)])
    unseen = cells[np.hypot(*cells.T) > 0.25]
    assert heading_to_leave(np.zeros(3), plan, np.zeros((0, 2)), PARAMS, unseen) is None
