"""Ground seen free lately (navigation.seen_space) and the local planner's rule to drive only onto it: a robot that
stood facing one way does not turn and drive into the side it has not looked at (where a person may have come)."""
from __future__ import annotations

import math

import numpy as np

from navigation.local_planner import LocalParams, compute_command, rollout
from navigation.scan_geometry import Beams
from navigation.seen_space import SeenSpace


def camera_beams(count: int = 40, reach: float = 3.0) -> Beams:
    """A depth camera's 57-degree scan from 0.087 m behind the centre, every beam seeing free space to `reach`."""
    angles = np.linspace(-math.radians(28.5), math.radians(28.5), count)
    return Beams(np.array([-0.087, 0.0]), angles, np.full(count, reach), np.zeros(count, dtype=bool))


def test_ground_ahead_is_seen_and_beside_it_is_not_and_sight_ages():
    seen = SeenSpace()
    robot = np.array([2.0, 1.0, math.pi / 2])  # facing +y
    seen.update(0.0, robot, camera_beams())
    unseen = seen.unseen(1.0, robot, keep=2.0, radius=1.5)  # robot frame
    ahead = np.hypot(unseen[:, 0] - 1.0, unseen[:, 1]) < 0.1
    beside = np.hypot(unseen[:, 0], unseen[:, 1] + 0.6) < 0.1
    own = np.hypot(*unseen.T) < 0.18 + 0.06 - 0.08
    assert not ahead.any() and beside.any() and not own.any()
    seen.update(3.0, robot, camera_beams(count=0))  # a scan with no beams: only where the robot stands is seen
    later = seen.unseen(3.0, robot, keep=2.0, radius=1.5)
    assert (np.hypot(later[:, 0] - 1.0, later[:, 1]) < 0.1).any()  # not seen again for 3 s: unseen
    assert not (np.hypot(*later.T) < 0.16).any()  # where the robot stands counts as seen


def test_the_planner_turns_on_the_spot_before_it_drives_onto_ground_it_has_not_seen():
    """The plan turns sharply right; to the right the robot has not looked: it may turn on the spot (a round robot
    moves onto no new ground) but no arc drives it there. With that ground seen, it drives off along an arc."""
    params = LocalParams(max_vel_x=0.4, rotate_in_place_above=math.pi)  # no turn-first shortcut: the sampler decides
    pose, velocity = np.zeros(3), (0.0, 0.0)
    path = np.array([[0.0, 0.0], [0.0, -1.5]])
    goal = np.array([0.0, -1.5, -math.pi / 2])
    seen = SeenSpace()
    seen.update(0.0, pose, camera_beams())
    unseen = seen.unseen(0.5, pose, keep=3.0, radius=1.4)
    held = compute_command(pose, velocity, path, goal, np.zeros((0, 2)), params, unseen=unseen)
    free = compute_command(pose, velocity, path, goal, np.zeros((0, 2)), params, unseen=np.zeros((0, 2)))
    assert free.ok and free.v > 0.1 and free.w < 0
    assert held.ok and held.v <= 0.1 + 1e-9 and held.w < 0


def test_a_person_standing_out_of_view_beside_the_robot_is_not_driven_into():
    """Office seed 1, 268.8 s: a person stood against the robot's right side, out of the 57-degree view, on ground
    not seen lately, and the planner drove past her into her: its centre kept 0.23 m from the unseen cells'
    centres, its rim 0.05 m, less than the half cell she may stand in. With the rim kept off whole cells (what
    SeenSpace.rim_clearance gives) it turns to look first; with the old clearance its arc touches her."""
    grid = np.arange(-1.35, 1.4, 0.1)  # cell centres, 0.1 m cells
    cells = np.column_stack([a.ravel() for a in np.meshgrid(grid, grid)])
    distance, bearing = np.hypot(*cells.T), np.arctan2(cells[:, 1], cells[:, 0])
    unseen = cells[(distance > 0.25) & (np.abs(bearing) > 0.55)]  # seen: the view ahead and where it stands
    person = np.array([0.2, -0.39])  # her centre, 0.44 m away at -62 degrees: 0.007 m from the rim
    pose, velocity = np.zeros(3), (0.0, 0.0)
    path = np.array([[0.0, 0.0], [1.0, -0.3]])
    goal = np.array([1.0, -0.3, -0.3])

    def nearest_to_her(clearance: float) -> float:
        params = LocalParams(max_vel_x=0.4, unseen_clearance=clearance, rotate_in_place_above=math.pi)
        command = compute_command(pose, velocity, path, goal, np.zeros((0, 2)), params, unseen=unseen)
        arc = rollout(0.0, 0.0, np.array([command.v]), np.array([command.w]), params)[0, :, :2]
        return float(np.hypot(*(arc - person).T).min())

    assert nearest_to_her(SeenSpace().rim_clearance(0.18)) > 0.18 + 0.25
    assert nearest_to_her(0.18 + 0.05) < 0.18 + 0.25


def test_no_arc_closes_on_a_cell_beside_it_down_to_the_distance_of_one_behind_it():
    """The robot stands 0.25 m from an unseen cell behind it and 0.32 m from unseen cells along its right side. An
    arc may get no closer to each cell within the clearance than it is now: with the nearest cell's distance as
    the bound for all, the planner arced right to 0.25 m of the side cells (where a person who walked up out of
    view may stand)."""
    side = np.column_stack((np.arange(-0.2, 1.25, 0.1), np.full(15, -0.32)))
    unseen = np.vstack(([-0.25, 0.0], side))
    params = LocalParams(max_vel_x=0.4, unseen_clearance=0.3, rotate_in_place_above=math.pi)
    path = np.array([[0.0, 0.0], [0.6, -0.1], [1.2, -0.6]])
    command = compute_command(np.zeros(3), (0.0, 0.0), path, np.array([1.2, -0.6, -0.7]), np.zeros((0, 2)), params,
                              unseen=unseen)
    arc = rollout(0.0, 0.0, np.array([command.v]), np.array([command.w]), params)[0, :, :2]
    assert command.ok
    assert np.hypot(arc[:, None, 0] - side[None, :, 0], arc[:, None, 1] - side[None, :, 1]).min() > 0.3 - 1e-3
