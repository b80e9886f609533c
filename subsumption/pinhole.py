"""The pinhole camera model: intrinsics from a CameraInfo's K, from a field of view, and the geometry between
pixels and rays.

One model for every package: the simulator renders with it and publishes its K and P, vision turns boxes into
bearings and points with it, the experiments project true face boxes with it, and the vision tests composite
photographs with it. Conventions are ROS's (REP 103 optical frame: z forward, x right, y down; K and P as
``sensor_msgs/CameraInfo`` lists them, row-major); a pixel's centre has integer coordinates, so the principal
point of a centred camera is ``((width - 1) / 2, (height - 1) / 2)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

__all__ = ["Pinhole"]


@dataclass(frozen=True)
class Pinhole:
    """A camera's intrinsics (pixels) and its image size."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    @classmethod
    def from_k(cls, k: Sequence[float], width: int, height: int) -> "Pinhole | None":
        """From CameraInfo.K (9 numbers, row-major) and the image size; None when K is unset (all zeros), as an
        uncalibrated driver sends it."""
        k = [float(v) for v in k]
        if len(k) != 9 or not k[0] > 0 or not k[4] > 0:
            return None
        return cls(k[0], k[4], k[2], k[5], int(width), int(height))

    @classmethod
    def from_camera_info(cls, info) -> "Pinhole | None":
        """From a sensor_msgs/CameraInfo (its K, width and height); None when K is unset."""
        return cls.from_k(info.K, info.width, info.height)

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_rad: float) -> "Pinhole":
        """A centred camera with square pixels whose image spans `hfov_rad` across: ``f = (width / 2) /
        tan(hfov / 2)`` (a Kinect: 640 px, 57 degrees, about 589 px)."""
        f = (width / 2.0) / math.tan(hfov_rad / 2.0)
        return cls(f, f, (width - 1) / 2.0, (height - 1) / 2.0, int(width), int(height))

    @property
    def K(self) -> list[float]:
        """The 3x3 camera matrix, row-major, as CameraInfo.K holds it."""
        return [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0]

    @property
    def P(self) -> list[float]:
        """The 3x4 projection matrix [K | 0] of an undistorted monocular camera, as CameraInfo.P holds it."""
        return [self.fx, 0.0, self.cx, 0.0, 0.0, self.fy, self.cy, 0.0, 0.0, 0.0, 1.0, 0.0]

    @property
    def matrix(self) -> np.ndarray:
        """K as a 3x3 numpy array (what OpenCV's calls take)."""
        return np.array(self.K).reshape(3, 3)

    @property
    def vfov_deg(self) -> float:
        """The vertical field of view (degrees) of the whole image."""
        return math.degrees(2 * math.atan((self.height / 2.0) / self.fy))

    def band(self, rows: int) -> tuple[int, int]:
        """The image rows [row0, row1) of a band of `rows` rows centred on the optical centre's row."""
        row0 = max(0, int(round(self.cy - (rows - 1) / 2.0)))
        return row0, min(self.height, row0 + rows)

    def cropped(self, row0: int, row1: int) -> "Pinhole":
        """The pinhole of rows [row0, row1) alone (as image_proc's crop does: cy shifts, size shrinks)."""
        return Pinhole(self.fx, self.fy, self.cx, self.cy - row0, self.width, row1 - row0)

    def bearing(self, u: float) -> float:
        """Angle (rad) of pixel column u from the optical axis, counter-clockwise positive seen from above
        (a target left of centre has a positive bearing, as a positive yaw turns the robot towards it)."""
        return math.atan2(self.cx - u, self.fx)

    def point(self, u: float, v: float, z: float) -> tuple[float, float, float]:
        """The point (x, y, z) in the optical frame (z forward, x right, y down) seen at pixel (u, v), z ahead."""
        return (u - self.cx) * z / self.fx, (v - self.cy) * z / self.fy, z

    def pixel(self, x: float, y: float, z: float) -> tuple[float, float]:
        """The pixel (u, v) where the point (x, y, z) of the optical frame is seen (z > 0: in front)."""
        return self.cx + self.fx * x / z, self.cy + self.fy * y / z
