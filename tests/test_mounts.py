"""navigation.scan_geometry.Mounts: where a sensor sits in the base frame odometry names, through a chain of static
frames as tf2 composes them (the live nodes' MountListener and the bag reader share it)."""
from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Quaternion, Transform, TransformStamped, Vector3

from navigation.scan_geometry import Mounts
from subsumption.planar import compose, quaternion


def transform(parent: str, child: str, x: float, y: float, yaw: float, upside_down: bool = False) -> TransformStamped:
    """`child` at (x, y, yaw) in `parent`, 0.3 m up; `upside_down`: then rolled half a turn about its own x axis."""
    c, s = math.cos(yaw / 2), math.sin(yaw / 2)
    q = Quaternion(c, s, 0.0, 0.0) if upside_down else quaternion(yaw)  # q_z(yaw) * q_x(pi) = (c, s, 0, 0)
    t = TransformStamped(child_frame_id=child, transform=Transform(Vector3(x, y, 0.3), q))
    t.header.frame_id = parent
    return t


def test_a_chain_of_static_frames_is_composed_and_an_upside_down_sensor_is_told():
    mounts = Mounts()
    for t in (transform("base_footprint", "base_link", 0.10, 0.0, 0.0),
              transform("base_link", "camera_link", 0.05, 0.02, 0.3),
              transform("camera_link", "camera_depth_frame", 0.0, 0.01, 0.0, upside_down=True)):
        assert mounts.add(t) is None
    pose, upside_down = mounts.mount("base_footprint", "/camera_depth_frame")  # a scan's frame with ROS 1's slash
    expected = compose(compose(np.array([0.10, 0.0, 0.0]), np.array([0.05, 0.02, 0.3])), np.array([0.0, 0.01, 0.0]))
    assert np.allclose(pose, expected) and upside_down
    laser, flipped = mounts.mount("base_link", "camera_link")
    assert np.allclose(laser, [0.05, 0.02, 0.3]) and not flipped
    assert mounts.mount("base_link", "base_link")[0].tolist() == [0.0, 0.0, 0.0]
    assert mounts.mount("base_footprint", "a_frame_no_one_placed") is None


def test_odometry_that_names_no_base_stands_for_the_top_of_the_sensors_chain():
    mounts = Mounts()
    assert mounts.mount("", "base_scan")[0].tolist() == [0.0, 0.0, 0.0]  # nothing known yet: the base itself ...
    looked_up = []
    mounts.top_of = lambda frame: looked_up.append(frame) or frame  # the buffer's frames, read for every scan?
    assert mounts.mount("", "base_scan")[0].tolist() == [0.0, 0.0, 0.0] and not looked_up  # no: kept meanwhile
    del mounts.top_of
    mounts.add(transform("base_footprint", "base_link", 0.10, 0.0, 0.0))
    mounts.add(transform("base_link", "base_scan", -0.14, 0.0, 0.0))
    assert mounts.top_of("base_scan") == "base_footprint" and mounts.top_of("elsewhere") == "elsewhere"
    pose, _ = mounts.mount("", "base_scan")  # ... but not kept: once /tf_static has come, the chain's
    assert np.allclose(pose, [-0.04, 0.0, 0.0])
