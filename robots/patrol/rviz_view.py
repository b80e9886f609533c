"""What rviz cannot draw by itself from the patrol robot's topics: the tracked box on the camera image, and the
alarms. launch/patrol.launch runs it with ``rviz:=true`` (launch/patrol.rviz shows both).

rviz's Image display shows an image as it is, and no display reads a ``sensor_msgs/RegionOfInterest`` or a
``diagnostic_msgs/DiagnosticArray``. So this module draws track's box (green while tracking) onto the newest
colour frame and publishes that as ``camera`` (rgb8, at most ``max_rate`` Hz: rviz need not get every frame),
and turns the alarm list into text markers: one line per alarm over the robot (frame ``robot_frame``), and a
red sphere where an alarm says it happened (its ``x``/``y`` values). An empty alarm list deletes the markers.
"""
from __future__ import annotations

import cv2
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Point, Pose, Quaternion, Vector3
from sensor_msgs.msg import Image, RegionOfInterest
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from subsumption import Input, Module, Output, Param
from subsumption.images import ImageEncodingError, from_array, to_rgb

LEVEL_NAMES = {DiagnosticStatus.OK: "OK", DiagnosticStatus.WARN: "ALARM", DiagnosticStatus.ERROR: "ALARM",
               DiagnosticStatus.STALE: "STALE"}


class RvizView(Module):
    """The camera with the tracked box drawn on it, and the alarms as rviz markers."""

    image = Input(Image, "the colour camera (camera/rgb/image_raw)", latest=True)
    box = Input(RegionOfInterest, "track's box on that image (all zero while nothing is tracked)")
    alarms = Input(DiagnosticArray, "the alarms raised now (the alarm module's list)")
    camera = Output(Image, "the newest frame with the box drawn on it (rgb8)")
    markers = Output(MarkerArray, "the alarms: text over the robot, a sphere where each happened")
    max_rate = Param(5.0, "Hz: frames drawn at most", min=0.1)
    robot_frame = Param("base_link", "frame the alarm text hangs over")
    map_frame = Param("map", "frame of an alarm's x and y when it names none")

    def setup(self) -> None:
        self._last_frame = -1e9
        self._shown = 0  # markers published last time: deleted when the list shrinks

    def on_image(self, msg: Image) -> None:
        if self.now() - self._last_frame < 1.0 / float(self.max_rate):
            return
        try:
            rgb = to_rgb(msg).copy()
        except ImageEncodingError as error:
            self.log_once("encoding", f"camera image not drawn: {error}")
            return
        self._last_frame = self.now()
        box = self.registers.box
        if box is not None and box.width > 0 and box.height > 0:
            x, y = int(box.x_offset), int(box.y_offset)
            cv2.rectangle(rgb, (x, y), (x + int(box.width), y + int(box.height)), (40, 220, 40), 3)
        self.camera.publish(from_array(rgb, "rgb8", msg.header))

    def on_alarms(self, msg: DiagnosticArray) -> None:
        markers = []
        stamp = msg.header.stamp
        for i, status in enumerate(msg.status):
            text = f"{LEVEL_NAMES.get(status.level, 'ALARM')}: {status.name}: {status.message}"
            markers.append(Marker(header=Header(stamp=stamp, frame_id=self.robot_frame), ns="alarm text", id=i,
                                  type=Marker.TEXT_VIEW_FACING, action=Marker.ADD, text=text,
                                  pose=Pose(Point(0.0, 0.0, 0.8 + 0.35 * i), Quaternion(0, 0, 0, 1)),
                                  scale=Vector3(0, 0, 0.3), color=ColorRGBA(1.0, 0.2, 0.2, 1.0)))
            where = {kv.key: kv.value for kv in status.values}
            if "x" in where and "y" in where:
                try:
                    x, y = float(where["x"]), float(where["y"])
                except ValueError:
                    continue
                markers.append(Marker(header=Header(stamp=stamp, frame_id=where.get("frame") or self.map_frame),
                                      ns="alarm place", id=i, type=Marker.SPHERE, action=Marker.ADD,
                                      pose=Pose(Point(x, y, 0.3), Quaternion(0, 0, 0, 1)),
                                      scale=Vector3(0.4, 0.4, 0.4), color=ColorRGBA(1.0, 0.0, 0.0, 0.7)))
        for i in range(len(msg.status), self._shown):
            markers += [Marker(ns=ns, id=i, action=Marker.DELETE) for ns in ("alarm text", "alarm place")]
        self._shown = len(msg.status)
        self.markers.publish(MarkerArray(markers))
