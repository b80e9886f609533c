"""Level 4, pursuit: what the patrol robot does between "a suspicious face is found" and "back to patrol".

detect, track and follow (from :mod:`vision.modules`) find, keep and follow the target; ``pursuit`` is the
level's glue, the part that knows it is on a patrol robot:

- on detect's ``alarm`` it starts a pursuit: ``stop`` (a Bool at `rate`) is the upper line of the inhibitor on
  the motor line below follow's suppressor, so levels 0-3 (navigation, wander, avoid) are silenced at once and
  only follow drives; ``hold`` true pauses level 3's patrol (its goal under way is cancelled);
- it raises the ``intruder`` alarm with where the target is on the map: the alarm's point in the camera's
  optical frame, put on the map with the robot's pose at the image's time (amcl's correction of odometry, as
  tf's ``map -> odom``, applied to the odometry at that time) and the camera's place on the base;
- while track is ``confident`` the pursuit goes on; when the target has been lost for `lost_s` (it left the
  view, or turned its face away), the pursuit ends: ``stop`` falls silent (the inhibitor lets go after its
  time constant) and ``hold`` false sends the patrol back to the goal it was heading for.

Only sensor-derived messages drive it (detect's alarm, track's confidence, amcl's pose, odometry): no ground
truth.
"""
from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool

from navigation.scan_sync import OdometryHistory
from subsumption.planar import compose, from_pose_msg, inverse, pose_msg
from subsumption import Input, Module, Output, Param
from subsumption.planar import yaw_of

from .alarm import alarm_status


def on_map(point: PointStamped, robot_pose, camera_x: float, camera_y: float) -> tuple[float, float]:
    """Where a point in the camera's optical frame (x right, z ahead) is on the map, for a level camera at
    (camera_x, camera_y) on a robot at `robot_pose` (geometry_msgs/Pose in the map frame)."""
    ahead, left = point.point.z + camera_x, -point.point.x + camera_y
    yaw = yaw_of(robot_pose.orientation)
    c, s = math.cos(yaw), math.sin(yaw)
    return robot_pose.position.x + c * ahead - s * left, robot_pose.position.y + s * ahead + c * left


class Pursuit(Module):
    """Pursues a suspicious target from detect's alarm until it has been lost for `lost_s`: silences the lower
    levels' motor commands (`stop`, an inhibitor's upper line), pauses the patrol (`hold`) and raises the
    intruder alarm with the target's place on the map; then hands back to the patrol."""

    alarm = Input(PointStamped, "detect's alarm: a suspicious target found, where (camera optical frame)")
    suspect = Input(PointStamped, "detect's suspect: where the suspect is, each scan that sees it")
    confident = Input(Bool, "track's: whether the target's box is believed this frame")
    pose = Input(PoseWithCovarianceStamped, "amcl_pose: the robot on the map (to place the target)")
    odom = Input(Odometry, "odometry: how the robot moved between amcl's pose and the alarm's image")
    stop = Output(Bool, "true at `rate` while pursuing: the upper line of the inhibitor that stops levels 0-3")
    hold = Output(Bool, "level 3 patrol's hold: true while pursuing, false when the pursuit ends")
    trigger = Output(DiagnosticStatus, "the intruder alarm (where the target is, map frame) for the alarm module")
    target_pose = Output(PointStamped, "where the target is on the map, each time detect places it")
    lost_s = Param(5.0, "s the target may stay lost (no confident box) before the pursuit ends", min=0.1)
    rate = Param(10.0, "Hz of `stop` and `hold` while pursuing", min=1.0)
    refresh_s = Param(5.0, "s between repeated intruder triggers while the pursuit lasts (keeps the alarm raised)",
                      min=0.5)
    camera_x = Param(-0.087, "m: the camera ahead of the base's centre (TurtleBot Kinect)")
    camera_y = Param(0.0, "m: the camera left of the base's centre")
    frame_id = Param("map", "frame of the alarm's x, y")

    def setup(self) -> None:
        self.pursuing = False
        self.started_at: float | None = None
        self.ended_at: float | None = None
        self.pursuits = 0
        self._seen_at = -math.inf
        self._triggered_at = -math.inf
        self._where: tuple[float, float] | None = None
        self._timer = None
        self._odometry = OdometryHistory()
        self._map_to_odom: np.ndarray | None = None  # amcl's correction of odometry, as its map -> odom

    def on_odom(self, msg: Odometry) -> None:
        self._odometry.add(msg.header.stamp.to_sec(), from_pose_msg(msg.pose.pose))

    def on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        odom = self._odometry.at(msg.header.stamp.to_sec())
        if odom is not None:
            self._map_to_odom = compose(from_pose_msg(msg.pose.pose), inverse(odom))

    def robot_at(self, stamp: float):
        """The robot's pose on the map (geometry_msgs/Pose) when the image of `stamp` was taken: amcl's pose
        carried forward by odometry. amcl publishes only after the robot moved and on a scan that can be
        seconds old on a loaded graph; its pose as it stood put a target 4.9 m off (the robot had turned since).
        None without amcl's pose."""
        if self.registers.pose is None:
            return None
        odom = self._odometry.at(stamp)
        if odom is None and self._odometry.stamps and stamp >= self._odometry.latest:
            odom = self._odometry.poses[-1]  # an image newer than the odometry heard: the newest motion
        if self._map_to_odom is None or odom is None:
            return self.registers.pose.pose.pose
        return pose_msg(compose(self._map_to_odom, odom))

    def on_alarm(self, msg: PointStamped) -> None:
        now = self.now()
        self._seen_at = now
        self._locate(msg)
        if not self.pursuing:
            self.pursuing = True
            self.started_at = now
            self.pursuits += 1
            self.log(f"suspicious target: pursuit {self.pursuits} starts; lower levels stopped, patrol held")
            self._tick()  # stop and hold at once, then at `rate`
            self._timer = self.every(1.0 / self.rate, self._tick)
        self._raise(force=True)

    def on_suspect(self, msg: PointStamped) -> None:
        if self.pursuing:
            self._locate(msg)
            self._raise()

    def on_confident(self, msg: Bool) -> None:
        if msg.data:
            self._seen_at = self.now()

    def _locate(self, point: PointStamped) -> None:
        robot = self.robot_at(point.header.stamp.to_sec())
        if robot is not None:
            self._where = on_map(point, robot, self.camera_x, self.camera_y)
            placed = PointStamped()
            placed.header.stamp, placed.header.frame_id = point.header.stamp, self.frame_id
            placed.point.x, placed.point.y = self._where
            self.target_pose.publish(placed)

    def _raise(self, force: bool = False) -> None:
        now = self.now()
        if not force and now - self._triggered_at < self.refresh_s:
            return
        self._triggered_at = now
        if self._where is None:
            status = alarm_status("intruder", "Intruder ahead of the robot.")
        else:
            x, y = self._where
            status = alarm_status("intruder", f"Intruder at x {x:.1f}, y {y:.1f}.", x, y, self.frame_id)
        status.values.append(KeyValue("pursuit", str(self.pursuits)))
        self.trigger.publish(status)

    def _tick(self) -> None:
        now = self.now()
        if now - self._seen_at > self.lost_s:
            self._end(now)
            return
        self.stop.publish(Bool(True))
        self.hold.publish(Bool(True))

    def _end(self, now: float) -> None:
        self.pursuing = False
        self.ended_at = now
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self.log(f"target lost for {self.lost_s:g} s: pursuit {self.pursuits} ends, back to patrol")
        self.hold.publish(Bool(False))
        self.trigger.publish(alarm_status("intruder", "Intruder gone.", level=DiagnosticStatus.OK))


__all__ = ["Pursuit", "on_map"]
