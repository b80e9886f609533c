"""Small plane-geometry helpers the wander modules share."""
from __future__ import annotations

import math

from subsumption.planar import yaw_of

__all__ = ["wrap", "yaw_of"]


def wrap(angle: float) -> float:
    """The same angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


