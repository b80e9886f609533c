"""Small plane-geometry helpers the wander modules share."""
from __future__ import annotations

import math

from geometry_msgs.msg import Quaternion


def wrap(angle: float) -> float:
    """The same angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def yaw_of(q: Quaternion) -> float:
    """Rotation about z of a (planar) quaternion."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
