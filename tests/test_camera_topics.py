"""The camera on the graph (LocalRuntime, and the simulator node under a private ROS master): the topics a
Kinect driver publishes, their encodings, CameraInfo, optical frames in tf_static, rates."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from tf2_msgs.msg import TFMessage

import subsim
import subsim.local
from subsumption.images import from_compressed, to_depth_m, to_rgb
from subsumption.local import LocalRuntime

ROOT = Path(__file__).resolve().parent.parent
TOPICS = {"/camera/rgb/image_raw": Image, "/camera/rgb/image_raw/compressed": CompressedImage,
          "/camera/rgb/camera_info": CameraInfo, "/camera/depth/image_raw": Image,
          "/camera/depth/camera_info": CameraInfo}


def quat_rotate(q, v):
    """Rotate vector v by quaternion q = (x, y, z, w)."""
    x, y, z, w = q
    u = np.array([x, y, z])
    v = np.asarray(v, float)
    return 2 * np.dot(u, v) * u + (w * w - np.dot(u, u)) * v + 2 * w * np.cross(u, v)


def listen(world, seconds: float):
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, world)
    got: dict[str, list] = {topic: [] for topic in TOPICS}
    node = runtime.node("listener")
    for topic, kind in TOPICS.items():
        node.subscribe(topic, kind, lambda msg, topic=topic: got[topic].append(msg))
    statics: list = []
    node.subscribe("/tf_static", TFMessage, lambda msg: statics.extend(msg.transforms))
    runtime.run_for(seconds)
    return bridge, got, statics


def test_kinect_topics_on_the_local_runtime():
    bridge, got, statics = listen(subsim.world_path("pingpong"), 2.0)
    counts = {topic: len(msgs) for topic, msgs in got.items()}
    assert all(abs(n - 61) <= 2 for n in counts.values()), counts  # 30 Hz for 2 s, and one at the start
    rgb_msg, depth_msg = got["/camera/rgb/image_raw"][-1], got["/camera/depth/image_raw"][-1]
    assert (rgb_msg.encoding, depth_msg.encoding) == ("rgb8", "16UC1")  # OpenNI's depth: mm, 0 = no reading
    assert rgb_msg.header.stamp == depth_msg.header.stamp
    assert rgb_msg.header.frame_id == "camera_rgb_optical_frame"
    assert depth_msg.header.frame_id == "camera_depth_optical_frame"
    rgb, depth = to_rgb(rgb_msg), to_depth_m(depth_msg)
    assert rgb.shape == (480, 640, 3) and depth.shape == (480, 640)
    frame = bridge.sim.render("robot0")  # nothing moved since the last frame: the robot had no command
    assert np.array_equal(rgb, frame.rgb)
    assert np.array_equal(np.isnan(depth), np.isnan(frame.depth))
    assert np.nanmax(np.abs(depth - frame.depth)) <= 0.0005 + 1e-6  # rounded to the millimetre
    jpeg = from_compressed(got["/camera/rgb/image_raw/compressed"][-1])
    assert np.abs(jpeg.astype(int) - rgb).mean() < 6
    info = got["/camera/rgb/camera_info"][-1]
    f = 320 / np.tan(np.radians(28.5))
    assert list(info.K) == pytest.approx([f, 0, 319.5, 0, f, 239.5, 0, 0, 1])
    assert list(info.P) == pytest.approx([f, 0, 319.5, 0, 0, f, 239.5, 0, 0, 0, 1, 0])
    assert (info.width, info.height, info.distortion_model) == (640, 480, "plumb_bob")
    assert info.header.frame_id == rgb_msg.header.frame_id
    tf = {t.child_frame_id: t for t in statics}
    mount = tf["camera_link"]
    assert mount.header.frame_id == "base_link"
    assert (mount.transform.translation.x, mount.transform.translation.z) == (-0.087, 0.287)
    for optical, parent in (("camera_rgb_optical_frame", "camera_rgb_frame"),
                            ("camera_depth_optical_frame", "camera_depth_frame")):
        t = tf[optical]
        assert t.header.frame_id == parent and tf[parent].header.frame_id == "camera_link"
        r = t.transform.rotation
        q = (r.x, r.y, r.z, r.w)
        # REP 103: the optical z axis is the body's x (forward), optical x is right (-y), optical y is down (-z)
        assert quat_rotate(q, [0, 0, 1]) == pytest.approx([1, 0, 0], abs=1e-9)
        assert quat_rotate(q, [1, 0, 0]) == pytest.approx([0, -1, 0], abs=1e-9)
        assert quat_rotate(q, [0, 1, 0]) == pytest.approx([0, 0, -1], abs=1e-9)


def test_depth_band_mode_publishes_only_the_band_with_its_own_camera_info(tmp_path):
    world = yaml.safe_load(subsim.world_path("pingpong").read_text())
    world["map"] = str(subsim.MAPS / world["map"])
    for picture in world["scene"]["pictures"] + [world["agents"][0]["picture"]]:
        picture["file"] = str(subsim.MAPS / picture["file"])
    world["robots"][0]["sensors"] = {"camera": {"mode": "depth_band", "depth_encoding": "32FC1"}}
    path = tmp_path / "band_world.yaml"
    path.write_text(yaml.safe_dump(world))
    bridge, got, _ = listen(path, 0.5)
    assert got["/camera/rgb/image_raw"] == [] and got["/camera/rgb/image_raw/compressed"] == []
    depth, info = got["/camera/depth/image_raw"][-1], got["/camera/depth/camera_info"][-1]
    assert (depth.height, depth.width, info.height, info.width) == (10, 640, 10, 640)
    assert depth.encoding == "32FC1"  # metres as rendered, NaN = no reading (REP 118 allows both)
    assert np.array_equal(to_depth_m(depth), bridge.sim.render("robot0").depth, equal_nan=True)
    assert info.K[5] == pytest.approx(239.5 - 235)  # cy of the band: rows 235..244


CHECKER = r"""
import json, time, rospy
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
counts = {}
first = {}
def seen(topic, msg):
    counts[topic] = counts.get(topic, 0) + 1
    first.setdefault(topic, getattr(msg, "encoding", getattr(msg, "format", "")))
rospy.init_node("camera_checker")
for topic, kind in (("/camera/rgb/image_raw", Image), ("/camera/depth/image_raw", Image),
                    ("/camera/rgb/camera_info", CameraInfo), ("/camera/rgb/image_raw/compressed", CompressedImage)):
    rospy.Subscriber(topic, kind, lambda m, t=topic: seen(t, m), queue_size=5)
deadline = time.monotonic() + 40
while time.monotonic() < deadline and counts.get("/camera/depth/image_raw", 0) < 3:
    time.sleep(0.1)
start = rospy.get_time(); n0 = dict(counts)
time.sleep(3.0)
span = rospy.get_time() - start
print(json.dumps({"rates": {t: (counts.get(t, 0) - n0.get(t, 0)) / span for t in counts}, "first": first}))
"""


@pytest.mark.timeout(120)
def test_camera_topics_under_ros(ros_processes):
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"),
                         f"_world:={subsim.world_path('pingpong')}", "_rate:=1.0"])
    checker = ros_processes.start([sys.executable, "-c", CHECKER])
    checker.wait(timeout=90)
    from conftest import output_of
    result = json.loads(output_of(checker).strip().splitlines()[-1])
    assert result["first"]["/camera/rgb/image_raw"] == "rgb8"
    assert result["first"]["/camera/depth/image_raw"] == "16UC1"
    assert "jpeg" in result["first"]["/camera/rgb/image_raw/compressed"]
    # 30 Hz of simulated time at real time (a loaded machine may drop a few on the way)
    assert result["rates"]["/camera/depth/image_raw"] > 15, result
