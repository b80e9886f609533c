"""Kinematics, limits, command timeout, solid walls, collisions and bumpers, agents, determinism."""
from __future__ import annotations

import math

import numpy as np
import pytest

from subsim.mapio import OCCUPIED, GridMap
from subsim.maps.generate import fill, walled
from subsim.raycast import BUMP_CENTRE, BUMP_LEFT, BUMP_RIGHT
from subsim.bodies import GIVE_WAY, GIVE_WAY_PAUSE, PATIENCE
from subsim.sim import ROBOT_CLEARANCE, Simulation
from subsim.world import AgentSpec, CueSpec, Limits, RobotSpec, World

RES, DT = 0.05, 0.02


def sim_with(start, grid=None, agents=(), seed=0, **robot) -> Simulation:
    grid = walled(20.0, 20.0) if grid is None else grid
    spec = RobotSpec("r", "", start=start, **robot)
    return Simulation(World(GridMap(grid, RES, (0.0, 0.0)), [spec], list(agents)), seed=seed)


def drive(sim: Simulation, v: float, w: float, seconds: float, dt: float = DT) -> None:
    """Command (v, w) every 0.1 s, as a controller would, for `seconds`."""
    for i in range(int(round(seconds / dt))):
        if i % max(1, int(round(0.1 / dt))) == 0:
            sim.set_command("r", v, w)
        sim.step(dt)


def test_straight_line_matches_acceleration_profile():
    sim = sim_with((5.0, 10.0, 0.0))
    drive(sim, 0.5, 0.0, 2.0)
    r = sim.robots["r"]
    ramp = 0.5 / Limits().acc_v  # seconds to reach 0.5 m/s
    expected = 0.5 * 2.0 - 0.5 * 0.5 * ramp
    assert r.x - 5.0 == pytest.approx(expected, abs=0.02)
    assert r.y == pytest.approx(10.0, abs=1e-9)
    assert r.theta == pytest.approx(0.0, abs=1e-9)
    assert r.v == pytest.approx(0.5)
    assert r.odom[0] == pytest.approx(r.x - 5.0, abs=1e-9)  # no noise: odometry is exact


def test_spin_in_place():
    sim = sim_with((5.0, 10.0, 0.0))
    drive(sim, 0.0, 1.0, 2.0)
    r = sim.robots["r"]
    expected = 1.0 * 2.0 - 0.5 * 1.0 * (1.0 / Limits().acc_w)
    assert (r.x, r.y) == pytest.approx((5.0, 10.0), abs=1e-12)
    assert r.theta == pytest.approx(expected, abs=0.02)


def test_arc_follows_circle_of_radius_v_over_w():
    sim = sim_with((10.0, 10.0, 0.0))
    drive(sim, 0.5, 0.5, 6.0)
    r = sim.robots["r"]
    assert r.v / r.w == pytest.approx(1.0)
    history = sim.history("r")[-100:, 1:3]  # the last two seconds: steady state on a circle of radius 1 m
    centre = history.mean(axis=0)
    A = np.c_[2 * history, np.ones(len(history))]  # least-squares circle fit
    b = (history ** 2).sum(axis=1)
    cx, cy, c = np.linalg.lstsq(A, b, rcond=None)[0]
    radius = math.sqrt(c + cx ** 2 + cy ** 2)
    assert radius == pytest.approx(1.0, abs=1e-6)
    assert np.hypot(*(centre - (cx, cy))) < 1.0


def test_velocity_and_acceleration_limits():
    sim = sim_with((3.0, 10.0, 0.0))
    sim.set_command("r", 5.0, -10.0)
    sim.step(DT)
    r = sim.robots["r"]
    assert r.v == pytest.approx(Limits().acc_v * DT)  # acceleration-limited first step
    assert r.w == pytest.approx(-Limits().acc_w * DT)
    drive(sim, 5.0, -10.0, 2.0)
    assert r.v == pytest.approx(0.7)
    assert r.w == pytest.approx(-2.0)


def test_command_timeout_stops_the_robot():
    sim = sim_with((3.0, 10.0, 0.0))
    sim.set_command("r", 0.5, 0.0)
    for _ in range(int(0.5 / DT)):  # within the timeout: it keeps driving
        sim.step(DT)
    assert sim.robots["r"].v == pytest.approx(0.5)
    for _ in range(int(1.0 / DT)):
        sim.step(DT)
    r = sim.robots["r"]
    assert r.v == 0.0
    x = r.x
    sim.step(DT)
    assert r.x == x


@pytest.mark.parametrize("dt", [0.02, 0.5, 3.0])
def test_no_tunnelling_through_a_one_cell_wall_at_top_speed(dt):
    grid = walled(20.0, 20.0)
    fill(grid, 10.0, 0.0, 10.0 + RES, 20.0, OCCUPIED)  # one cell thick
    sim = sim_with((9.0, 10.0, 0.0), grid=grid)
    for _ in range(int(round(6.0 / dt))):
        sim.set_command("r", 5.0, 0.0)
        sim.step(dt)
    r = sim.robots["r"]
    assert r.x + r.radius <= 10.0 + 1e-9
    assert r.x + r.radius == pytest.approx(10.0, abs=0.005)  # it got there and touches
    assert r.collisions == 1
    assert np.all(sim.history("r")[:, 1] + r.radius <= 10.0 + 1e-9)


def test_each_new_contact_counts_once_and_bumper_tells_the_side():
    sim = sim_with((18.6, 10.0, 0.0))
    drive(sim, 0.5, 0.0, 3.0)  # into the east wall (face x = 19.8), head on
    r = sim.robots["r"]
    assert (r.collisions, r.in_contact, r.bumper) == (1, True, BUMP_CENTRE)
    drive(sim, 0.5, 0.0, 1.0)  # pushing on: still the same contact
    assert r.collisions == 1
    drive(sim, -0.3, 0.0, 1.0)  # back off
    assert (r.in_contact, r.bumper) == (False, 0)
    drive(sim, 0.5, 0.0, 2.0)  # and in again
    assert r.collisions == 2
    assert len(sim.collision_points()["r"]) == 2


@pytest.mark.parametrize("heading, bit", [(-math.pi / 3, BUMP_LEFT), (math.pi / 3, BUMP_RIGHT)])
def test_glancing_contact_presses_side_bumper(heading, bit):
    sim = sim_with((19.3, 10.0, heading))
    drive(sim, 0.3, 0.0, 3.0)
    r = sim.robots["r"]
    assert r.collisions == 1
    assert r.bumper == bit


def test_robot_cannot_leave_the_map():
    sim = sim_with((1.0, 1.0, math.pi), grid=np.zeros((60, 60), dtype=np.int8))
    drive(sim, 0.7, 0.0, 3.0)
    r = sim.robots["r"]
    assert r.x == pytest.approx(r.radius, abs=0.005)
    assert r.collisions == 1


def test_agent_walks_waypoints_and_blocks_the_robot():
    walker = AgentSpec("p", waypoints=((5.0, 10.0), (5.0, 12.0)), loop=False, speed=1.0, radius=0.25)
    sim = sim_with((3.0, 12.0, 0.0), agents=[walker])
    for _ in range(int(3.0 / DT)):
        sim.step(DT)
    p = sim.agents["p"]
    assert (p.x, p.y) == pytest.approx((5.0, 12.0))
    reading = sim.sense("r")
    assert reading.laser[270] == pytest.approx(2.0 - 0.25, abs=1e-9)
    drive(sim, 0.7, 0.0, 5.0)
    r = sim.robots["r"]
    assert r.collisions == 1
    assert r.x == pytest.approx(5.0 - 0.25 - 0.18, abs=0.005)
    assert r.bumper == BUMP_CENTRE


def test_agent_with_a_cue_stands_until_the_robot_comes_near():
    cue = CueSpec(robot="r", near=(8.0, 5.0), within=1.0)
    walker = AgentSpec("p", waypoints=((10.0, 15.0), (18.0, 15.0)), loop=False, speed=1.0, cue=cue)
    sim = sim_with((3.0, 5.0, 0.0), agents=[walker])
    drive(sim, 0.5, 0.0, 8.0)  # stops short of the cue: 3 + ~3.9 m < 7 m
    assert (sim.agents["p"].x, sim.agents["p"].y) == (10.0, 15.0)
    drive(sim, 0.5, 0.0, 2.0)  # within 1 m of (8, 5) from about 8.3 s
    assert 10.0 < sim.agents["p"].x < 12.0
    drive(sim, -0.5, 0.0, 8.0)  # once started it goes on, though the robot is out of the cue's reach in ~3 s
    assert sim.agents["p"].x == pytest.approx(18.0)


def test_walkers_face_to_face_pass_each_other():
    """Two walkers on one line towards each other: each steps aside (to its right) and both reach their far
    ends, never touching; before, each waited for the other's way to clear for ever."""
    west = AgentSpec("w", waypoints=((4.0, 10.0), (12.0, 10.0)), loop=False, speed=1.0)
    east = AgentSpec("e", waypoints=((12.0, 10.0), (4.0, 10.0)), loop=False, speed=0.8)
    sim = sim_with((3.0, 3.0, 0.0), agents=[west, east])
    for _ in range(int(14.0 / DT)):
        sim.step(DT)
    assert sim.agents["w"].done and sim.agents["e"].done
    assert sim.agents["w"].pose()[:2] == pytest.approx((12.0, 10.0))
    assert sim.agents["e"].pose()[:2] == pytest.approx((4.0, 10.0))
    gap = np.hypot(*(sim.history("w")[:, 1:3] - sim.history("e")[:, 1:3]).T) - 0.5
    assert gap.min() >= 0.02 - 1e-9
    assert sim.history("w")[:, 2].min() < 10.0 - 0.25  # west-to-east keeps right: it stepped south


def robot_gap(sim: Simulation, agent: str) -> np.ndarray:
    """Free distance between the agent's and robot r's rims over the recorded history."""
    a, r = sim.history(agent), sim.history("r")
    return np.hypot(*(a[:, 1:3] - r[:, 1:3]).T) - sim.agents[agent].radius - sim.robots["r"].radius


@pytest.mark.parametrize("passage", [True, False])
def test_walker_waits_for_a_robot_in_its_way_then_gives_way(passage):
    """A robot standing on a walker's line (in a passage one walker wide, or in the open): the walker stops
    ROBOT_CLEARANCE short of its rim, waits PATIENCE s, walks GIVE_WAY m back the way it came, and comes again.
    Before, it waited for ever, and a robot that waited for it (or could not see it) did too."""
    grid = walled(20.0, 20.0)
    if passage:
        fill(grid, 0.0, 9.0, 20.0, 9.65, OCCUPIED)
        fill(grid, 0.0, 10.35, 20.0, 20.0, OCCUPIED)  # free only 9.65 <= y < 10.35: 0.7 m
    walker = AgentSpec("p", waypoints=((3.0, 10.0), (15.0, 10.0)), loop=False, speed=1.0)
    sim = sim_with((8.0, 10.0, 0.0), grid=grid, agents=[walker])
    for _ in range(int(16.0 / DT)):
        sim.step(DT)
    t, x, y = sim.history("p")[:, :3].T
    stop = 8.0 - 0.18 - ROBOT_CLEARANCE - 0.25
    assert x.max() == pytest.approx(stop, abs=0.03) and np.abs(y - 10.0).max() < 1e-9
    first_stop = int(np.argmax(x > stop - 0.03))
    back = first_stop + int(np.argmax(x[first_stop:] < stop - 0.05))
    assert t[back] - t[first_stop] == pytest.approx(PATIENCE, abs=0.1)  # it waited
    assert x[back:].min() == pytest.approx(stop - GIVE_WAY, abs=0.05)  # went back
    there = back + int(np.argmax(x[back:] < x[back:].min() + 1e-6))
    left = there + int(np.argmax(x[there:] > x[there] + 1e-6))
    assert t[left] - t[there] == pytest.approx(GIVE_WAY_PAUSE, abs=0.1)  # stood aside there
    assert x[left:].max() == pytest.approx(stop, abs=0.03)  # and came again
    assert robot_gap(sim, "p").min() >= ROBOT_CLEARANCE - 1e-9


def test_walkers_who_cannot_pass_in_a_passage_take_turns():
    """Two walkers meeting in a door one walker wide, where neither can step aside: the first out of PATIENCE
    gives way (walks back), the other waits for it, not both; before, each waited for ever."""
    grid = walled(20.0, 20.0)
    fill(grid, 9.9, 0.0, 10.1, 9.65, OCCUPIED)
    fill(grid, 9.9, 10.35, 10.1, 20.0, OCCUPIED)  # a wall at x 10 with a door at y 9.65-10.35
    west = AgentSpec("w", waypoints=((4.0, 10.0), (16.0, 10.0)), loop=True, speed=1.0)
    east = AgentSpec("e", waypoints=((14.0, 10.0), (4.0, 10.0)), loop=False, speed=0.8)
    sim = sim_with((3.0, 3.0, 0.0), grid=grid, agents=[west, east])
    for _ in range(int(30.0 / DT)):
        sim.step(DT)
    assert sim.agents["e"].done
    gap = np.hypot(*(sim.history("w")[:, 1:3] - sim.history("e")[:, 1:3]).T) - 0.5
    assert gap.min() >= 0.02 - 1e-9


def test_walker_off_its_lane_comes_back_round_a_door_jamb():
    """A walker that stepped aside just before a door (off its lane, the jamb between it and the lane ahead)
    turns back to its lane and goes through; before, it walked straight at its waypoint into the jamb and
    stood there for ever (a generated office, seed 11)."""
    grid = walled(20.0, 20.0)
    fill(grid, 0.0, 9.9, 7.4, 10.1, OCCUPIED)
    fill(grid, 8.6, 9.9, 20.0, 10.1, OCCUPIED)  # a wall at y 10 with a door at x 7.4-8.6
    walker = AgentSpec("p", waypoints=((8.0, 13.0), (8.0, 7.0)), loop=False, speed=1.0)
    sim = sim_with((15.0, 15.0, 0.0), grid=grid, agents=[walker])
    p = sim.agents["p"]
    p.target, p.lane_from, (p.x, p.y) = 1, (8.0, 13.0), (7.0, 10.45)  # stepped aside 1 m off its lane by the jamb
    assert sim.gap(6.4, 10.0, 0.25, sim.circles(exclude="p")) < 0  # the straight line to (8, 7) hits the wall
    for _ in range(int(8.0 / DT)):
        sim.step(DT)
    assert p.done and p.pose()[:2] == pytest.approx((8.0, 7.0))


def test_wanderer_stays_in_free_space():
    rover = AgentSpec("w", kind="robot", motion="wander", start=(10.0, 10.0, 0.3), speed=0.7, radius=0.18)
    sim = sim_with((2.0, 2.0, 0.0), agents=[rover], seed=5)
    for _ in range(int(60.0 / DT)):
        sim.step(DT)
    path = sim.history("w")[:, 1:3]
    assert np.all((path > 0.2 + 0.18 - 1e-9) & (path < 19.8 - 0.18 + 1e-9))
    assert np.ptp(path[:, 0]) > 5.0  # it did get around


def test_free_start_pose_is_deterministic_and_clear():
    grid = walled(6.0, 6.0)
    spec = RobotSpec("r", "")
    poses = [Simulation(World(GridMap(grid, RES, (0.0, 0.0)), [spec], [])).robots["r"].pose() for _ in range(2)]
    assert poses[0] == poses[1]
    assert poses[0][:2] == pytest.approx((3.0, 3.0), abs=0.05)


def test_same_seed_same_trajectory_bit_for_bit():
    def run(seed):
        rover = AgentSpec("w", kind="robot", motion="wander", start=(10.0, 10.0, 0.3), speed=0.5, radius=0.18)
        sim = sim_with((3.0, 3.0, 0.5), agents=[rover], seed=seed, odom_noise=0.05)
        for i in range(1500):
            if i % 5 == 0:
                sim.set_command("r", 0.6, 0.8 * math.sin(i / 50))
                sim.sense("r")
            sim.step(DT)
        return sim.history("r"), sim.history("w"), sim.robots["r"].odom
    a, b, c = run(7), run(7), run(8)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[2] == b[2]
    assert not np.array_equal(a[1], c[1])  # the wanderer's turns come from the seed


def test_never_overlaps_anything_under_random_driving():
    """Random commands at random step lengths in the sparse world with a walker and a wanderer: no pose
    of any body ever overlaps a wall or another body."""
    import subsim
    from subsim.world import load_world
    world = load_world(subsim.world_path("sparse"))
    world.agents = [AgentSpec("p", waypoints=((3.0, 3.0), (9.0, 4.0), (4.0, 9.0)), speed=1.2),
                    AgentSpec("w", kind="robot", motion="wander", start=(6.0, 6.0, 0.0), speed=0.7, radius=0.18)]
    sim = Simulation(world, seed=11)
    rng = np.random.default_rng(11)
    for _ in range(3000):
        sim.set_command("robot0", rng.uniform(-0.2, 1.0), rng.uniform(-2.5, 2.5))
        sim.step(float(rng.choice([0.02, 0.05, 0.2])))
        for name, body in sim._bodies():
            assert sim.gap(body.x, body.y, body.radius, sim.circles(exclude=name)) >= -1e-9, (name, body.pose())
    assert sim.robots["robot0"].collisions > 0  # it did meet things


def test_non_finite_command_stops_the_robot():
    sim = sim_with((5.0, 10.0, 0.0))
    drive(sim, 0.5, 0.0, 1.0)
    drive(sim, math.nan, 0.0, 1.0)
    r = sim.robots["r"]
    assert r.v == 0.0 and math.isfinite(r.x)


def test_odometry_turn_noise_of_its_own():
    """odom_turn_noise sets the noise of odometry's turning apart from its distance (a base whose heading comes
    from a gyro); left out, the turn has odom_noise's. Turning on the spot: only the turn part counts."""
    def heading_error(**noise) -> float:
        sim = sim_with((10.0, 10.0, 0.0), seed=3, **noise)
        drive(sim, 0.0, 1.0, 6.0)
        robot = sim.robots["r"]
        return abs(math.remainder(robot.odom[2] - (robot.theta - robot.start[2]), 2 * math.pi))

    assert heading_error(odom_noise=0.02, odom_turn_noise=0.0) < 1e-9
    assert heading_error(odom_noise=0.02) > 1e-4
    assert heading_error(odom_noise=0.0, odom_turn_noise=0.02) > 1e-4
