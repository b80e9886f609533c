"""``depth_scan``: a LaserScan from a band of depth-image rows, as ``depthimage_to_laserscan`` makes a TurtleBot's
"laser" from its Kinect.

For each image column the nearest valid depth among ``scan_height`` rows round the optical centre's row is
taken (the band is horizontal for a level camera: the scan plane is the camera's height), and turned into a
range in the scan plane: a pixel at column u and depth z lies at x = (u - cx) z / fx beside the optical axis,
so its range is ``z * sqrt(1 + ((u - cx) / fx)^2)`` and its bearing ``-atan((u - cx) / fx)``. The scan has one
beam per column, evenly spaced in angle from the right edge of the image (``angle_min``) to the left
(``angle_max``), counter-clockwise as REP 103 wants; each beam takes the column nearest its angle.

REP 117: a beam whose nearest reading is inside [range_min, range_max] gives that range; one that saw something
closer than range_min gives -inf; one with no reading (NaN pixels: out of the sensor's range) gives +inf.

The scan's frame is ``output_frame_id``, or by default the depth image's frame with ``_optical`` taken out
(``camera_depth_optical_frame`` -> ``camera_depth_frame``: x forward, the frame a LaserScan wants). A depth image
cropped to the band alone (with its CameraInfo's cy shifted, as the simulator's ``depth_band`` mode publishes
it) works the same as a full one.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from sensor_msgs.msg import CameraInfo, Image, LaserScan

from subsumption import Input, Module, Output, Param
from subsumption.images import ImageEncodingError, to_depth_m


@lru_cache(maxsize=8)
def beam_layout(width: int, fx: float, cx: float) -> tuple[float, float, float, np.ndarray, np.ndarray]:
    """(angle_min, angle_max, increment, column of each beam, range factor of each beam) for an image width
    and pinhole; beam 0 is the rightmost column."""
    angle_min = -math.atan((width - 1 - cx) / fx)
    angle_max = math.atan(cx / fx)
    increment = (angle_max - angle_min) / max(1, width - 1)
    angles = angle_min + increment * np.arange(width)
    columns = np.clip(np.rint(cx - fx * np.tan(angles)), 0, width - 1).astype(np.intp)
    factors = np.sqrt(1.0 + ((columns - cx) / fx) ** 2)
    return angle_min, angle_max, increment, columns, factors


def band_rows(height: int, cy: float, scan_height: int) -> tuple[int, int]:
    """The rows [row0, row1) of the band of `scan_height` rows round row cy, within an image `height` tall."""
    row0 = min(max(0, int(round(cy - (scan_height - 1) / 2.0))), max(0, height - scan_height))
    return row0, min(height, row0 + scan_height)


def scan_ranges(depth_m: np.ndarray, fx: float, cx: float, cy: float, scan_height: int, range_min: float,
                range_max: float, row0: int | None = None) -> tuple[np.ndarray, float, float, float]:
    """(ranges, angle_min, angle_max, increment) of the band of `scan_height` rows round row cy, REP 117.
    `depth_m` is the whole image, or (`row0` given) that band of it alone, starting at image row `row0`."""
    height, width = depth_m.shape
    if row0 is None:
        row0, row1 = band_rows(height, cy, scan_height)
        band = depth_m[row0:row1]
    else:
        band = depth_m
    angle_min, angle_max, increment, columns, factors = beam_layout(width, float(fx), float(cx))
    with np.errstate(invalid="ignore"):
        valid = (band >= range_min) & (band <= range_max)
        nearest = np.where(valid, band, np.inf).min(axis=0)
        too_close = ((band < range_min) & (band > 0)).any(axis=0)
    column_range = np.where(np.isfinite(nearest), nearest, np.where(too_close, -np.inf, np.inf))
    ranges = column_range[columns] * factors  # +-inf stay infinite
    ranges = np.where(np.isfinite(ranges) & (ranges > range_max), np.inf, ranges)
    return ranges.astype(np.float32), angle_min, angle_max, increment


class DepthToScan(Module):
    """Turns a band of rows of the depth image into a LaserScan (what depthimage_to_laserscan does for a
    TurtleBot), so that modules written for a laser work on a Kinect."""

    depth = Input(Image, "camera/depth/image_raw: 16UC1 mm (OpenNI's) or 32FC1 m", latest=True)
    camera_info = Input(CameraInfo, "camera/depth/camera_info: the pinhole of the depth image")
    scan = Output(LaserScan, "one beam per image column, REP 117")
    scan_height = Param(10, "rows of the band round the optical centre's row that make the scan")
    range_min = Param(0.45, "m: nearer readings are -inf (REP 117)")
    range_max = Param(6.0, "m: farther readings are +inf")
    output_frame_id = Param("", "frame of the scan; empty: the depth image's frame without '_optical'")
    max_rate = Param(0.0, "Hz: at most this many scans a second of the images' time (0: one per image, as "
                          "depthimage_to_laserscan). A 30 Hz camera otherwise makes every reader of the scan "
                          "(localization, costmaps, obstacle maps) work at 30 Hz", min=0.0)

    def setup(self) -> None:
        self._last_stamp = None

    def on_depth(self, msg: Image) -> None:
        """Turn a depth image into a LaserScan (at most `max_rate` a second), once the camera_info is known."""
        if self._last_stamp is not None and self.max_rate > 0:
            # a quarter period of slack: 30 Hz frames (20 or 40 ms apart on 50 Hz physics) give 10 Hz scans; time
            # going backwards (a simulation restarted) starts afresh
            if 0.0 <= (msg.header.stamp - self._last_stamp).to_sec() < 0.75 / self.max_rate:
                return
        info = self.registers.camera_info
        if info is None or not info.K[0] > 0:
            self.log_once("camera_info", "no camera_info yet (or its K is empty): cannot tell the beams' angles")
            return
        if info.width != msg.width or info.height != msg.height:
            self.log_every("size", 5.0, f"camera_info is for {info.width}x{info.height}, the depth image is "
                                        f"{msg.width}x{msg.height}", "warn")
            return
        row0, row1 = band_rows(msg.height, info.K[5], int(self.scan_height))
        try:
            band = to_depth_m(msg, slice(row0, row1))
        except ImageEncodingError as error:
            self.log(f"depth: {error}", "warn")
            return
        ranges, angle_min, angle_max, increment = scan_ranges(
            band, info.K[0], info.K[2], info.K[5], int(self.scan_height), float(self.range_min),
            float(self.range_max), row0=row0)
        scan = LaserScan()
        scan.header.stamp = msg.header.stamp
        scan.header.frame_id = self.output_frame_id or msg.header.frame_id.replace("_optical", "")
        scan.angle_min, scan.angle_max, scan.angle_increment = angle_min, angle_max, increment
        if self._last_stamp is not None:
            scan.scan_time = max(0.0, (msg.header.stamp - self._last_stamp).to_sec())
        self._last_stamp = msg.header.stamp
        scan.time_increment = 0.0
        scan.range_min, scan.range_max = float(self.range_min), float(self.range_max)
        scan.ranges = ranges.tolist()
        self.scan.publish(scan)


__all__ = ["DepthToScan", "scan_ranges", "beam_layout", "band_rows"]
