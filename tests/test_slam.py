"""The map builder: its pieces (REP 117 scans, the hit/visit grid, normals) and a small room mapped within the
targets, on a shipped world and on a generated map it was not tuned on."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from sensor_msgs.msg import LaserScan

import subsim
from experiments.mapping import prepare_world, run_local, score
from navigation.scan_geometry import Beams, beams_of
from navigation.slam_grid import CountGrid
from navigation.slam_match import scan_normals
from subsim.maps.generate import sparse
from subsim.mapio import load_map, save_map
from subsumption.mapfile import FREE, OCCUPIED, UNKNOWN

ROOT = Path(__file__).resolve().parent.parent


def scan(ranges, range_min=0.1, range_max=4.0) -> LaserScan:
    n = len(ranges)
    return LaserScan(angle_min=-0.5, angle_max=0.5, angle_increment=1.0 / (n - 1), range_min=range_min,
                     range_max=range_max, ranges=list(ranges))


def test_scans_are_read_per_rep_117():
    beams = beams_of(scan([1.0, math.inf, -math.inf, math.nan, 0.05, 2.0]), max_usable_range=1.5)
    # -inf, NaN and too-close readings carry no geometry: dropped
    assert len(beams.ranges) == 3
    # +inf: free up to range_max (here cut at maxUrange); 2.0 is beyond maxUrange: free space, not a hit
    assert beams.hit.tolist() == [True, False, False]
    assert beams.ranges.tolist() == [1.0, 1.5, 1.5]


def test_mounting_turns_beams_into_the_robot_frame():
    mounted = beams_of(scan([1.0, 1.0, 1.0]), (np.array([0.1, 0.0, math.pi / 2]), False))
    assert np.allclose(mounted.angles, [-0.5 + math.pi / 2, math.pi / 2, 0.5 + math.pi / 2])
    assert np.allclose(mounted.endpoints()[1], [0.1, 1.0])
    flipped = beams_of(scan([1.0, 1.0, 1.0]), (np.zeros(3), True))  # upside down: mirrored
    assert np.allclose(flipped.angles, [0.5, 0.0, -0.5])


def test_a_drawn_scan_can_be_taken_back_out_exactly():
    grid = CountGrid(0.05)
    beams = Beams(np.zeros(2), np.linspace(-1, 1, 50), np.full(50, 2.0), np.ones(50, dtype=bool))
    grid.integrate(np.array([1.0, 1.0, 0.3]), beams)
    occupancy = grid.occupancy()
    assert (occupancy == OCCUPIED).sum() > 10 and (occupancy == FREE).sum() > 200
    grid.integrate(np.array([1.0, 1.0, 0.3]), beams, -1.0)
    assert np.all(grid.occupancy() == UNKNOWN)
    assert grid.origin[0] / 0.05 == pytest.approx(round(grid.origin[0] / 0.05))  # cells line up with 0


def test_normals_of_a_wall_are_perpendicular_to_it():
    points = np.column_stack((np.full(20, 2.0), np.linspace(-1, 1, 20)))  # the wall x = 2
    normals = scan_normals(points, 3, 0.3)
    assert np.allclose(np.abs(normals[:, 0]), 1.0) and np.allclose(normals[:, 1], 0.0, atol=1e-9)


def test_normals_face_the_sensor():
    """The side of a wall that was seen: a wall at x = 2 seen from the origin has normals (-1, 0), one at x = -2
    normals (1, 0), whichever way the fit's eigenvector came out."""
    wall = np.column_stack((np.full(20, 2.0), np.linspace(-1, 1, 20)))
    assert np.allclose(scan_normals(wall, 3, 0.3), [-1.0, 0.0], atol=1e-9)
    assert np.allclose(scan_normals(-wall, 3, 0.3), [1.0, 0.0], atol=1e-9)


def test_a_far_wall_has_normals_only_with_a_radius_growing_with_range():
    """A wall 10 m away seen with beams 1 degree apart: its hits lie 17-20 cm apart, beyond the fixed 0.15 m, so
    they get no normal (tracking cannot use the wall); with normal_radius_growth 0.1 (1 m there) they do."""
    angles = np.radians(np.arange(-30.0, 31.0))
    points = np.column_stack((np.full(len(angles), 10.0), 10.0 * np.tan(angles)))  # the wall x = 10
    assert np.isnan(scan_normals(points, 3, 0.15)).all()
    grown = scan_normals(points, 3, 0.15, 0.1)
    assert np.allclose(np.abs(grown[:, 0]), 1.0) and np.allclose(grown[:, 1], 0.0, atol=1e-9)


def _map_and_score(world: Path, out: Path, duration: float, sensor: str | None):
    prepared, start = prepare_world(world, out, sensor, 0.02)
    recorder, wall, slam = run_local(prepared, start, duration, seed=3, explore="wander")
    return score(recorder, prepared, wall), slam


def test_room_is_mapped_within_the_targets(tmp_path):
    result, slam = _map_and_score(subsim.world_path("room"), tmp_path, 60.0, "laser")
    m = result.metrics
    assert m["collisions"] == 0
    assert m["ate_m"] <= 0.05 and m["ate_online_m"] <= 0.05
    assert m["free_mapped_free"] >= 0.95 and m["walls_within_cell"] >= 0.95
    assert m["keyframes"] > 50
    # the saved map is a map_server map the simulator loads back, in the world's frame
    path = slam.save(tmp_path / "built.yaml")
    built = load_map(path)
    truth = load_map(subsim.world_path("room").parent / "room.yaml")
    col = int(round((2.0 - built.origin[0]) / 0.05))  # x = 2 m, a column crossing the room
    rows = [int(round((y - built.origin[1]) / 0.05)) for y in (0.175, 3.0)]
    assert built.occupancy[rows[0], col] == OCCUPIED == truth.occupancy[3, 40]  # the south wall where it is
    assert built.occupancy[rows[1], col] == FREE


def test_a_generated_map_with_the_narrow_depth_scan(tmp_path):
    """A map the method was not tuned on (the sparse generator with another seed, cut to 10 m x 10 m), seen
    with a 58-degree 0.45-4 m scan like a depth camera's."""
    grid = sparse(seed=23)[:200, :200].copy()
    grid[:4, :] = OCCUPIED
    grid[-4:, :] = OCCUPIED
    grid[:, :4] = OCCUPIED
    grid[:, -4:] = OCCUPIED
    map_path = save_map(grid, tmp_path / "generated.yaml", 0.05)
    world = tmp_path / "generated_world.yaml"
    world.write_text(yaml.safe_dump({"map": map_path.name, "robots": [
        {"name": "robot0", "namespace": "", "start": [2.0, 2.0, 0.785]}]}))
    result, _ = _map_and_score(world, tmp_path / "run", 60.0, "depth")
    m = result.metrics
    assert m["collisions"] == 0
    assert m["ate_m"] <= 0.10
    assert m["free_mapped_free"] >= 0.95 and m["walls_within_cell"] >= 0.9


def test_map_command_rejects_bad_input_in_one_line(tmp_path):
    missing = subprocess.run([sys.executable, "-m", "subsumption.cli", "map", "--world", str(tmp_path / "no.yaml"),
                              "--duration", "5", "--out", str(tmp_path / "out")], capture_output=True, text=True,
                             cwd=ROOT)
    assert missing.returncode == 2
    assert "no.yaml" in missing.stderr and "Traceback" not in missing.stderr
    assert len(missing.stderr.strip().splitlines()) == 1
    bad_param = subprocess.run([sys.executable, "-m", "subsumption.cli", "map", "--world",
                                str(subsim.world_path("room")), "--param", "linearUpdat=0.3", "--out",
                                str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT)
    assert bad_param.returncode == 2 and "linearUpdat" in bad_param.stderr and "Traceback" not in bad_param.stderr
    bad_explore = subprocess.run([sys.executable, "-m", "subsumption.cli", "map", "--world",
                                  str(subsim.world_path("room")), "--explore", "frontier", "--explore-param",
                                  "look_round=true", "--out", str(tmp_path / "out")], capture_output=True, text=True,
                                 cwd=ROOT)
    assert bad_explore.returncode == 2 and "Traceback" not in bad_explore.stderr
    assert "--explore-param 'look_round=true'" in bad_explore.stderr and "look_around" in bad_explore.stderr


def test_the_pingpong_room_is_mapped_with_the_narrow_depth_scan(tmp_path):
    """The patrol robot's map (experiments.patrol.built_map: 240 s of wander driving, depth scan, 2% odometry
    noise), on the seed that went worst before degeneracy-aware tracking and agreeing loop closures: a
    58-degree scan of one flat wall or of the table's long edge slid along it (ATE 2.2 m, walls 46%)."""
    import json

    from experiments.patrol import built_map

    built_map(subsim.world_path("pingpong"), tmp_path, 1, 240.0, progress=False)
    m = json.loads((tmp_path / "map" / "metrics.json").read_text())
    assert m["ate_m"] <= 0.10
    assert m["free_mapped_free"] >= 0.95 and m["walls_within_cell"] >= 0.95
