"""Pixel boxes and the camera geometry that turns one into a bearing, a range and a point.

A :class:`Box` is (x, y, w, h) in pixels, x right and y down from the image's top-left corner, as OpenCV and
``sensor_msgs/RegionOfInterest`` (x_offset, y_offset, width, height) have it. The pinhole geometry follows the
camera's ``CameraInfo`` K (REP 103 optical frame: z forward, x right, y down).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from sensor_msgs.msg import RegionOfInterest

from subsumption.pinhole import Pinhole


@dataclass(frozen=True)
class Box:
    x: float
    y: float
    w: float
    h: float

    @property
    def area(self) -> float:
        return max(0.0, self.w) * max(0.0, self.h)

    @property
    def centre(self) -> tuple[float, float]:
        return self.x + self.w / 2.0, self.y + self.h / 2.0

    def iou(self, other: "Box") -> float:
        """Intersection over union, 0 when apart."""
        ix = min(self.x + self.w, other.x + other.w) - max(self.x, other.x)
        iy = min(self.y + self.h, other.y + other.h) - max(self.y, other.y)
        if ix <= 0 or iy <= 0:
            return 0.0
        inter = ix * iy
        return inter / (self.area + other.area - inter)

    def scaled(self, factor: float) -> "Box":
        """The box grown (or shrunk) by `factor` about its centre."""
        cx, cy = self.centre
        return Box(cx - self.w * factor / 2, cy - self.h * factor / 2, self.w * factor, self.h * factor)

    def clipped(self, width: int, height: int) -> "Box":
        """The part of the box inside a width x height image (may be empty: w or h 0)."""
        x0, y0 = max(0.0, self.x), max(0.0, self.y)
        x1, y1 = min(float(width), self.x + self.w), min(float(height), self.y + self.h)
        return Box(x0, y0, max(0.0, x1 - x0), max(0.0, y1 - y0))

    def inside(self, width: int, height: int, share: float = 1.0) -> bool:
        """Whether at least `share` of the box lies inside the image."""
        return self.area > 0 and self.clipped(width, height).area >= share * self.area

    def ints(self) -> tuple[int, int, int, int]:
        return int(round(self.x)), int(round(self.y)), int(round(self.w)), int(round(self.h))

    def slices(self, width: int, height: int) -> tuple[slice, slice]:
        """Row and column slices of the box's part inside the image, for numpy indexing."""
        x, y, w, h = self.clipped(width, height).ints()
        return slice(y, y + h), slice(x, x + w)

    def to_roi(self, width: int | None = None, height: int | None = None) -> RegionOfInterest:
        """The box as a RegionOfInterest, clipped to the image when its size is given (ROI fields are unsigned)."""
        box = self.clipped(width, height) if width is not None and height is not None else self
        x, y, w, h = box.ints()
        return RegionOfInterest(x_offset=max(0, x), y_offset=max(0, y), width=max(0, w), height=max(0, h))

    @staticmethod
    def from_roi(roi: RegionOfInterest) -> "Box":
        return Box(float(roi.x_offset), float(roi.y_offset), float(roi.width), float(roi.height))

    @staticmethod
    def of(xywh) -> "Box":
        x, y, w, h = (float(v) for v in xywh)
        return Box(x, y, w, h)


def box_depth(depth_m: np.ndarray, box: Box, core: float = 0.5) -> float:
    """Robust distance (m) of what fills the box: the 30th percentile of valid depths in its central `core`
    part (the near side of the face; a little background at the edges does not pull it away). NaN if none."""
    rows, cols = box.scaled(core).slices(depth_m.shape[1], depth_m.shape[0])
    values = depth_m[rows, cols]
    values = values[np.isfinite(values) & (values > 0)]
    return float(np.percentile(values, 30)) if values.size else math.nan


__all__ = ["Box", "Pinhole", "box_depth"]  # Pinhole: the core's, with the box geometry it serves
