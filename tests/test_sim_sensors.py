"""Sensors against geometry we can compute by hand: laser and sonar ranges, REP 117, other bodies."""
from __future__ import annotations

import math

import numpy as np
import pytest

from subsim import raycast
from subsim.mapio import OCCUPIED, GridMap
from subsim.maps.generate import fill, walled
from subsim.sim import Simulation
from subsim.world import AgentSpec, RobotSpec, World

RES = 0.05


def world(grid: np.ndarray, robots: list[RobotSpec], agents: list[AgentSpec] = ()) -> World:
    return World(GridMap(grid, RES, (0.0, 0.0)), list(robots), list(agents))


def test_centre_laser_beam_reads_distance_to_wall_within_one_cell():
    grid = walled(6.0, 6.0)
    fill(grid, 3.0, 0.0, 3.05, 6.0, OCCUPIED)  # a wall whose face is at x = 3.00
    sim = Simulation(world(grid, [RobotSpec("r", "", start=(2.0, 3.0, 0.0))]))
    laser = sim.sense("r").laser
    assert laser.size == 541
    assert laser[270] == pytest.approx(1.00, abs=RES)
    # the beam 90 degrees to the left (index 270 + 180) meets the top wall (face at y = 5.8)
    assert laser[450] == pytest.approx(2.8, abs=RES)


def test_laser_range_is_exact_for_oblique_beams():
    grid = walled(6.0, 6.0)
    sim = Simulation(world(grid, [RobotSpec("r", "", start=(3.0, 3.0, 0.0))]))
    laser = sim.sense("r").laser
    angles = np.linspace(-3 * math.pi / 4, 3 * math.pi / 4, 541)
    # distance to the inner faces of the walled square [0.2, 5.8]^2 along each beam
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (5.8 - 3.0) / c, np.where(c < 0, (0.2 - 3.0) / c, np.inf))
        ty = np.where(s > 0, (5.8 - 3.0) / s, np.where(s < 0, (0.2 - 3.0) / s, np.inf))
    expected = np.minimum(tx, ty)
    assert np.all(np.abs(laser - expected) < 1e-6)


def test_sonar_cone_reports_nearest_obstacle_inside_the_cone():
    grid = walled(8.0, 8.0)
    # a person standing still 1.5 m ahead of the robot's rim, 10 degrees left of sonar 0's axis
    bearing = math.radians(10.0)
    cx, cy = 2.0 + 0.18 + 1.5 * math.cos(bearing), 4.0 + 1.5 * math.sin(bearing)
    person = AgentSpec("p", waypoints=((cx, cy),), loop=False, speed=0.0, radius=0.25)
    sim = Simulation(world(grid, [RobotSpec("r", "", start=(2.0, 4.0, 0.0))], [person]))
    reading = sim.sense("r")
    assert reading.sonar.size == 12
    # not the wall straight ahead (5.6 m, out of range anyway) but the person's near side, ~1.25 m away
    assert reading.sonar[0] == pytest.approx(1.25, abs=0.03)
    # the centre laser beam misses the person (it is 10 degrees off): it sees the far wall
    assert reading.laser[270] == pytest.approx(7.8 - 2.0, abs=RES)
    # sonar 6 looks backwards at the wall: 2.0 - 0.18 - 0.2 from the rim
    assert reading.sonar[6] == pytest.approx(1.62, abs=RES)


def test_sonar_cone_is_wider_than_its_axis():
    grid = walled(8.0, 8.0)
    # a thin pillar 14 degrees off sonar 0's axis: only the cone's edge ray can see it
    bearing = math.radians(14.5)
    px, py = 2.18 + 1.0 * math.cos(bearing), 4.0 + 1.0 * math.sin(bearing)
    person = AgentSpec("p", waypoints=((px, py),), loop=False, speed=0.0, radius=0.05)
    sim = Simulation(world(grid, [RobotSpec("r", "", start=(2.0, 4.0, 0.0))], [person]))
    assert sim.sense("r").sonar[0] == pytest.approx(0.95, abs=0.05)


def test_out_of_range_follows_rep_117():
    grid = walled(20.0, 20.0)
    # rim 0.1 m from the left wall (face at x = 0.2), facing +x into 19 m of open space
    sim = Simulation(world(grid, [RobotSpec("r", "", start=(0.48, 10.0, 0.0))]))
    reading = sim.sense("r")
    assert reading.sonar[6] == -math.inf  # behind: closer than min_range 0.3
    assert reading.sonar[0] == math.inf  # ahead: nothing within max_range 3.0
    assert reading.laser[270] == math.inf  # nothing within 8 m
    assert np.all(np.isfinite(reading.laser[:10]))  # beams toward the nearby wall do see it


def test_laser_and_sonar_see_another_robot_as_a_circle():
    grid = walled(10.0, 10.0)
    robots = [RobotSpec("a", "a", start=(3.0, 5.0, 0.0)), RobotSpec("b", "b", start=(5.0, 5.0, math.pi))]
    sim = Simulation(world(grid, robots))
    a, b = sim.sense("a"), sim.sense("b")
    assert a.laser[270] == pytest.approx(2.0 - 0.18, abs=1e-9)  # exact: analytic ray-circle
    assert b.laser[270] == pytest.approx(2.0 - 0.18, abs=1e-9)
    assert a.sonar[0] == pytest.approx(2.0 - 0.36, abs=0.01)


def test_noise_is_seeded_and_changes_ranges():
    grid = walled(6.0, 6.0)
    spec = RobotSpec("r", "", start=(3.0, 3.0, 0.0))
    noisy = World(GridMap(grid, RES, (0, 0)), [spec], [])
    from dataclasses import replace
    spec_noisy = replace(spec, laser=replace(spec.laser, noise=0.02))
    noisy.robots = [spec_noisy]
    r1 = Simulation(noisy, seed=3).sense("r").laser
    r2 = Simulation(noisy, seed=3).sense("r").laser
    r3 = Simulation(noisy, seed=4).sense("r").laser
    clean = Simulation(world(grid, [spec])).sense("r").laser
    assert np.array_equal(r1, r2)
    assert not np.array_equal(r1, r3)
    assert 0.01 < np.std(r1 - clean) < 0.03


def test_skipping_through_open_space_gives_exactly_the_cell_walk_result():
    rng = np.random.default_rng(0)
    occupancy = np.where(rng.random((200, 300)) < 0.01, OCCUPIED, 0).astype(np.int8)
    occupancy[80:120, 100:103] = OCCUPIED  # a thin wall among the scattered cells
    grid = GridMap(occupancy, RES, (-2.0, 1.0))
    xs = rng.uniform(-2.0, 13.0, 3000)
    ys = rng.uniform(1.0, 11.0, 3000)
    angles = rng.uniform(-math.pi, math.pi, 3000)
    reach = np.full(3000, 8.0)
    fast = raycast.cast_rays(grid.solid, grid.wall_distance, -2.0, 1.0, RES, xs, ys, angles, reach,
                             raycast.NO_CIRCLES)
    walk = np.array([raycast._ray_grid(grid.solid, -2.0, 1.0, RES, x, y, math.cos(a), math.sin(a), 8.0)
                     for x, y, a in zip(xs, ys, angles)])
    assert np.array_equal(np.isinf(fast), np.isinf(walk))
    finite = np.isfinite(walk)
    assert finite.sum() > 1000
    assert np.max(np.abs(fast[finite] - walk[finite])) < 1e-9
