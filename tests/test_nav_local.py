"""The local planner's margin from what is not on the map (dynamic_padding): kept when driving, never a trap,
and no backing up into the laser's blind spot with someone near."""
from __future__ import annotations

import numpy as np

from navigation.local_planner import LocalParams, compute_command


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
