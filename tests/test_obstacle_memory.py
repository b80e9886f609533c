"""navigation.obstacle_memory: a hit off the map stays while the narrow scan cannot see its place, and goes
when a beam reaches it (or when it is old)."""
from __future__ import annotations

import math

import numpy as np

from navigation.obstacle_memory import ObstacleMemory
from navigation.scan_geometry import Beams


def scan(ranges: float, hit: bool = False) -> Beams:
    """A 57-degree scan from the robot's centre, every beam ending at `ranges`."""
    angles = np.linspace(-math.radians(28.5), math.radians(28.5), 60)
    return Beams(np.zeros(2), angles, np.full(60, ranges), np.full(60, hit))


def test_a_person_out_of_view_is_remembered_until_a_beam_reaches_her_place():
    memory = ObstacleMemory(keep=5.0, reach=3.0)
    person = np.array([[1.0, 0.0]])  # 1 m ahead, base frame
    assert len(memory.update(0.0, np.zeros(3), scan(1.0, True), 0.45, person)) == 0  # seen now: not "remembered"
    # the robot turned 90 degrees left: she is on its right, out of the 57-degree view
    kept = memory.update(1.0, np.array([0.0, 0.0, math.pi / 2]), scan(4.0), 0.45, np.zeros((0, 2)))
    assert kept.shape == (1, 2) and np.allclose(kept[0], [0.0, -1.0], atol=1e-9)
    # nearer than the camera's minimum range, straight ahead: still unseen, still remembered
    kept = memory.update(2.0, np.array([0.7, 0.0, 0.0]), scan(4.0), 0.45, np.zeros((0, 2)))
    assert np.allclose(kept, [[0.3, 0.0]])
    # back where it was, facing her place: the beams reach 4 m, nothing there now: cleared
    assert len(memory.update(3.0, np.zeros(3), scan(4.0), 0.45, np.zeros((0, 2)))) == 0
    assert len(memory.points) == 0


def test_remembered_points_are_forgotten_after_keep_seconds_or_far_away():
    memory = ObstacleMemory(keep=5.0, reach=3.0)
    memory.update(0.0, np.zeros(3), scan(1.0, True), 0.45, np.array([[1.0, 0.0]]))
    away = np.array([0.0, 0.0, math.pi])  # facing away: out of view
    assert len(memory.update(4.9, away, scan(4.0), 0.45, np.zeros((0, 2)))) == 1
    assert len(memory.update(5.1, away, scan(4.0), 0.45, np.zeros((0, 2)))) == 0
    memory.update(6.0, np.zeros(3), scan(1.0, True), 0.45, np.array([[1.0, 0.0]]))
    assert len(memory.update(6.5, np.array([-2.5, 0.0, math.pi]), scan(4.0), 0.45, np.zeros((0, 2)))) == 0


def test_a_cell_keeps_one_point_the_newest():
    """A wall leaving the view scan after scan is remembered once per cell, not once per scan."""
    memory = ObstacleMemory(keep=30.0, reach=3.0, cell=0.05)
    away = np.array([0.0, 0.0, math.pi])  # facing away: the wall (1 m ahead of the start pose) is out of view
    for k in range(5):  # the same wall point, seen five times with a centimetre of noise
        memory.update(float(k), away, scan(4.0), 0.45, np.array([[-1.0 - 0.004 * k, 0.0], [-1.0, 0.5]]))
    assert len(memory.points) == 2
    assert sorted(memory.seen.tolist()) == [4.0, 4.0]
    assert np.allclose(memory.points[np.argmax(memory.points[:, 1])], [1.016, 0.0])
    # without thinning every sighting stays
    plain = ObstacleMemory(keep=30.0, reach=3.0)
    for k in range(5):
        plain.update(float(k), away, scan(4.0), 0.45, np.array([[-1.0 - 0.004 * k, 0.0], [-1.0, 0.5]]))
    assert len(plain.points) == 10
