"""navigation.global_search: the robot's recent scans searched over a whole map and every heading; an unambiguous
fit is the pose, a place that looks the same elsewhere is none."""
from __future__ import annotations

import math

import numpy as np

from navigation.global_search import GlobalSearch, GlobalSearchParams
from subsim.mapio import GridMap
from subsim.raycast import cast_rays
from subsumption.mapfile import OccupancyMap
from subsumption.planar import compose, wrap

RES = 0.05


def room(inner_walls: bool) -> GridMap:
    """A 10 x 15 m room; with `inner_walls`, a wall half across it and a box, which no turn or shift repeats."""
    occupancy = np.zeros((300, 200), np.int8)
    occupancy[:3, :] = occupancy[-3:, :] = 100
    occupancy[:, :3] = occupancy[:, -3:] = 100
    if inner_walls:
        occupancy[148:152, :120] = 100       # a wall from the west side, 6 m long, at y = 7.5
        occupancy[40:70, 140:160] = 100      # a 1 x 1.5 m box in the south-east
    return GridMap(occupancy, RES, (0.0, 0.0), "room.yaml")


def hits_from(grid: GridMap, pose: np.ndarray) -> np.ndarray:
    """A 180-degree, 181-beam laser's hits (base frame) at `pose`, 10 m range."""
    angles = np.linspace(-math.pi / 2, math.pi / 2, 181)
    n = len(angles)
    ranges = cast_rays(grid.solid, grid.wall_distance, 0.0, 0.0, RES, np.full(n, pose[0]), np.full(n, pose[1]),
                       angles + pose[2], np.full(n, 10.0), np.zeros((0, 3)))
    ok = np.isfinite(ranges)
    return np.column_stack([ranges[ok] * np.cos(angles[ok]), ranges[ok] * np.sin(angles[ok])])


def drive(grid: GridMap, search: GlobalSearch, start: np.ndarray, steps: int):
    """Drive 0.5 m at a time from `start`; odometry in a frame of its own (turned and shifted from the map's)."""
    odom_origin = np.array([-3.0, 7.0, 1.0])
    pose = start.copy()
    for step in range(steps):
        found = search.add(float(step), compose(odom_origin, pose), hits_from(grid, pose))
        if found is not None:
            return found, pose
        pose = compose(pose, np.array([0.5, 0.0, 0.05]))
    return None, pose


def test_the_pose_is_found_anywhere_on_the_map_at_any_heading():
    grid = room(inner_walls=True)
    for start in (np.array([2.0, 3.0, 0.3]), np.array([7.5, 11.0, -2.5]), np.array([4.0, 5.5, -1.0])):
        search = GlobalSearch(grid)
        found, truth = drive(grid, search, start, 8)
        assert found is not None, (start, search.last)
        assert math.hypot(*(found.pose[:2] - truth[:2])) <= 0.15, (found.pose, truth)
        assert abs(float(wrap(found.pose[2] - truth[2]))) <= math.radians(3.0), (found.pose, truth)


def test_a_room_that_looks_the_same_turned_round_gives_no_pose():
    """A plain rectangle looks the same from the pose turned 180 degrees about its centre: the search sees the rival
    and says nothing, however long it drives."""
    grid = room(inner_walls=False)
    search = GlobalSearch(grid, GlobalSearchParams(attempt_every=0.5))
    found, _ = drive(grid, search, np.array([3.0, 4.0, 0.2]), 6)
    assert found is None and search.attempts >= 4
    assert search.last is not None and search.last.rival > 0


def test_a_map_without_walls_is_refused_by_name():
    empty = OccupancyMap(np.zeros((20, 20), np.int8), RES, (0.0, 0.0), "empty.yaml")
    try:
        GlobalSearch(empty)
    except ValueError as error:
        assert "empty.yaml" in str(error)
    else:
        raise AssertionError("a map without walls was taken")


def test_a_score_floor_prunes_without_changing_the_best_pose():
    """The branch and bound's `floor` (the score below which no pose is taken) leaves the best pose, its score, its
    covariance and its rival as they were when a pose scores above it; with nothing above it, the search says so
    (score 0) instead of naming a poor pose."""
    from navigation.slam_correlative import LikelihoodField, search

    grid = room(inner_walls=True)
    truth = np.array([4.0, 5.5, -1.0])
    points = hits_from(grid, truth)
    rows, cols = np.nonzero(grid.solid)
    field = LikelihoodField.of(np.column_stack([cols, rows]) * RES + RES / 2, RES, 0.05)
    guess = truth + np.array([0.3, -0.2, 0.1])
    plain = search(points, field, guess, 1.0, 0.3, apart=2.0)
    floored = search(points, field, guess, 1.0, 0.3, apart=2.0, floor=0.5)
    assert plain.score > 0.5
    assert np.array_equal(floored.pose, plain.pose) and floored.score == plain.score
    assert np.array_equal(floored.covariance, plain.covariance) and floored.rival == plain.rival
    none = search(points, field, guess, 1.0, 0.3, floor=plain.score + 0.01)
    assert none.score == 0.0 and np.array_equal(none.pose, guess)


def test_the_level_above_the_coarse_one_changes_no_result():
    """With a floor, the search first scores blocks of 3 x 3 coarse blocks on a field dilated over them, and scores
    the coarse level only under the blocks that can still beat the floor: the same pose, score, covariance and
    rival as the coarse level everywhere, from near and far guesses, with and without a pose above the floor."""
    from dataclasses import replace

    from navigation.slam_correlative import LikelihoodField, search

    grid = room(inner_walls=True)
    rows, cols = np.nonzero(grid.solid)
    field = LikelihoodField.of(np.column_stack([cols, rows]) * RES + RES / 2, RES, 0.05)
    without_top = replace(field, top=None)
    rng = np.random.default_rng(3)
    found = 0
    for truth in (np.array([4.0, 5.5, -1.0]), np.array([2.0, 3.0, 0.3]), np.array([7.5, 11.0, -2.5])):
        points = hits_from(grid, truth)
        for _ in range(3):
            guess = truth + rng.uniform([-1.5, -1.5, -0.3], [1.5, 1.5, 0.3])
            for floor in (0.5, 0.9):
                fast = search(points, field, guess, 2.0, 0.4, apart=2.0, floor=floor)
                plain = search(points, without_top, guess, 2.0, 0.4, apart=2.0, floor=floor)
                assert np.array_equal(fast.pose, plain.pose) and fast.score == plain.score
                assert np.array_equal(fast.covariance, plain.covariance) and fast.rival == plain.rival
                found += fast.score > 0
    assert 0 < found < 18  # some searches found a pose above the floor, some did not


def test_the_branch_and_bound_finds_the_best_pose_of_the_whole_window():
    """The search scores few of the window's poses; the best it finds is the best of all of them: every pose of the
    window (each angle step, each cell offset the coarse blocks cover) scored here one by one, by the field's mean
    value under the scan's points (0 outside it), as the search defines the score."""
    from navigation.slam_correlative import LikelihoodField, angular_step, search

    grid = room(inner_walls=True)
    rows, cols = np.nonzero(grid.solid)
    lf = LikelihoodField.of(np.column_stack([cols, rows]) * RES + RES / 2, RES, 0.05)
    truth = np.array([4.0, 5.5, -1.0])
    points = hits_from(grid, truth)[::3]
    guess = truth + np.array([0.23, -0.17, 0.04])
    window_xy, window_theta = 0.4, 0.08
    found = search(points, lf, guess, window_xy, window_theta)

    k = lf.coarse_cells
    block = 2 * k + 1
    reach = (math.ceil(max(math.ceil(window_xy / RES) - k, 0) / block)) * block + k
    step = angular_step(points, RES)
    n_theta = math.ceil(window_theta / step)
    best, best_pose = -1.0, None
    for theta in guess[2] + step * np.arange(-n_theta, n_theta + 1):
        c, s = math.cos(theta), math.sin(theta)
        wx = guess[0] + c * points[:, 0] - s * points[:, 1]
        wy = guess[1] + s * points[:, 0] + c * points[:, 1]
        col0 = np.floor((wx - lf.origin[0]) / RES).astype(int)
        row0 = np.floor((wy - lf.origin[1]) / RES).astype(int)
        for dx in range(-reach, reach + 1):
            for dy in range(-reach, reach + 1):
                col, row = col0 + dx, row0 + dy
                inside = (row >= 0) & (row < lf.field.shape[0]) & (col >= 0) & (col < lf.field.shape[1])
                score = lf.field[row[inside], col[inside]].astype(float).sum() / len(points)
                if score > best:
                    best, best_pose = score, np.array([guess[0] + dx * RES, guess[1] + dy * RES, theta])
    assert math.isclose(found.score, best, rel_tol=1e-9), (found.score, best)
    assert np.allclose(found.pose, best_pose), (found.pose, best_pose)
    assert math.hypot(*(found.pose[:2] - truth[:2])) <= 0.1  # the truth, to within the window's steps
