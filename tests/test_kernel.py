"""The core's shared kernel: planar geometry, the pinhole model and the one bad-input-file error, checked
against hand-worked values and against the libraries that share the conventions (scipy's rotations, OpenCV's
projection)."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from geometry_msgs.msg import Quaternion
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import CameraInfo

from subsim.mapio import MapError
from subsim.world import WorldError, load_world
from subsumption import yamlfile
from subsumption.errors import InputFileError
from subsumption.mapfile import read_map_file
from subsumption.pinhole import Pinhole
from subsumption.planar import (between, compose, from_pose_msg, inverse, pose_msg, quaternion, transform_msg,
                                transform_points, wrap, yaw_of)


@pytest.mark.parametrize("angle, wrapped", [(0.0, 0.0), (math.pi, -math.pi), (-math.pi, -math.pi),
                                            (3 * math.pi / 2, -math.pi / 2), (-7.0, -7.0 + 2 * math.pi),
                                            (4 * math.pi + 0.25, 0.25)])
def test_wrap_puts_angles_in_minus_pi_to_pi(angle, wrapped):
    assert wrap(angle) == pytest.approx(wrapped, abs=1e-12)
    assert isinstance(wrap(angle), float) and isinstance(wrap(np.float32(angle)), float)
    assert wrap(np.array([angle, angle]))[1] == pytest.approx(wrapped, abs=1e-12)


def test_quaternion_and_yaw_are_inverse_and_agree_with_scipy():
    for yaw in np.linspace(-math.pi + 1e-9, math.pi - 1e-9, 13):
        q = quaternion(yaw)
        assert np.allclose([q.x, q.y, q.z, q.w], Rotation.from_euler("z", yaw).as_quat())  # (x, y, z, w)
        assert yaw_of(q) == pytest.approx(yaw)
    tilted = Rotation.from_euler("ZYX", [0.7, 0.0, 0.3]).as_quat()  # a roll leaves the heading alone
    assert yaw_of(Quaternion(*tilted)) == pytest.approx(0.7)


def test_se2_compose_inverse_between():
    a, b = np.array([1.0, 2.0, math.pi / 2]), np.array([1.0, 0.0, math.pi / 2])
    assert np.allclose(compose(a, b), [1.0, 3.0, -math.pi])  # one metre ahead of a is +y; yaw wraps to -pi
    assert np.allclose(compose(a, inverse(a)), [0.0, 0.0, 0.0])
    assert np.allclose(between(a, compose(a, b)), b)
    many = np.array([a, b, [0.0, 0.0, 0.0]])
    assert compose(many, b).shape == (3, 3) and np.allclose(compose(many, b)[0], compose(a, b))
    assert np.allclose(transform_points(a, np.array([[1.0, 0.0], [0.0, 1.0]])), [[1.0, 3.0], [0.0, 2.0]])


def test_pose_and_transform_messages_round_trip():
    p = np.array([-3.0, 0.5, 2.0])
    assert np.allclose(from_pose_msg(pose_msg(p)), p)
    t = transform_msg(p, 12.5, "map", "odom")
    assert (t.header.frame_id, t.child_frame_id, t.header.stamp.to_sec()) == ("map", "odom", 12.5)
    assert yaw_of(t.transform.rotation) == pytest.approx(2.0) and transform_msg(p, -1.0, "a", "b").header.stamp.secs == 0


def test_pinhole_from_fov_k_and_camera_info_are_one_model():
    kinect = Pinhole.from_fov(640, 480, math.radians(57.0))
    assert kinect.fx == pytest.approx(589.37, abs=0.01) and (kinect.cx, kinect.cy) == (319.5, 239.5)
    info = CameraInfo(width=640, height=480, K=kinect.K, P=kinect.P)
    assert Pinhole.from_camera_info(info) == kinect == Pinhole.from_k(kinect.K, 640, 480)
    assert Pinhole.from_camera_info(CameraInfo(width=640, height=480)) is None  # K unset: uncalibrated
    assert kinect.vfov_deg == pytest.approx(44.3, abs=0.1)


def test_pinhole_projects_as_opencv_does_and_back():
    cam = Pinhole(500.0, 480.0, 320.0, 240.0, 640, 480)
    points = np.array([[0.3, -0.2, 2.0], [-1.0, 0.5, 4.0]])
    expected, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), cam.matrix, np.zeros(5))
    for point, uv in zip(points, expected.reshape(-1, 2)):
        assert cam.pixel(*point) == pytest.approx(tuple(uv))
        assert cam.point(*cam.pixel(*point), point[2]) == pytest.approx(tuple(point))
    assert cam.bearing(320.0 - 500.0) == pytest.approx(math.pi / 4)  # left of centre: positive, turn left
    crop = cam.cropped(*cam.band(100))
    assert (crop.height, crop.cy) == (100, 50.0)  # rows 190..289: round(190.5) is 190


def test_one_error_class_names_the_file_and_the_field_or_line(tmp_path):
    assert MapError is WorldError is yamlfile.YamlFileError is InputFileError
    world = tmp_path / "w.yaml"
    world.write_text("map: m.yaml\nrobots: [{name: r, start: [1, 2]}]\n")
    with pytest.raises(InputFileError) as error:
        load_world(world)
    assert str(error.value).startswith(f"{world}: field ") and error.value.field and "\n" not in str(error.value)
    bad = tmp_path / "m.yaml"
    bad.write_text("resolution: [\n")
    with pytest.raises(InputFileError, match=r"m.yaml: field '\(file\)': line \d+: not valid YAML"):
        read_map_file(bad)
    with pytest.raises(InputFileError, match=r"m.yaml:\d+: not valid YAML"):
        yamlfile.load(bad, "map file")
    long = InputFileError("f.yaml", "x" * 1000, field="a")
    assert len(str(long)) < 340 and str(long).endswith("...")
