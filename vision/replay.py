"""Feed camera frames through detect, track and follow on a LocalRuntime and record what they send.

For tests and ``bench/vision``: frames come from anywhere (composited photos today, the simulator's camera or
a bag tomorrow) as (time, rgb, depth) and reach the modules only as ``sensor_msgs/Image`` and ``CameraInfo``
messages, exactly as under ROS. The wiring is level 4's: detect's target line into track (through a suppressor
with the operator's ``terminal/target`` in the real network), track's box_info into follow.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped, Twist
from sensor_msgs.msg import CameraInfo, Image, RegionOfInterest

from subsumption.local import LocalRuntime

from .modules import Detect, Follow, Track
from .photoscene import Frame, messages


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
        image, depth, info = messages(frame, t)
        self._publish["info"].publish(info)
        self._publish["depth"].publish(depth)
        self._publish["image"].publish(image)
        self.runtime.run_for(0.0)

    def run(self, frames: Iterable[tuple[float, Frame]]) -> Recording:
        """Feed every (time, frame) pair through the pipeline and return what it recorded."""
        for t, frame in frames:
            self.feed(t, frame)
        return self.recording


__all__ = ["Pipeline", "Recording"]
