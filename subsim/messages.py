"""Simulation state as ROS messages (genpy classes, usable without a master or any transport).

Kept apart from the physics so the simulation stays numpy-only and from the bridge so the mapping from
state to messages can be tested message by message. Frames follow REP 105 (map -> odom -> base_link) and
ranges REP 117 (-inf too close, +inf nothing in range).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import genpy
import numpy as np
from geometry_msgs.msg import Pose, PoseArray, TransformStamped
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, LaserScan, Range
from std_msgs.msg import Header, UInt8, UInt32
from tf2_msgs.msg import TFMessage

from subsumption.pinhole import Pinhole
from subsumption.planar import quaternion

from .bodies import Agent, Robot
from .drivers import driver
from .mapio import GridMap
from .world import LaserSpec, RobotSpec, SonarSpec


@dataclass(frozen=True)
class Frames:
    """The tf frame names of one robot: '<ns>/odom', '<ns>/base_link', ... or bare names when ns is ''."""

    prefix: str
    laser_name: str = "laser"
    footprint_name: str | None = None  # REP 120's base_footprint, when the odometry's child frame is that

    @classmethod
    def of(cls, spec: RobotSpec) -> "Frames":
        named = driver(spec.kind)
        return cls(f"{spec.namespace}/" if spec.namespace else "", named.laser_frame, named.footprint)

    @property
    def footprint(self) -> str | None:
        return None if self.footprint_name is None else self.prefix + self.footprint_name

    @property
    def odom_child(self) -> str:
        """The frame odometry moves: base_footprint if the robot has one, else base_link."""
        return self.footprint or self.base

    @property
    def odom(self) -> str:
        return self.prefix + "odom"

    @property
    def base(self) -> str:
        return self.prefix + "base_link"

    @property
    def laser(self) -> str:
        return self.prefix + self.laser_name

    def sonar(self, i: int) -> str:
        return f"{self.prefix}sonar_{i}"

    # the camera's frames, named as openni_launch / the TurtleBot's description name them
    @property
    def camera_link(self) -> str:
        return self.prefix + "camera_link"

    @property
    def rgb(self) -> str:
        return self.prefix + "camera_rgb_frame"

    @property
    def rgb_optical(self) -> str:
        return self.prefix + "camera_rgb_optical_frame"

    @property
    def depth(self) -> str:
        return self.prefix + "camera_depth_frame"

    @property
    def depth_optical(self) -> str:
        return self.prefix + "camera_depth_optical_frame"


MAP_FRAME = "map"


def stamp(t: float) -> genpy.Time:
    return genpy.Time.from_sec(max(0.0, t))


def header(t: float | genpy.Time, frame: str) -> Header:
    """A header at time t (seconds, or a genpy.Time to share one stamp among a sweep's messages)."""
    return Header(0, t if isinstance(t, genpy.Time) else stamp(t), frame)  # positional: twice as fast


def pose(x: float, y: float, yaw: float) -> Pose:
    p = Pose()
    p.position.x, p.position.y = x, y
    p.orientation = quaternion(yaw)
    return p


def transform(t: float, parent: str, child: str, x: float, y: float, yaw: float) -> TransformStamped:
    msg = TransformStamped(header=header(t, parent), child_frame_id=child)
    msg.transform.translation.x, msg.transform.translation.y = x, y
    msg.transform.rotation = quaternion(yaw)
    return msg


def clock(t: float) -> Clock:
    return Clock(clock=stamp(t))


def laser_scan(t: float, frames: Frames, spec: LaserSpec, ranges: np.ndarray, period: float,
               zero_no_return: bool = False) -> LaserScan:
    """A sweep as LaserScan; `zero_no_return` sends 0.0 for a beam without a reading (too near or nothing in
    range), as older drivers (the TurtleBot 3's LDS-01) do, instead of REP 117's -inf/+inf."""
    angle_min, increment, angle_max = spec.angles()
    if zero_no_return:
        ranges = np.where(np.isfinite(ranges), ranges, 0.0)
    return LaserScan(
        header=header(t, frames.laser), angle_min=angle_min, angle_max=angle_max,
        angle_increment=increment, time_increment=0.0, scan_time=period,
        range_min=spec.min_range, range_max=spec.max_range, ranges=ranges.tolist(), intensities=[])


def sonar_ranges(t: float, frames: Frames, spec: SonarSpec, ranges: np.ndarray) -> list[Range]:
    fov = math.radians(spec.fov_deg)
    when = stamp(t)
    # fields in order: header, radiation_type, field_of_view, min_range, max_range, range
    return [Range(header(when, frames.sonar(i)), Range.ULTRASOUND, fov, spec.min_range, spec.max_range, r)
            for i, r in enumerate(ranges.tolist())]


def odometry(t: float, frame: str, child: str, x: float, y: float, yaw: float, v: float, w: float) -> Odometry:
    """Pose in `frame`, twist in the body frame `child`, as nav_msgs/Odometry specifies."""
    msg = Odometry(header=header(t, frame), child_frame_id=child)
    msg.pose.pose = pose(x, y, yaw)
    msg.twist.twist.linear.x, msg.twist.twist.angular.z = v, w
    return msg


def robot_odometry(t: float, robot: Robot, frames: Frames) -> Odometry:
    return odometry(t, frames.odom, frames.odom_child, *robot.odom, robot.v, robot.w)


def ground_truth(t: float, robot: Robot, frames: Frames) -> Odometry:
    return odometry(t, MAP_FRAME, frames.odom_child, robot.x, robot.y, robot.theta, robot.v, robot.w)


def map_to_odom(robot: Robot) -> tuple[float, float, float]:
    """The map -> odom transform that makes map -> odom -> base_link equal the true pose (drifts with noise)."""
    ox, oy, oth = robot.odom
    yaw = robot.theta - oth
    c, s = math.cos(yaw), math.sin(yaw)
    return robot.x - (c * ox - s * oy), robot.y - (s * ox + c * oy), yaw


def robot_tf(t: float, robot: Robot, frames: Frames, with_map: bool = True) -> list[TransformStamped]:
    """odom -> base_link (or base_footprint), and (with_map) the map -> odom that places the robot at its true
    pose."""
    odom = [transform(t, frames.odom, frames.odom_child, *robot.odom)]
    return [transform(t, MAP_FRAME, frames.odom, *map_to_odom(robot))] + odom if with_map else odom


def static_tf(robot: Robot, frames: Frames, sonar_mounts: np.ndarray) -> list[TransformStamped]:
    """base_footprint -> base_link (if the robot has a footprint frame), base_link -> laser (at the centre, at the
    driver's height) and base_link -> sonar_i (on the rim, facing outward)."""
    named = driver(robot.spec.kind)
    identity = (0.0, 0.0, 0.0, 1.0)
    out = []
    if frames.footprint is not None:
        out.append(transform3d(frames.footprint, frames.base, (0.0, 0.0, named.footprint_height), identity))
    if robot.spec.laser:
        out.append(transform(0.0, frames.base, frames.laser, 0.0, 0.0, 0.0) if not named.laser_height else
                   transform3d(frames.base, frames.laser, (0.0, 0.0, named.laser_height), identity))
    r = robot.radius
    out += [transform(0.0, frames.base, frames.sonar(i), r * math.cos(a), r * math.sin(a), float(a))
            for i, a in enumerate(sonar_mounts)]
    return out


# REP 103: an optical frame has z forward, x right, y down; from x forward, y left, z up that is the rotation
# roll -90 deg, yaw -90 deg (openni_launch's static transform), as a quaternion (x, y, z, w):
OPTICAL_ROTATION = (-0.5, 0.5, -0.5, 0.5)


def transform3d(parent: str, child: str, xyz: tuple[float, float, float],
                quat: tuple[float, float, float, float]) -> TransformStamped:
    msg = TransformStamped(header=header(0.0, parent), child_frame_id=child)
    msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = xyz
    r = msg.transform.rotation
    r.x, r.y, r.z, r.w = quat
    return msg


def camera_static_tf(robot: Robot, frames: Frames) -> list[TransformStamped]:
    """base_link -> camera_link (the camera's pose on the robot) -> camera_rgb_frame and camera_depth_frame (the
    same point: depth is registered to colour) -> their optical frames (z forward, REP 103)."""
    cam = robot.spec.camera
    if cam is None:
        return []
    identity = (0.0, 0.0, 0.0, 1.0)
    yaw = (0.0, 0.0, math.sin(cam.yaw / 2), math.cos(cam.yaw / 2))
    # the camera's height is above the floor; base_link is above base_footprint (the floor) on a posing kind
    z = cam.z - (driver(robot.spec.kind).footprint_height if frames.footprint is not None else 0.0)
    return [transform3d(frames.base, frames.camera_link, (cam.x, cam.y, z), yaw),
            transform3d(frames.camera_link, frames.rgb, (0.0, 0.0, 0.0), identity),
            transform3d(frames.camera_link, frames.depth, (0.0, 0.0, 0.0), identity),
            transform3d(frames.rgb, frames.rgb_optical, (0.0, 0.0, 0.0), OPTICAL_ROTATION),
            transform3d(frames.depth, frames.depth_optical, (0.0, 0.0, 0.0), OPTICAL_ROTATION)]


def camera_info(t: float | genpy.Time, frame: str, pinhole: Pinhole) -> CameraInfo:
    """A calibrated, undistorted pinhole (plumb_bob with zero D, R identity, P = [K | 0])."""
    return CameraInfo(header=header(t, frame), height=pinhole.height, width=pinhole.width,
                      distortion_model="plumb_bob", D=[0.0] * 5, K=pinhole.K,
                      R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], P=pinhole.P)


def tf_message(transforms: list[TransformStamped]) -> TFMessage:
    return TFMessage(transforms=transforms)


def agents(t: float, bodies: list[Agent]) -> PoseArray:
    return PoseArray(header=header(t, MAP_FRAME), poses=[pose(a.x, a.y, a.theta) for a in bodies])


def occupancy_grid(t: float, grid: GridMap) -> OccupancyGrid:
    rows, cols = grid.shape
    info = MapMetaData(map_load_time=stamp(t), resolution=grid.resolution, width=cols, height=rows,
                       origin=pose(grid.origin[0], grid.origin[1], 0.0))
    return OccupancyGrid(header=header(t, MAP_FRAME), info=info, data=grid.occupancy.ravel().tolist())


def bumper(bits: int) -> UInt8:
    return UInt8(data=bits)


def collisions(count: int) -> UInt32:
    return UInt32(data=count)
