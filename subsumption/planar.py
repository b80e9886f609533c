"""Headings in the plane from ROS messages: the one formula every package that reads a pose needs (the core,
the robots, navigation and vision each used to carry a copy)."""
from __future__ import annotations

import math

from geometry_msgs.msg import Quaternion


def yaw_of(q: Quaternion) -> float:
    """Rotation about z of a (planar) quaternion (REP 103: counter-clockwise from +x)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
