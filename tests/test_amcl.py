"""The particle filter: its sensor model and sampling bound, and convergence on a shipped map from a start
that is known to be off."""
from __future__ import annotations

import math

import genpy
import numpy as np
import pytest

import subsim
from experiments.localization import run_local
from experiments.mapping import prepare_world
from navigation.amcl_core import AmclParams, LikelihoodField, ParticleFilter, kld_size
from subsim.mapio import load_map


def room_field() -> LikelihoodField:
    return LikelihoodField(load_map(subsim.world_path("room").parent / "room.yaml"), 2.0)


def test_field_measures_distance_to_the_wall_surface():
    field = room_field()
    g = field.grid
    row = int((3.0 - g.origin[1]) / g.resolution)
    # the west wall's surface is at x = 0.2: the cell centred at x = 0.525 is 0.325 m from it
    col = int((0.525 - g.origin[0]) / g.resolution)
    assert abs(field.distance[row, col] - 0.325) < 1e-4
    assert field.distance[row, 1] == 0.0  # inside the wall


def test_kld_bound_grows_with_the_spread():
    assert kld_size(1, 0.01, 0.99) == 0
    sizes = [kld_size(k, 0.01, 0.99) for k in (2, 10, 100, 1000)]
    assert sizes == sorted(sizes) and sizes[-1] > 1000


def test_scan_picks_the_true_pose_and_walls_hold_no_particle():
    field = room_field()
    pf = ParticleFilter(field, AmclParams(), seed=1)
    truth = np.array([2.0, 2.0, 0.3])
    # beam ends of a robot at `truth` seeing the four walls of the room (surfaces at 0.2 and 5.8)
    angles = np.linspace(-math.pi, math.pi, 72, endpoint=False)
    ends = []
    for a in angles:
        c, s = math.cos(truth[2] + a), math.sin(truth[2] + a)
        t = min((5.8 - truth[0]) / c if c > 0 else (0.2 - truth[0]) / c if c < 0 else math.inf,
                (5.8 - truth[1]) / s if s > 0 else (0.2 - truth[1]) / s if s < 0 else math.inf)
        ends.append((t * math.cos(a), t * math.sin(a)))
    pf.particles = np.array([truth, truth + [0.3, 0.0, 0.0], truth + [0.0, 0.0, 0.2], [0.1, 3.0, 0.3]])
    pf.weights = np.full(4, 0.25)
    pf.params.resample_interval = 1000
    pf.correct(np.array(ends), 8.0)
    assert np.argmax(pf.weights) == 0
    assert pf.weights[3] < 1e-6  # inside the west wall


def test_converges_from_a_known_offset_on_a_shipped_map(tmp_path):
    world, start = prepare_world(subsim.world_path("corridors"), tmp_path, "laser", 0.02)
    wrong = [start[0] + 0.4, start[1] - 0.3, start[2] + 0.25]  # told 0.5 m and 14 degrees off the truth
    metrics = run_local(world, 40.0, seed=2, initial=wrong, initial_sigma=(0.4, 0.3), settle=10.0)
    assert metrics["collisions"] == 0
    assert metrics["loc_rmse_m"] <= 0.08 and metrics["loc_rmse_yaw_deg"] <= 2.0


def test_two_sided_field_penalises_ends_inside_walls_and_beams_through_them():
    field = room_field()
    g = field.grid
    row = int((3.0 - g.origin[1]) / g.resolution)
    assert field.signed[row, 1] < 0 < field.signed[row, 10]  # inside the west wall (0-0.2 m) / in the room
    pf = ParticleFilter(field, AmclParams(resample_interval=1000), seed=1)
    truth = np.array([3.0, 3.0, 0.0])
    # one beam straight ahead hitting the east wall's surface (x = 5.8), one to the left seeing nothing up to 2 m
    ends = np.array([[2.8, 0.0], [0.0, 2.0]])
    hit = np.array([True, False])
    # the truth; 0.1 m too far east (the hit ends inside the wall: amcl's field reads 0 there and cannot
    # tell); 1.2 m north (the free beam would pass through the north wall at y = 5.8)
    pf.particles = np.array([truth, truth + [0.1, 0.0, 0.0], truth + [0.0, 1.2, 0.0]])
    pf.weights = np.full(3, 1 / 3)
    pf.correct(ends, 4.0, hit)
    # the old model (hits only, 0 inside walls) weighs all three alike
    assert np.argmax(pf.weights) == 0
    assert pf.weights[1] < 0.2 * pf.weights[0] and pf.weights[2] < 0.2 * pf.weights[0]


def test_depth_scan_localizes_on_a_small_map(tmp_path):
    """The TurtleBot's narrow depth-camera scan (58 degrees, 0.45-4 m) in the square room, started 0.3 m off.
    Measured: amcl's one-sided field (likelihood_field_prob) 0.137 m RMS, the two-sided field 0.006 m; the
    bound is half the issue's 0.10 m target."""
    world, start = prepare_world(subsim.world_path("room"), tmp_path, "depth", 0.02)
    wrong = [start[0] + 0.2, start[1] - 0.2, start[2] + 0.1]
    metrics = run_local(world, 60.0, seed=1, initial=wrong, initial_sigma=(0.3, 0.2), settle=10.0)
    assert metrics["collisions"] == 0
    assert metrics["loc_rmse_m"] <= 0.05, metrics


def test_unknown_laser_model_is_named():
    import pytest

    with pytest.raises(ValueError, match="laser_model_type: 'beam'"):
        AmclParams(laser_model_type="beam")


def test_motion_before_the_first_scan_is_not_lost():
    """The initial pose is where the robot stood at the start (the first odometry). On a loaded ROS graph amcl's
    first scan came 35 s in, after the lower levels had driven the robot on; that motion was dropped and the
    estimate stayed at the start pose (the patrol then collided 23 times). Now it is predicted."""
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import LaserScan

    from navigation.amcl import Amcl
    from navigation.grid_messages import grid_msg
    from subsumption.mapfile import read_map_file
    from subsumption.testing import Harness

    grid = read_map_file(subsim.world_path("room").parent / "room.yaml")
    start, truth = (1.5, 3.0, 0.0), (2.7, 3.0, 0.0)  # the robot drove 1.2 m along x before the first scan
    h = Harness(Amcl, params={"initial_pose_x": start[0], "initial_pose_y": start[1], "initial_pose_a": start[2],
                              "initial_cov_xx": 0.01, "initial_cov_yy": 0.01, "initial_cov_aa": 0.01, "seed": 1})
    h.feed("map", grid_msg(grid, 0.0, "map"))

    def odom(t: float, x: float) -> Odometry:
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = genpy.Time.from_sec(t), "odom", "base_link"
        msg.pose.pose.position.x, msg.pose.pose.orientation.w = x, 1.0
        return msg

    def range_to_wall(angle: float) -> float:
        for r in np.arange(0.05, 8.0, 0.01):
            col = int((truth[0] + r * math.cos(angle) - grid.origin[0]) / grid.resolution)
            row = int((truth[1] + r * math.sin(angle) - grid.origin[1]) / grid.resolution)
            if grid.occupancy[row, col] == 100:
                return float(r)
        return math.inf

    h.feed("odom", odom(0.0, 0.0))
    h.feed("odom", odom(5.0, 1.2))
    scan = LaserScan(angle_min=-math.pi, angle_max=math.pi, angle_increment=2 * math.pi / 180, range_min=0.05,
                     range_max=8.0)
    scan.header.stamp, scan.header.frame_id = genpy.Time.from_sec(5.0), "base_link"
    scan.ranges = [range_to_wall(scan.angle_min + i * scan.angle_increment) for i in range(180)]
    h.feed("scan", scan)
    h.feed("odom", odom(5.1, 1.2))
    pose = h.sent("amcl_pose")[-1].pose.pose.position
    assert math.hypot(pose.x - truth[0], pose.y - truth[1]) < 0.15


def test_a_respawned_amcl_resumes_from_the_saved_correction():
    """Issue 31: a respawned amcl started from initial_pose_* (where the robot stood at the start of the run), not
    where it is. amcl now saves its map -> odom on the parameter server (~saved_map_to_odom, every
    save_pose_period s); an amcl started again under the same name resumes from it and the odometry it hears."""
    from nav_msgs.msg import Odometry

    from navigation.amcl import Amcl
    from navigation.grid_messages import grid_msg
    from subsumption.mapfile import read_map_file
    from subsumption.module import ParamError
    from subsumption.testing import Harness

    grid = read_map_file(subsim.world_path("room").parent / "room.yaml")
    h = Harness(Amcl, params={"initial_pose_x": 1.5, "initial_pose_y": 3.0, "saved_map_to_odom": [0.5, 1.0, 0.0]})
    h.feed("map", grid_msg(grid, 0.0, "map"))
    odom = Odometry()
    odom.header.stamp, odom.header.frame_id, odom.child_frame_id = genpy.Time.from_sec(1.0), "odom", "base_link"
    odom.pose.pose.position.x, odom.pose.pose.position.y, odom.pose.pose.orientation.w = 2.0, 2.0, 1.0
    h.feed("odom", odom)
    assert np.allclose(h.module.pose_now(), [2.5, 3.0, 0.0])  # the saved correction applied to odometry, not 1.5, 3
    with pytest.raises(ParamError, match="saved_map_to_odom must be"):
        Harness(Amcl, params={"saved_map_to_odom": [1.0, "x"]})


@pytest.mark.parametrize("background", [True, False])
def test_global_localization_finds_the_robot_by_searching_the_whole_map(tmp_path, background):
    """The amcl node started with `global_localization` (particles everywhere) on the ping-pong room: the whole-map
    search of its last scans (navigation.global_search), on a thread of its own or in the scan's callback, waits out
    the room's symmetry at the start, then puts the filter on the robot; from 10 s on it is within centimetres
    (without the search the filter settles on the room's mirror pose: 5.8 m and 180 degrees off)."""
    world, _ = prepare_world(subsim.world_path("pingpong"), tmp_path, "laser", 0.02)
    metrics = run_local(world, 25.0, seed=2, initial=[0.0, 0.0, 0.0], initial_sigma=(1.0, 1.0), settle=10.0,
                        amcl_params={"global_localization": True, "search_in_background": background})
    assert metrics["loc_rmse_m"] <= 0.05 and metrics["loc_rmse_yaw_deg"] <= 1.0, metrics


def test_a_search_in_the_background_does_not_hold_the_node_at_exit():
    """The whole-map search runs on a daemon thread of its own: a node told to shut down exits without waiting for a
    search that may take a minute on a large map (a thread pool's worker is joined at interpreter exit)."""
    import threading

    from navigation.amcl import in_background

    release = threading.Event()
    running = in_background(lambda: release.wait(30.0) and 42)
    searching = [t for t in threading.enumerate() if t.name == "amcl_global_search"]
    assert searching and all(t.daemon for t in searching) and not running.done()
    release.set()
    assert running.result(timeout=5.0) == 42
    failing = in_background(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        failing.result(timeout=5.0)
