"""Planar geometry: angles, headings and rigid motions (x, y, yaw) in the plane, and their ROS messages.

The one copy every package uses (the simulator, the robots, navigation, vision, the terminal and the experiments
each used to carry its own ``wrap``, ``quaternion`` or yaw formula). A pose ``a`` places a frame in its parent;
``compose(a, b)`` is ``a (+) b`` (b given in a's frame), ``between(a, b)`` is ``a^-1 (+) b``, what odometry edges
and pose-graph factors hold. The SE(2) functions take a single pose (shape (3,)) or many (shape (n, 3)) and
broadcast, so a whole particle set moves in one call.
"""
from __future__ import annotations

import math

import genpy
import numpy as np
from geometry_msgs.msg import Pose, Quaternion, TransformStamped
from std_msgs.msg import Header

__all__ = ["wrap", "yaw_of", "quaternion", "compose", "inverse", "between", "transform_points", "pose_msg",
           "from_pose_msg", "transform_msg"]


def wrap(angle):
    """The same angle(s) in [-pi, pi): a float for a number (behaviour code turns by it), an array for an
    array (a particle set's headings in one call)."""
    if isinstance(angle, (int, float)) or np.ndim(angle) == 0:  # a numpy scalar too: a float, never a 0-d array
        return (float(angle) + math.pi) % math.tau - math.pi
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def yaw_of(q: Quaternion) -> float:
    """Rotation about z of a (planar) quaternion (REP 103: counter-clockwise from +x)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def quaternion(yaw: float) -> Quaternion:
    """The quaternion of a rotation by `yaw` (rad) about z: the orientation of a planar pose."""
    return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a (+) b: the pose b, given in the frame a places, in a's parent frame."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a: np.ndarray) -> np.ndarray:
    """a^-1: the parent's pose seen from the frame a places."""
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


def pose_msg(p) -> Pose:
    """A geometry_msgs/Pose on the floor (z 0) at planar pose p = (x, y, yaw)."""
    msg = Pose()
    msg.position.x, msg.position.y = float(p[0]), float(p[1])
    msg.orientation = quaternion(float(p[2]))
    return msg


def from_pose_msg(msg: Pose) -> np.ndarray:
    """The planar pose (x, y, yaw) of a geometry_msgs/Pose (its height and tilt dropped)."""
    return np.array([msg.position.x, msg.position.y, yaw_of(msg.orientation)])


def transform_msg(pose, stamp: float, parent: str, child: str) -> TransformStamped:
    """The tf message placing `child` at planar `pose` in `parent` at time `stamp` (s; clamped at 0)."""
    msg = TransformStamped(header=Header(0, genpy.Time.from_sec(max(stamp, 0.0)), parent), child_frame_id=child)
    msg.transform.translation.x, msg.transform.translation.y = float(pose[0]), float(pose[1])
    msg.transform.rotation = quaternion(float(pose[2]))
    return msg
