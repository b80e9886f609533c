"""The local planner's margin from what is not on the map (dynamic_padding): kept when driving, never a trap,
and no backing up into the laser's blind spot with someone near."""
from __future__ import annotations

import numpy as np

from navigation.local_planner import LocalParams, compute_command
from navigation.moving_obstacles import MovingObstacles


def ahead_of_a_person(padding: float):
    """A robot at the origin facing +x, a plan straight ahead, a person's near surface 0.42 m ahead."""
    path = np.array([[0.0, 0.0], [3.0, 0.0]])
    person = np.array([[0.42, dy] for dy in np.linspace(-0.1, 0.1, 5)])
    params = LocalParams(dynamic_padding=padding)
    return compute_command(np.zeros(3), (0.0, 0.0), path, np.array([3.0, 0.0, 0.0]), person, params,
                           dynamic=person if padding > 0 else None)


def test_the_padding_keeps_the_robot_further_from_a_person_than_from_a_wall():
    near_wall = ahead_of_a_person(0.0)
    assert near_wall.ok and near_wall.v > 0.05  # 0.42 m leaves room for the 0.22 m safety radius
    padded = ahead_of_a_person(0.25)
    # with 0.25 m more: nothing that gets closer to the person is admissible: it stops or turns away
    assert padded.ok and padded.v <= 0.05 or abs(padded.w) > 0.3


def test_a_robot_someone_walked_up_to_can_still_get_away_but_not_backwards():
    path = np.array([[0.0, 0.0], [-3.0, 0.0]])  # the plan goes behind the robot
    person = np.array([[0.3, dy] for dy in np.linspace(-0.1, 0.1, 5)])  # within safe + padding already
    command = compute_command(np.zeros(3), (0.0, 0.0), path, np.array([-3.0, 0.0, np.pi]), person,
                              LocalParams(dynamic_padding=0.2, rotate_in_place_above=10.0), dynamic=person)
    assert command.ok
    assert command.v >= 0.0  # never backwards with someone this near


def test_a_robot_someone_stands_against_is_not_trapped():
    """A walker waits when the robot is in its way: a robot refusing every arc because the person is already
    within its safety radius would wait too, for ever."""
    path = np.array([[0.0, 0.0], [-3.0, 0.0]])
    person = np.array([[0.2, dy] for dy in np.linspace(-0.1, 0.1, 5)])  # 0.2 m from the centre: inside 0.22
    command = compute_command(np.zeros(3), (0.0, 0.0), path, np.array([-3.0, 0.0, np.pi]), person,
                              LocalParams(dynamic_padding=0.1), dynamic=person)
    assert command.ok and (abs(command.w) > 0.1 or command.v < 0)


def near_the_goal(offset: float):
    """A robot facing +x, the goal `offset` m straight ahead, a standing person's near side 0.12 m beyond it."""
    goal = np.array([offset, 0.0, 0.0])
    person = np.array([[offset + 0.12 + 0.03 * dy * dy, dy] for dy in np.linspace(-0.15, 0.15, 7)])
    return compute_command(np.zeros(3), (0.0, 0.0), np.array([[0.0, 0.0], goal[:2]]), goal, person,
                           LocalParams(dynamic_padding=0.1), dynamic=person)


def test_within_the_tolerance_with_someone_at_the_goal_the_position_counts_as_reached():
    """Within xy_goal_tolerance but not half of it, the last few cm would take it nearer a person: latched
    (it turns to the goal's heading), not left to the sampler, which found nothing and was stuck."""
    command = near_the_goal(0.07)
    assert command.ok and command.latched and command.v == 0.0


def test_the_last_stretch_creeps_where_a_walker_coming_cannot_be_kept_clear_of():
    """0.3 m from the goal, a walker 0.8 m to the side coming across at 0.8 m/s: even braking cannot keep clear
    of her predicted path, so the approach creeps (creep_vel_x), as the sampler may, instead of being refused
    every time she comes by (a goal beside her beat was never reached)."""
    goal = np.array([0.3, 0.0, 0.0])
    person = np.array([[0.3 + 0.2 * np.cos(a), 0.8 + 0.2 * np.sin(a)] for a in np.linspace(-2.5, -0.6, 7)])
    moving = MovingObstacles(person, np.tile([0.0, -0.8], (len(person), 1)))
    command = compute_command(np.zeros(3), (0.0, 0.0), np.array([[0.0, 0.0], goal[:2]]), goal, person,
                              LocalParams(dynamic_padding=0.1, creep_vel_x=0.1), dynamic=person, moving=moving)
    assert command.ok and command.why == "approaching the goal" and 0.0 < command.v <= 0.1 + 1e-9


def _gap_to_square(points: np.ndarray, centre: np.ndarray, half: float) -> float:
    """Least distance from `points` (n, 2) to the axis-aligned square of half side `half` at `centre`."""
    d = np.maximum(np.abs(points - centre) - half, 0.0)
    return float(np.hypot(*d.T).min())


def test_a_map_cell_is_kept_off_as_a_square_not_as_its_centre():
    """Two box corners (5 cm cells) either side of the plan, their centres 0.47 m apart: kept off as their centres
    (0.22 m of radius and padding each) the gap looks wide enough and the robot drives through with its rim 0.02 m
    from each cell, as frontier exploration's depth robot touched boxes; kept off as the cells' corners
    (move_base's cell_corners) no arc comes nearer than the padding to either cell."""
    from navigation.local_planner import rollout
    from navigation.move_base import cell_corners

    res, p = 0.05, LocalParams()
    origin = (0.0, 0.01)  # cell (4, 10)'s centre at (0.525, 0.235); its mirror image across the plan
    centres = np.array([[0.525, 0.235], [0.525, -0.235]])
    one = cell_corners(np.ones((1, 1), dtype=bool), 4, 10, origin, res)
    assert np.allclose(one.mean(axis=0), centres[0])
    corners = np.concatenate([one, one * [1, -1]])
    path = np.array([[0.0, 0.0], [3.0, 0.0]])
    goal = np.array([3.0, 0.0, 0.0])
    gaps = {}
    for name, obstacles in (("centres", centres), ("corners", corners)):
        cmd = compute_command(np.zeros(3), (0.3, 0.0), path, goal, obstacles, p)
        arc = rollout(0.3, 0.0, np.array([cmd.v]), np.array([cmd.w]), p)[0, :, :2]
        gaps[name] = min(_gap_to_square(arc, c, res / 2) for c in centres) - p.robot_radius
    assert gaps["centres"] < p.footprint_padding - 0.009  # the rim passes 3 cm from each cell (face and corner)
    assert gaps["corners"] >= p.footprint_padding - 1e-6


def test_two_cells_side_by_side_share_their_corners_and_a_block_keeps_only_its_rim():
    from navigation.move_base import cell_corners

    corners = cell_corners(np.array([[False, True, True]]), 0, -1, (1.0, 2.0), 0.1)
    assert len(corners) == 6
    assert np.allclose(sorted(map(tuple, corners.round(6))),
                       sorted([(1.0, 2.0), (1.1, 2.0), (1.2, 2.0), (1.0, 2.1), (1.1, 2.1), (1.2, 2.1)]))
    block = np.zeros((5, 5), dtype=bool)
    block[1:4, 1:4] = True  # a 3 x 3 block: 16 corners, the 4 inside it dropped
    rim = cell_corners(block, 10, 20, (0.0, 0.0), 1.0)
    assert len(rim) == 12
    assert not any(21 < x < 24 and 11 < y < 14 for x, y in rim)
