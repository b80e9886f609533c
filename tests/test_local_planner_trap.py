"""The local planner where no arc ahead may go: it turns on the spot towards where it can drive, never dithering.

Office, seed 1, frontier exploration (issue 31): the robot stood in the pocket between the west wall and a desk,
facing the desk 0.34 m away (within the depth camera's 0.45 m blind range), its plan leaving 66 degrees to the
left. Every arc ahead moved it nearer a sliver of floor before the desk that no beam ever reaches (each one is cut
short by the desk), so none was admissible; every turn on the spot ended where the robot stood and scored the
same, and the tie went to the fastest turn clockwise, away from the plan. Past 1.2 rad of error it turned left
again, and so on: from 180 s to the end it never moved. The pocket is rebuilt here from what move_base saw then
(the map's wall and desk edges, the cells not seen lately) and driven closed-loop with a perfect base."""
from __future__ import annotations

import math

import numpy as np

from navigation.local_planner import LocalParams, compute_command
from subsumption.planar import inverse, transform_points

PLAN = np.array([[0.66, 10.37], [0.67, 10.68], [0.97, 10.98], [8.02, 10.48]])  # north round the desk, then east
GOAL = np.array([8.03, 10.48, 0.0])
SAFE = 0.18 + 0.04


def pocket() -> tuple[np.ndarray, np.ndarray]:
    """Obstacle points (the west wall's face at x 0.17, the desk x 1.0-1.7, y 9.6-10.45) and the centres of the
    cells not seen lately (the wall's, and the desk's with the sliver of floor along its face), map frame."""
    wall = np.column_stack((np.full(60, 0.17), np.linspace(9.5, 11.3, 60)))
    face = np.column_stack((np.full(18, 1.0), np.linspace(9.6, 10.45, 18)))
    top = np.column_stack((np.linspace(1.0, 1.7, 15), np.full(15, 10.45)))
    bottom = np.column_stack((np.linspace(1.0, 1.7, 15), np.full(15, 9.6)))
    xs, ys = np.arange(-0.04, 1.8, 0.1), np.arange(9.54, 11.3, 0.1)
    cells = np.column_stack([a.ravel() for a in np.meshgrid(xs, ys)])
    desk = (cells[:, 0] > 0.95) & (cells[:, 0] < 1.4) & (cells[:, 1] > 9.7) & (cells[:, 1] < 10.4)
    return np.vstack((wall, face, top, bottom)), cells[desk | (cells[:, 0] < 0.2)]


def drive(seconds: float, params: LocalParams, pose: np.ndarray) -> tuple[np.ndarray, float, list[str]]:
    """Closed loop at 10 Hz, the base doing what it is told: the end pose, the least clearance, the reasons."""
    obstacles, unseen = pocket()
    velocity, least, why = (0.0, 0.0), math.inf, []
    for _ in range(int(round(seconds / 0.1))):
        to_robot = inverse(pose)
        command = compute_command(pose, velocity, PLAN, GOAL, transform_points(to_robot, obstacles), params,
                                  unseen=transform_points(to_robot, unseen))
        v, w = (command.v, command.w) if command.ok else (0.0, 0.0)
        heading = pose[2] + 0.05 * w
        pose = np.array([pose[0] + 0.1 * v * math.cos(heading), pose[1] + 0.1 * v * math.sin(heading),
                         pose[2] + 0.1 * w])
        velocity = (v, w)
        least = min(least, float(np.hypot(*(obstacles - pose[:2]).T).min()))
        why.append(command.why)
    return pose, least, why


def test_a_robot_facing_a_desk_in_its_blind_range_turns_to_where_it_can_drive_and_leaves():
    params = LocalParams(dynamic_padding=0.1, unseen_clearance=0.18 + 0.05 + 0.1 * math.sqrt(0.5),
                         unseen_blind=0.45 - 0.087)  # the camera's minimum range less its offset from the centre
    start = np.array([0.66, 10.37, 0.0])
    end, least, why = drive(4.0, params, start)
    assert np.hypot(*(end[:2] - start[:2])) > 0.5, why  # out of the pocket (today: 0.0 m, turning to and fro)
    assert least > SAFE
    assert "turning to where it can drive" in why


def test_a_turn_on_the_spot_goes_towards_the_plan():
    """No seen-ground rule, the plan 60 degrees to the left, the sampler deciding (no turn-first shortcut): with a
    wall 0.27 m ahead the robot turns left, to where it can drive along it; ringed in at 0.27 m (no arc anywhere)
    the turn on the spot it takes is still towards the plan. Both turned right: the tie between turns on the spot
    went to the first sample, the fastest turn clockwise."""
    params = LocalParams(rotate_in_place_above=math.pi)
    plan = np.array([[0.0, 0.0], [0.5, 0.87], [1.0, 1.73]])
    around = np.linspace(-math.pi, math.pi, 90, endpoint=False)
    ring = 0.27 * np.column_stack((np.cos(around), np.sin(around)))
    wall = np.column_stack((np.full(40, 0.27), np.linspace(-1.0, 1.0, 40)))
    for obstacles in (wall, ring):
        command = compute_command(np.zeros(3), (0.0, 0.0), plan, np.array([1.0, 1.73, 1.0]), obstacles, params)
        assert command.ok and abs(command.v) < 1e-9 and command.w > 0.0, command
