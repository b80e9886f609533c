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
from nav_msgs.msg import OccupancyGrid, Odometry
from sensor_msgs.msg import RegionOfInterest
from std_msgs.msg import Bool

from navigation.scan_sync import OdometryHistory
from subsumption.planar import compose, from_pose_msg, inverse, pose_msg
from subsumption import Input, Module, Output, Param
from subsumption.mapfile import OCCUPIED
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


class Posters(Module):
    """Passes detect's alarm, target and suspect on, except for a face that hangs on a wall and stays there: a
    poster (the Chelsea cat passed for a face and the robot followed the wall for 8 s while the real stranger
    went unseen). The face's place on the map (as the pursuit places it: the alarm's point, the robot's pose at
    the image's time, the camera's place on the base) within `wall_m` of an occupied cell of the patrol's own map
    is held back; each later sighting (detect's suspect, every scan) is placed too, and the held alarm goes on,
    late, the moment the face is off the wall or has moved `moved_m` from where it was first seen: a person
    walking along a wall is still found. A person stands at least a body's half-width off a wall, with the face
    on the side of the body turned to the robot; a poster's place is the wall itself (within the depth's and
    amcl's error). An alarm raised before the robot can place it (no amcl pose or map yet) is judged on its first
    sighting that can be placed, or passed on after `judge_wait` s without one. Ground truth plays no part: the
    map is the robot's own."""

    alarm = Input(PointStamped, "detect's alarm (camera optical frame)")
    suspect = Input(PointStamped, "detect's suspect, each scan that sees it")
    target = Input(RegionOfInterest, "detect's target box, for the tracker")
    map = Input(OccupancyGrid, "the patrol's map (map_server)")
    pose = Input(PoseWithCovarianceStamped, "amcl_pose: the robot on the map")
    odom = Input(Odometry, "odometry: the robot's motion between amcl's pose and the image")
    passed_alarm = Output(PointStamped, "the alarm of a face that is not a poster")
    passed_suspect = Output(PointStamped, "the suspect's sightings once its alarm went on")
    passed_target = Output(RegionOfInterest, "the target box once its alarm went on")
    wall_m = Param(0.15, "m: a face placed this near an occupied cell of the map hangs on the wall", min=0.0)
    moved_m = Param(0.4, "m: a face held back as a poster that moves this far from its first place is a person",
                    min=0.0)
    camera_x = Param(-0.087, "m: the camera ahead of the base's centre (TurtleBot Kinect)")
    camera_y = Param(0.0, "m: the camera left of the base's centre")
    judge_wait = Param(2.0, "s an alarm that cannot be placed on the map yet (no amcl pose or map) is held for a "
                            "sighting that can; still unplaced after this, it is passed on", min=0.0)

    def setup(self) -> None:
        self._places = RobotPlaces()
        self._clearance: np.ndarray | None = None  # m from each cell to the nearest occupied one
        self._grid = None
        self.held: tuple[PointStamped, tuple[float, float]] | None = None  # an alarm held back, where first seen
        self._held_target: RegionOfInterest | None = None
        self._passing = False  # the current suspect's alarm went on
        self.posters = 0  # alarms held back and never passed

    def on_map(self, msg: OccupancyGrid) -> None:
        from scipy.ndimage import distance_transform_edt

        from navigation.grid_messages import grid_of

        self._grid = grid_of(msg, self.node.resolve("map"))
        self._clearance = distance_transform_edt(self._grid.occupancy != OCCUPIED) * self._grid.resolution

    def on_odom(self, msg: Odometry) -> None:
        self._places.add_odometry(msg)

    def on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        self._places.add_pose(msg)

    def place(self, point: PointStamped) -> tuple[float, float] | None:
        robot = self._places.robot_at(point.header.stamp.to_sec())
        return None if robot is None else on_map(point, robot, self.camera_x, self.camera_y)

    def judgeable(self, where: tuple[float, float] | None) -> bool:
        """Whether a face's place can be held against the map: both are known."""
        return where is not None and self._clearance is not None

    def on_wall(self, where: tuple[float, float] | None) -> bool:
        if not self.judgeable(where):
            return False
        row, col = self._grid.cell_of(*where)
        rows, cols = self._clearance.shape
        if not (0 <= row < rows and 0 <= col < cols):
            return False
        return bool(self._clearance[row, col] <= self.wall_m)

    def on_alarm(self, msg: PointStamped) -> None:
        """A face confirmed: passed on at once if it stands off the wall; held back if it hangs on one, or if the
        robot cannot place it yet (early in a run amcl may not have spoken: a poster then passed unjudged)."""
        where = self.place(msg)
        self._passing = False
        if not self.judgeable(where):
            self.held = (msg, None)  # type: ignore[assignment]
            self.log(f"a face, but no pose or map to place it by yet: alarm held up to {self.judge_wait:.1f} s")
            self.after(self.judge_wait, lambda held=self.held: self._judge_late(held))
            return
        if self.on_wall(where):
            self._hold_as_poster(msg, where)
            return
        self._pass(msg)

    def _hold_as_poster(self, msg: PointStamped, where: tuple[float, float]) -> None:
        self.held = (msg, where)  # type: ignore[assignment]
        self.posters += 1
        self.log(f"a face on the wall at x {where[0]:.2f}, y {where[1]:.2f}: a poster? alarm held back", "warn")

    def _judge_late(self, held) -> None:
        """`judge_wait` s after an alarm that could not be placed: if it still could not, a face is a face."""
        if self.held is held and held[1] is None:
            self.log(f"no pose or map to place the face by after {self.judge_wait:.1f} s: alarm passed on", "warn")
            self._pass(held[0])

    def on_target(self, msg: RegionOfInterest) -> None:
        if self.held is not None and not self._passing:
            self._held_target = msg
        else:
            self.passed_target.publish(msg)

    def on_suspect(self, msg: PointStamped) -> None:
        if self._passing:
            self.passed_suspect.publish(msg)
            return
        if self.held is None:
            return
        where = self.place(msg)
        _, first = self.held
        if first is None:  # an alarm that could not be placed: judged on its first sighting that can
            if not self.judgeable(where):
                return
            if self.on_wall(where):
                self._hold_as_poster(msg, where)
                return
            self.log(f"the face is off the wall at x {where[0]:.2f}, y {where[1]:.2f}: a person; alarm passed on")
            self._pass(msg)
            return
        moved = where is not None and math.hypot(where[0] - first[0], where[1] - first[1]) >= self.moved_m
        if where is not None and (moved or not self.on_wall(where)):
            self.log(f"the face held back is {'moving' if moved else 'off the wall'} at x {where[0]:.2f}, "
                     f"y {where[1]:.2f}: a person; alarm passed on")
            self.posters -= 1
            self._pass(msg)

    def _pass(self, msg: PointStamped) -> None:
        self._passing = True
        self.held = None
        self.passed_alarm.publish(msg)
        if self._held_target is not None:
            self.passed_target.publish(self._held_target)
            self._held_target = None


class RobotPlaces:
    """The robot's pose on the map at an image's time: amcl's pose carried forward by odometry (see
    :meth:`Pursuit.robot_at`)."""

    def __init__(self) -> None:
        self._odometry = OdometryHistory()
        self._map_to_odom: np.ndarray | None = None
        self._pose: PoseWithCovarianceStamped | None = None

    def add_odometry(self, msg: Odometry) -> None:
        self._odometry.add(msg.header.stamp.to_sec(), from_pose_msg(msg.pose.pose))

    def add_pose(self, msg: PoseWithCovarianceStamped) -> None:
        self._pose = msg
        odom = self._odometry.at(msg.header.stamp.to_sec())
        if odom is not None:
            self._map_to_odom = compose(from_pose_msg(msg.pose.pose), inverse(odom))

    def robot_at(self, stamp: float):
        if self._pose is None:
            return None
        odom = self._odometry.at(stamp)
        if odom is None and self._odometry.stamps and stamp >= self._odometry.latest:
            odom = self._odometry.poses[-1]
        if self._map_to_odom is None or odom is None:
            return self._pose.pose.pose
        return pose_msg(compose(self._map_to_odom, odom))


__all__ = ["Posters", "Pursuit", "RobotPlaces", "on_map"]
