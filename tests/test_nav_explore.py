"""Frontier exploration: which frontiers count (reachable, wide enough, not blacklisted), where the goal is put
and which way it faces; the look-around's full turn on the spot; and a real exploration of a small world (SLAM,
move_base and explore in-process) that stops by itself with the reachable space mapped."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from navigation.explore import FrontierParams, find_frontiers, frontier_cells, goal_clear
from subsumption.mapfile import OccupancyMap


def known_room() -> np.ndarray:
    """A 4 x 3 m room, all known and walled, in unknown surroundings (5 cm cells; the room's inside spans
    x and y 0.3 m on from the grid's corner; row 0 at y = 0)."""
    occ = np.full((70, 130), -1, dtype=np.int8)
    occ[5:65, 5:85] = 100
    occ[6:64, 6:84] = 0
    return occ


def test_a_closed_known_room_has_no_frontier():
    grid = OccupancyMap(known_room(), 0.05, (0.0, 0.0))
    assert not frontier_cells(grid).any()
    assert find_frontiers(grid, (1.0, 1.0)) == []


def test_a_doorway_into_unknown_space_is_a_frontier_with_a_goal_facing_it():
    occ = known_room()
    occ[25:45, 84] = 0  # a 1 m doorway in the east wall, x = 4.2-4.25, y = 1.25-2.25; beyond it unknown
    grid = OccupancyMap(occ, 0.05, (0.0, 0.0))
    found = find_frontiers(grid, (1.0, 1.5))
    assert len(found) == 1
    goal = found[0].goal
    assert goal[0] == pytest.approx(4.225, abs=0.03) and 1.45 <= goal[1] <= 2.05
    assert abs(goal[2]) < 0.3  # facing east, into the unknown
    assert found[0].distance_m == pytest.approx(math.hypot(goal[0] - 1.0, goal[1] - 1.5), rel=0.1)


def test_a_gap_narrower_than_the_robot_is_not_a_reachable_frontier_and_blacklisting_removes_one():
    occ = known_room()
    occ[33:37, 84] = 0  # 0.2 m: the robot (0.36 m wide) cannot go there
    grid = OccupancyMap(occ, 0.05, (0.0, 0.0))
    assert frontier_cells(grid).any()
    assert find_frontiers(grid, (1.0, 1.5)) == []
    occ = known_room()
    occ[25:45, 84] = 0
    grid = OccupancyMap(occ, 0.05, (0.0, 0.0))
    assert find_frontiers(grid, (1.0, 1.5), blacklist=[(4.225, 1.75, 0.6)]) == []


def test_the_cheaper_frontier_comes_first_and_short_ones_are_noise():
    occ = known_room()
    occ[25:45, 84] = 0   # east doorway, 3 m away
    occ[5, 15:35] = 0    # south doorway near the robot, x 0.75-1.75
    occ[5, 50:52] = 0    # a 0.1 m slit: shorter than min_frontier_size
    grid = OccupancyMap(occ, 0.05, (0.0, 0.0))
    found = find_frontiers(grid, (1.0, 1.5), FrontierParams(min_frontier_size=0.3))
    assert len(found) == 2  # the slit is not one (and it is too narrow to reach anyway)
    assert found[0].goal[1] < 0.3 and abs(found[0].goal[2] + math.pi / 2) < 0.3  # the south one, facing south


def test_a_goal_is_clear_until_the_map_shows_something_within_the_clearance():
    """A frontier goal chosen on an older map is replaced once the map shows an obstacle (a box's corner) within
    the clearance every new goal keeps: find_frontiers would not choose it now."""
    occ = known_room()
    occ[25:45, 84] = 0
    grid = OccupancyMap(occ.copy(), 0.05, (0.0, 0.0))
    goal = find_frontiers(grid, (1.0, 1.5))[0].goal
    clearance = FrontierParams().robot_radius + FrontierParams().goal_clearance
    assert goal_clear(grid, (goal[0], goal[1]), clearance)
    row, col = grid.cell_of(goal[0], goal[1])
    occ[row + 4, col - 3] = 100  # a box's corner 0.25 m from the goal
    later = OccupancyMap(occ, 0.05, (0.0, 0.0))
    assert not goal_clear(later, (goal[0], goal[1]), clearance)
    assert all(np.hypot(*(f.goal[:2] - goal[:2])) > 0.01 for f in find_frontiers(later, (1.0, 1.5)))
    assert goal_clear(later, (goal[0], goal[1]), 0.2)  # 0.25 m is clear of a smaller clearance
    assert goal_clear(later, (-5.0, -5.0), clearance)  # off the grid: nothing known there


def test_a_narrow_scan_makes_move_base_remember_its_hits_and_drive_only_on_ground_seen(tmp_path: Path):
    from experiments.mapping import move_base_params, prepare_world

    depth, _ = prepare_world(two_rooms(tmp_path), tmp_path / "depth", "depth", 0.02)
    laser, _ = prepare_world(two_rooms(tmp_path), tmp_path / "laser", "laser", 0.02)
    params = move_base_params(depth)
    assert params["hit_memory"] > 0 and params["seen_keep"] > 0 and params["seen_reach"] == pytest.approx(0.75)
    assert params["map_cell_corners"] is True
    assert move_base_params(laser) == {}


def two_rooms(folder: Path) -> Path:
    """A world of two 2.5 x 3 m rooms joined by a 0.8 m door (x = 2.5 m, y = 2.0-2.8), the robot at (0.8, 0.8)
    facing east, 2% odometry noise."""
    from subsumption.mapfile import save_map

    occ = np.zeros((60, 100), dtype=np.int8)           # 5 x 3 m
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[:, 50] = 100                                    # a wall at x = 2.5 m ...
    occ[40:56, 50] = 0                                  # ... with a 0.8 m door at y = 2.0-2.8
    save_map(OccupancyMap(occ, 0.05, (0.0, 0.0)), folder / "two.yaml", 0.05)
    world = folder / "two_world.yaml"
    world.write_text(yaml.safe_dump({"map": str(folder / "two.yaml"), "robots": [
        {"name": "robot0", "namespace": "", "start": [0.8, 0.8, 0.0], "odom_noise": 0.02}]}))
    return world


def test_look_around_turns_a_full_circle_in_place_before_the_first_frontier_goal(tmp_path: Path):
    """With ``look_around`` the robot turns once round on the spot, one way, before it drives off to a frontier.
    Measured on the true pose (scoring only)."""
    from experiments.mapping import run_local

    recorder, _, _ = run_local(two_rooms(tmp_path), [0.8, 0.8, 0.0], 12.0, 1, "frontier",
                               explore_params={"look_around": True})
    poses = np.array([recorder.truth[t] for t in sorted(recorder.truth)])
    moved = np.hypot(poses[:, 0] - 0.8, poses[:, 1] - 0.8) > 0.1
    assert moved.any()  # it drove off to a frontier within 12 s
    turns = np.diff(np.unwrap(poses[: int(np.argmax(moved)), 2]))
    assert turns.sum() >= 2 * math.pi - 0.2 and turns[turns < 0].sum() > -0.1  # once round, one way


def test_frontier_exploration_maps_a_small_world_and_stops_by_itself(tmp_path: Path):
    """Two rooms joined by a doorway, the robot starting in the one whose door it cannot see through
    at first; exploration must drive through and say done with every reachable cell known."""
    from experiments.mapping import run_local, score

    world = two_rooms(tmp_path)
    recorder, _, _ = run_local(world, [0.8, 0.8, 0.0], 240.0, 1, "frontier")
    assert recorder.explore_finished
    result = score(recorder, world, 1.0)
    assert result.metrics["collisions"] == 0
    built = result.built
    for x, y in ((4.5, 0.5), (4.5, 2.5), (3.7, 1.5)):  # the far room's corners and middle are known free
        r, c = built.cell_of(x, y)
        assert built.occupancy[r, c] == 0, (x, y)


def test_a_world_with_pictures_is_copied_for_mapping_with_its_files_found(tmp_path: Path):
    """`subsumption map` runs on a copy of the world file in its output folder: the ping-pong world's target
    wears a picture (a PNG beside the world file) that the copy must still find (it said "no such picture file")."""
    from experiments.mapping import prepare_world
    from subsim import world_path
    from subsim.world import load_world

    copy, start = prepare_world(world_path("pingpong"), tmp_path / "out", "depth", 0.02)
    assert copy.parent == tmp_path / "out" and len(start) == 3
    world = load_world(copy)
    assert any(agent.picture is not None and Path(agent.picture.file).is_file() for agent in world.agents)
