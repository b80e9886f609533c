"""Ground seen free lately (navigation.seen_space) and the local planner's rule to drive only onto it: a robot that
stood facing one way does not turn and drive into the side it has not looked at (where a person may have come)."""
from __future__ import annotations

import math

import numpy as np

from navigation.local_planner import LocalParams, compute_command
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
