"""Planar rigid motions (x, y, yaw) as numpy arrays: the small algebra SLAM and localization share.

A pose ``a`` places a frame in its parent; ``compose(a, b)`` is ``a (+) b`` (b given in a's frame),
``between(a, b)`` is ``a^-1 (+) b``, what odometry edges and pose-graph factors hold. Functions take a single
pose (shape (3,)) or many (shape (n, 3)) and broadcast, so a whole particle set moves in one call.
"""
from __future__ import annotations

import math

import numpy as np
import genpy
from geometry_msgs.msg import Pose, Quaternion, TransformStamped
from std_msgs.msg import Header

from subsumption.planar import yaw_of  # noqa: F401 - part of this module's API (poses from messages)


def wrap(angle):
    """Angle(s) into [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a (+) b: the pose b, given in the frame a places, in a's parent frame (x, y, yaw; arrays of poses too)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a: np.ndarray) -> np.ndarray:
    """The pose that undoes `a`: compose(inverse(a), a) is the identity."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1], wrap(-a[..., 2])], axis=-1)


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a^-1 (+) b: where b lies seen from a."""
    return compose(inverse(a), b)


def transform_points(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, 2) points of the frame `pose` places, in the parent frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    out = np.empty_like(points, dtype=float)
    out[:, 0] = pose[0] + c * points[:, 0] - s * points[:, 1]
    out[:, 1] = pose[1] + s * points[:, 0] + c * points[:, 1]
    return out


def quaternion(yaw: float) -> Quaternion:
    """The quaternion of a rotation by `yaw` radians about z."""
    return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def pose_msg(p: np.ndarray) -> Pose:
    """A planar pose (x, y, yaw) as a geometry_msgs/Pose."""
    msg = Pose()
    msg.position.x, msg.position.y = float(p[0]), float(p[1])
    msg.orientation = quaternion(float(p[2]))
    return msg


def from_pose_msg(msg: Pose) -> np.ndarray:
    """A geometry_msgs/Pose as a planar pose (x, y, yaw), the yaw read from its quaternion."""
    return np.array([msg.position.x, msg.position.y, yaw_of(msg.orientation)])


def transform_msg(pose: np.ndarray, stamp: float, parent: str, child: str) -> TransformStamped:
    """The tf message placing `child` at planar `pose` in `parent`."""
    msg = TransformStamped(header=Header(0, genpy.Time.from_sec(max(stamp, 0.0)), parent), child_frame_id=child)
    msg.transform.translation.x, msg.transform.translation.y = float(pose[0]), float(pose[1])
    msg.transform.rotation = quaternion(float(pose[2]))
    return msg
