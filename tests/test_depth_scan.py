"""vision.depth_scan.DepthToScan: a LaserScan from a band of depth rows, on hand-made images and against the
simulator's laser in the same world."""
from __future__ import annotations

import math

import numpy as np
import pytest
import rospy
import yaml
from sensor_msgs.msg import CameraInfo, LaserScan
from std_msgs.msg import Header

import subsim
import subsim.local
from subsumption.images import from_array
from subsumption.local import LocalRuntime
from subsumption.testing import Harness
from vision.depth_scan import DepthToScan

FX, CX, CY = 589.37, 319.5, 239.5


def info(width=640, height=480, cy=CY) -> CameraInfo:
    return CameraInfo(width=width, height=height, K=[FX, 0, CX, 0, FX, cy, 0, 0, 1])


def depth_msg(depth: np.ndarray, frame="tb/camera_depth_optical_frame", encoding="32FC1"):
    if encoding == "16UC1":  # OpenNI's: millimetres, 0 = no reading
        depth = np.where(np.isfinite(depth), np.rint(depth * 1000.0), 0).astype(np.uint16)
        return from_array(depth, "16UC1", Header(frame_id=frame))
    return from_array(depth.astype(np.float32), "32FC1", Header(frame_id=frame))


def scan_of(depth: np.ndarray, camera: CameraInfo | None = None, encoding="32FC1", **params) -> LaserScan:
    harness = Harness(DepthToScan, params=params)
    harness.feed("camera_info", camera or info(depth.shape[1], depth.shape[0]))
    harness.feed("depth", depth_msg(depth, encoding=encoding))
    return harness.sent("scan")[-1]


def test_flat_wall_gives_ranges_of_the_pinhole_geometry():
    depth = np.full((480, 640), 2.0, np.float32)
    scan = scan_of(depth)
    assert scan.header.frame_id == "tb/camera_depth_frame"  # x forward: the optical frame without '_optical'
    assert len(scan.ranges) == 640
    assert scan.angle_min == pytest.approx(-math.atan(CX / FX)) and scan.angle_max == pytest.approx(math.atan(CX / FX))
    angles = scan.angle_min + scan.angle_increment * np.arange(640)
    # a wall square on at 2 m: range = 2 / cos(bearing) (within the half-column a beam may be off by)
    assert np.allclose(scan.ranges, 2.0 / np.cos(angles), atol=2.0 * np.tan(0.5 / FX * 2) + 1e-3)


@pytest.mark.parametrize("encoding", ["32FC1", "16UC1"])
def test_nearest_in_the_band_and_rep117(encoding):
    depth = np.full((480, 640), np.nan, np.float32)  # nothing in range anywhere: +inf
    depth[236:244, :100] = 3.0  # right of the image: beams at the start
    depth[240, 50] = 1.0  # a nearer pixel in the band wins
    depth[236:244, 300:340] = 0.2  # too close: -inf
    depth[100, 500:] = 1.0  # outside the band: ignored
    scan = scan_of(depth, encoding=encoding, scan_height=10)
    r = np.array(scan.ranges)
    angles = scan.angle_min + scan.angle_increment * np.arange(640)
    columns = np.rint(CX - FX * np.tan(angles)).astype(int)
    assert np.all(r[columns >= 340][(columns[columns >= 340] < 500)] == np.inf)
    assert np.all(r[(columns >= 305) & (columns < 335)] == -np.inf)
    assert np.all(r[columns < 100][columns[columns < 100] != 50] > 3.0)
    assert r[columns == 50].min() == pytest.approx(1.0 * math.hypot(1, (50 - CX) / FX), rel=1e-4)
    assert np.all(r[columns >= 500] == np.inf)


def test_cropped_band_gives_the_same_scan_as_the_full_image():
    rng = np.random.default_rng(1)
    depth = rng.uniform(0.5, 5.0, (480, 640)).astype(np.float32)
    full = scan_of(depth, scan_height=10)
    row0 = round(CY - 4.5)
    band = scan_of(depth[row0:row0 + 10], info(640, 10, CY - row0), scan_height=10)
    assert band.ranges == full.ranges


def test_max_rate_thins_30_hz_frames_to_10_hz_scans_by_their_stamps():
    harness = Harness(DepthToScan, params={"max_rate": 10.0})
    harness.feed("camera_info", info())
    stamps = [0.0, 0.04, 0.06, 0.1, 0.14, 0.16, 0.2, 0.24, 0.26, 0.3, 0.1]  # 30 Hz on 50 Hz physics, then a restart
    for t in stamps:
        msg = depth_msg(np.full((480, 640), 2.0, np.float32))
        msg.header.stamp = rospy.Time.from_sec(t)
        harness.feed("depth", msg)
    assert [m.header.stamp.to_sec() for m in harness.sent("scan")] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.1])


def test_without_camera_info_it_waits():
    harness = Harness(DepthToScan)
    harness.feed("depth", depth_msg(np.ones((480, 640))))
    assert harness.sent("scan") == []


def world_with_laser_and_camera(tmp_path, mode="rgbd", start=(1.0, 1.0, 0.0)):
    world = yaml.safe_load(subsim.world_path("pingpong").read_text())
    world["map"] = str(subsim.MAPS / world["map"])
    for picture in world["scene"]["pictures"]:
        picture["file"] = str(subsim.MAPS / picture["file"])
    world["agents"][0]["picture"]["file"] = str(subsim.MAPS / world["agents"][0]["picture"]["file"])
    world["agents"][0].update(wait=0.0, waypoints=[[2.5, 4.0], [2.5, 1.2]])  # walks across in front
    world["robots"][0]["sensors"] = {"laser": True, "camera": {"x": 0.0, "mode": mode}}
    world["robots"][0]["start"] = list(start)
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(world))
    return path


@pytest.mark.parametrize("mode", ["rgbd", "depth_band"])
@pytest.mark.parametrize("pose", [(1.0, 2.0, 0.3), (8.0, 1.0, 2.4), (3.0, 5.0, -1.2)])
def test_depth_scan_agrees_with_the_laser_where_both_see(tmp_path, pose, mode):
    """The pingpong room with the table and the target walking across; the camera at the laser's place. Where both
    have a range (the laser reaches 8 m, the depth camera 6 m), they agree within a cell, except on the edges of
    things, where a beam and a column a fraction of a degree apart may see different things."""
    path = world_with_laser_and_camera(tmp_path, mode, pose)
    runtime = LocalRuntime()
    subsim.local.attach(runtime, path)
    runtime.add_module(DepthToScan, "depth_scan", remap={"depth": "/camera/depth/image_raw",
                                                         "camera_info": "/camera/depth/camera_info",
                                                         "~scan": "/depth_scan"})
    depth_scans: dict = {}
    lasers: list[LaserScan] = []
    listener = runtime.node("listener")
    listener.subscribe("/depth_scan", LaserScan, lambda m: depth_scans.__setitem__(m.header.stamp, m))
    listener.subscribe("/scan", LaserScan, lambda m: lasers.append(m))
    runtime.run_for(3.0)
    # the newest laser sweep and the camera frame of the same step (both fall on physics steps)
    laser = next(m for m in reversed(lasers) if m.header.stamp in depth_scans)
    depth = depth_scans[laser.header.stamp]
    assert laser.header.stamp.to_sec() > 2.5
    angles = depth.angle_min + depth.angle_increment * np.arange(len(depth.ranges))
    ranges = np.array(depth.ranges)
    laser_angles = laser.angle_min + laser.angle_increment * np.arange(len(laser.ranges))
    laser_ranges = np.array(laser.ranges)
    nearest = np.clip(np.rint((angles - laser.angle_min) / laser.angle_increment).astype(int), 1,
                      len(laser_ranges) - 2)
    # beams away from edges: the laser's neighbours agree with each other
    with np.errstate(invalid="ignore"):  # inf - inf where the laser sees nothing
        steady = np.abs(laser_ranges[nearest - 1] - laser_ranges[nearest + 1]) < 0.03 + 0.03 * laser_ranges[nearest]
    both = steady & np.isfinite(ranges) & np.isfinite(laser_ranges[nearest]) & (laser_ranges[nearest] < 6.0)
    assert both.sum() > 100
    interpolated = np.interp(angles, laser_angles, laser_ranges)
    assert np.all(np.abs(ranges[both] - interpolated[both]) <= 0.05)
    # and where the laser has nothing within 6 m, neither has the depth scan
    far = steady & (laser_ranges[nearest] > 6.2)
    assert np.all(ranges[far] == np.inf)
