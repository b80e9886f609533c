"""Feed camera frames through detect, track and follow on a LocalRuntime and record what they send.

For tests and ``bench.vision``: frames come from anywhere (composited photos, the simulator's camera or a bag)
as anything with ``rgb`` and ``depth`` arrays, and reach the modules only as ``sensor_msgs/Image`` and ``CameraInfo``
messages, exactly as under ROS. The wiring is level 4's: detect's target line into track (through a suppressor
with the operator's ``terminal/target`` in the real network), track's box_info into follow.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Protocol

import genpy
import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped, Twist
from sensor_msgs.msg import CameraInfo, Image, RegionOfInterest
from std_msgs.msg import Header

from subsumption.images import from_array
from subsumption.local import LocalRuntime
from subsumption.pinhole import Pinhole

from .modules import Detect, Follow, Track

KINECT = Pinhole.from_fov(640, 480, math.radians(57.0))  # a TurtleBot's Kinect: 640x480, 57 degrees across


class Frame(Protocol):
    """A camera frame: RGB (h, w, 3) uint8 and registered depth (h, w) float32 in metres."""

    rgb: np.ndarray
    depth: np.ndarray


def camera_messages(rgb: np.ndarray, depth: np.ndarray, stamp_s: float, camera: Pinhole = KINECT,
                    frame_id: str = "camera_rgb_optical_frame") -> tuple[Image, Image, CameraInfo]:
    """A frame as a Kinect driver publishes it: (rgb8 Image, 32FC1 depth Image, CameraInfo), one header. The
    CameraInfo is `camera`'s focal length centred on the frame (a frame of another size is a crop of it)."""
    header = Header(stamp=genpy.Time.from_sec(stamp_s), frame_id=frame_id)
    height, width = depth.shape
    k = Pinhole(camera.fx, camera.fy, (width - 1) / 2.0, (height - 1) / 2.0, width, height)
    info = CameraInfo(header=header, width=width, height=height, distortion_model="plumb_bob", D=[0.0] * 5,
                      K=k.K, R=np.eye(3).ravel().tolist(), P=k.P)
    return from_array(rgb, "rgb8", header), from_array(depth, "32FC1", header), info


@dataclass
class Recording:
    """Every message the pipeline sent, with the simulated time it was sent at."""

    alarms: list[tuple[float, PointStamped]] = field(default_factory=list)
    targets: list[tuple[float, RegionOfInterest]] = field(default_factory=list)
    suspects: list[tuple[float, PointStamped]] = field(default_factory=list)
    intruders: list[tuple[float, DiagnosticStatus]] = field(default_factory=list)
    boxes: list[tuple[float, CameraInfo]] = field(default_factory=list)
    commands: list[tuple[float, Twist]] = field(default_factory=list)


class Pipeline:
    """detect -> track -> follow on their own LocalRuntime, camera topics as a Kinect driver names them."""

    def __init__(self, detect: Mapping[str, Any] | None = None, track: Mapping[str, Any] | None = None,
                 follow: Mapping[str, Any] | None = None) -> None:
        self.runtime = LocalRuntime()
        camera = {"image": "/camera/rgb/image_raw", "depth": "/camera/depth/image_raw",
                  "camera_info": "/camera/rgb/camera_info"}
        self.detect = self.runtime.add_module(Detect, "detect", remap=camera, params=detect)
        self.track = self.runtime.add_module(
            Track, "track", remap={**camera, "target": "/detect/target"}, params=track)
        self.follow = self.runtime.add_module(
            Follow, "follow", remap={"box_info": "/track/box_info", "depth": "/camera/depth/image_raw",
                                     "alarm": "/detect/alarm"}, params=follow)
        driver = self.runtime.node("camera_driver")
        self._publish = {name: driver.publisher(topic, kind) for name, topic, kind in (
            ("info", "/camera/rgb/camera_info", CameraInfo),
            ("depth", "/camera/depth/image_raw", Image), ("image", "/camera/rgb/image_raw", Image))}
        self.recording = Recording()
        recorder = self.runtime.node("recorder")
        for topic, kind, store in (("/detect/alarm", PointStamped, self.recording.alarms),
                                   ("/detect/target", RegionOfInterest, self.recording.targets),
                                   ("/detect/suspect", PointStamped, self.recording.suspects),
                                   ("/detect/intruder", DiagnosticStatus, self.recording.intruders),
                                   ("/track/box_info", CameraInfo, self.recording.boxes),
                                   ("/follow/cmd_vel", Twist, self.recording.commands)):
            recorder.subscribe(topic, kind, lambda msg, store=store: store.append((self.runtime.now(), msg)))

    def feed(self, t: float, frame: Frame) -> None:
        """One camera frame at time t: camera_info, depth, then the colour image (the modules act on it)."""
        self.runtime.run_until(t)
        image, depth, info = camera_messages(frame.rgb, frame.depth, t)
        self._publish["info"].publish(info)
        self._publish["depth"].publish(depth)
        self._publish["image"].publish(image)
        self.runtime.run_for(0.0)

    def run(self, frames: Iterable[tuple[float, Frame]]) -> Recording:
        """Feeds every (time, frame) in turn; what the modules sent."""
        for t, frame in frames:
            self.feed(t, frame)
        return self.recording


__all__ = ["Frame", "KINECT", "Pipeline", "Recording", "camera_messages"]
