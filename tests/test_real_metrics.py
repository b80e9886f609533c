"""The real-data scores on made-up trajectories and maps: a map that is right but turned as a whole scores badly
unaligned and perfectly aligned, and the alignment found is the turn that was applied; a map that is wrong in
shape stays wrong aligned."""
from __future__ import annotations

import math

import numpy as np

from navigation.real_metrics import ate, ate_aligned, rigid_alignment, wall_gaps, walls_within
from subsumption.mapfile import OCCUPIED, OccupancyMap
from subsumption.planar import transform_points


def square_walk() -> np.ndarray:
    """(x, y, yaw) along a 10 m x 6 m rectangle, every 0.5 m."""
    corners = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 6.0], [0.0, 6.0], [0.0, 0.0]])
    points = np.concatenate([np.linspace(a, b, 20, endpoint=False) for a, b in zip(corners[:-1], corners[1:])])
    yaw = np.arctan2(*np.diff(points, axis=0, append=points[:1]).T[::-1])
    return np.column_stack((points, yaw))


def test_a_trajectory_turned_as_a_whole_is_wrong_unaligned_and_right_aligned():
    reference = square_walk()
    turn = np.array([0.0, 0.0, math.radians(9.0)])
    turned = np.column_stack((transform_points(turn, reference[:, :2]), reference[:, 2]))
    assert ate(turned, reference) > 0.4
    error, motion = ate_aligned(turned, reference)
    assert error < 1e-9
    assert abs(math.degrees(motion[2]) + 9.0) < 1e-9  # the turn that undoes it
    shape_wrong = reference.copy()
    shape_wrong[20:40, 1] += 0.3  # one side drawn 0.3 m off: alignment cannot take that out
    assert ate_aligned(shape_wrong, reference)[0] > 0.1


def test_rigid_alignment_undoes_a_turn_and_shift():
    points = np.random.default_rng(1).uniform(-5, 5, (50, 2))
    motion = np.array([1.5, -2.0, 0.7])
    found = rigid_alignment(points, transform_points(motion, points))
    assert np.allclose(found, motion)


def test_walls_are_compared_after_the_alignment():
    occ = np.zeros((120, 120), np.int8)
    occ[20, 20:100] = OCCUPIED  # a wall 4 m long
    reference = OccupancyMap(occ, 0.05, (0.0, 0.0))
    assert walls_within(reference, reference, motion=np.zeros(3)) == 1.0
    # the built map is the reference turned by 10 degrees about (1, 1): moved back by the inverse, it fits again
    turn = math.radians(10.0)
    rows, cols = np.nonzero(occ == OCCUPIED)
    centres = np.column_stack(((cols + 0.5) * 0.05, (rows + 0.5) * 0.05))
    pivot = np.array([1.0, 1.0])
    turned = transform_points(np.array([0.0, 0.0, turn]), centres - pivot) + pivot
    built_occ = np.zeros_like(occ)
    r = np.floor(turned[:, 1] / 0.05).astype(int)
    c = np.floor(turned[:, 0] / 0.05).astype(int)
    built_occ[r, c] = OCCUPIED
    built = OccupancyMap(built_occ, 0.05, (0.0, 0.0))
    assert walls_within(built, reference, motion=np.zeros(3)) < 0.3
    assert walls_within(built, reference) == walls_within(built, reference, motion=np.zeros(3))  # None: as it is
    back = rigid_alignment(turned, centres)
    assert walls_within(built, reference, motion=back) == 1.0


def test_walls_within_counts_a_built_wall_up_to_the_distance_and_no_farther():
    """A reference wall and a built one 0.1 m beside it (two cells): within 0.1 m, not within 0.05 m; a built
    map with no wall scores 0, a reference with none is NaN."""
    ref_occ = np.zeros((40, 40), np.int8)
    ref_occ[10, 5:35] = OCCUPIED
    built_occ = np.zeros_like(ref_occ)
    built_occ[12, 5:35] = OCCUPIED
    reference, built = OccupancyMap(ref_occ, 0.05, (0.0, 0.0)), OccupancyMap(built_occ, 0.05, (0.0, 0.0))
    assert walls_within(built, reference, 0.1) == 1.0
    assert walls_within(built, reference, 0.05) == 0.0
    assert walls_within(OccupancyMap(np.zeros_like(ref_occ), 0.05, (0.0, 0.0)), reference) == 0.0
    assert math.isnan(walls_within(built, OccupancyMap(np.zeros_like(ref_occ), 0.05, (0.0, 0.0))))


def test_wall_gaps_say_where_the_built_walls_are_off_and_by_how_much():
    """A reference wall 1.5 m long; the built one lies on its first third and 0.3 m beside its last third: there
    the gaps are 0 and 0.3 m; a built map without walls leaves every gap infinite."""
    ref_occ = np.zeros((40, 40), np.int8)
    ref_occ[10, 5:35] = OCCUPIED
    built_occ = np.zeros_like(ref_occ)
    built_occ[10, 5:15] = OCCUPIED
    built_occ[16, 25:35] = OCCUPIED
    reference, built = OccupancyMap(ref_occ, 0.05, (0.0, 0.0)), OccupancyMap(built_occ, 0.05, (0.0, 0.0))
    gaps = wall_gaps(built, reference)
    rows, cols = np.nonzero(ref_occ == OCCUPIED)  # the order of the answer
    assert gaps.shape == (30,) and np.all(rows == 10)
    first, last = cols < 15, cols >= 25
    assert first.sum() == last.sum() == 10
    assert np.allclose(gaps[first], 0.0) and np.allclose(gaps[last], 0.3)
    assert walls_within(built, reference, 0.1) == np.mean(gaps <= 0.1 + 1e-6)
    none = wall_gaps(OccupancyMap(np.zeros_like(ref_occ), 0.05, (0.0, 0.0)), reference)
    assert np.all(np.isinf(none))
