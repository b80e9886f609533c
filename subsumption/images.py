"""``sensor_msgs/Image`` and ``CompressedImage`` to and from numpy: the few lines of cv_bridge we need.

Debian's ``cv_bridge`` calls ``ndarray.tostring`` (gone in numpy 2) and pulls in a second OpenCV beside the
pinned wheel, so the project converts images here, in one place. Supported encodings are the ones a Kinect
driver and a camera viewer use: ``rgb8``, ``bgr8``, ``mono8`` (uint8), ``16UC1`` (depth in mm) and ``32FC1``
(depth in metres). Arrays are ``(height, width)`` or ``(height, width, 3)``, row-major, as OpenCV has them.
"""
from __future__ import annotations

import sys

import numpy as np
from sensor_msgs.msg import CompressedImage, Image

# encoding -> (numpy dtype, channels)
ENCODINGS: dict[str, tuple[np.dtype, int]] = {
    "rgb8": (np.dtype(np.uint8), 3),
    "bgr8": (np.dtype(np.uint8), 3),
    "mono8": (np.dtype(np.uint8), 1),
    "16UC1": (np.dtype(np.uint16), 1),
    "32FC1": (np.dtype(np.float32), 1),
}


class ImageEncodingError(ValueError):
    """An image whose encoding, size or data does not make a valid array; the message says which."""


def _layout(encoding: str) -> tuple[np.dtype, int]:
    try:
        return ENCODINGS[encoding]
    except KeyError:
        raise ImageEncodingError(
            f"unsupported image encoding {encoding!r} (supported: {', '.join(ENCODINGS)})") from None


def to_array(msg: Image) -> np.ndarray:
    """A read-only view of the message's pixels as (h, w) or (h, w, 3), in the message's own encoding."""
    dtype, channels = _layout(msg.encoding)
    row_bytes = msg.width * channels * dtype.itemsize
    if msg.step < row_bytes or len(msg.data) < msg.step * msg.height:
        raise ImageEncodingError(
            f"image {msg.width}x{msg.height} {msg.encoding}: step {msg.step} and {len(msg.data)} bytes of data "
            f"cannot hold it (each row needs {row_bytes} bytes)")
    buffer = np.frombuffer(msg.data, dtype=np.uint8, count=msg.step * msg.height).reshape(msg.height, msg.step)
    pixels = buffer[:, :row_bytes].view(dtype.newbyteorder(">" if msg.is_bigendian else "<"))
    shape = (msg.height, msg.width, channels) if channels > 1 else (msg.height, msg.width)
    return pixels.reshape(shape)


def to_rgb(msg: Image) -> np.ndarray:
    """The pixels as an (h, w, 3) uint8 RGB array, whatever colour encoding the message has."""
    pixels = to_array(msg)
    if msg.encoding == "rgb8":
        return pixels
    if msg.encoding == "bgr8":
        return pixels[:, :, ::-1]
    if msg.encoding == "mono8":
        return np.repeat(pixels[:, :, None], 3, axis=2)
    raise ImageEncodingError(f"image encoding {msg.encoding!r} is not a colour image")


def to_depth_m(msg: Image, rows: slice = slice(None)) -> np.ndarray:
    """Depth in metres as float32 (h, w); NaN where there is no reading (0 in 16UC1, NaN in 32FC1). `rows`: only
    those rows, and only they are converted (a scan's band of a 16UC1 frame at 30 Hz costs a tenth of it all)."""
    pixels = to_array(msg)[rows]
    if msg.encoding == "32FC1":
        return pixels.astype(np.float32, copy=False)
    if msg.encoding == "16UC1":
        depth = pixels.astype(np.float32) / 1000.0
        depth[pixels == 0] = np.nan
        return depth
    raise ImageEncodingError(f"image encoding {msg.encoding!r} is not a depth image (16UC1 or 32FC1)")


def from_array(pixels: np.ndarray, encoding: str, header=None) -> Image:
    """An Image message holding `pixels` (copied), checked against `encoding`."""
    dtype, channels = _layout(encoding)
    shape_ok = pixels.ndim == 3 and pixels.shape[2] == channels if channels > 1 else pixels.ndim == 2
    if not shape_ok or pixels.dtype != dtype:
        raise ImageEncodingError(
            f"array of shape {pixels.shape} and dtype {pixels.dtype} is not a {encoding} image "
            f"(wants {channels} channel{'s' if channels > 1 else ''} of {dtype})")
    msg = Image()
    if header is not None:
        msg.header = header
    msg.height, msg.width = int(pixels.shape[0]), int(pixels.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = int(sys.byteorder == "big")
    msg.step = msg.width * channels * dtype.itemsize
    msg.data = np.ascontiguousarray(pixels).tobytes()
    return msg


def compressed_jpeg(rgb: np.ndarray, header=None, quality: int = 80) -> CompressedImage:
    """A ``CompressedImage`` (format "rgb8; jpeg compressed bgr8", as image_transport writes it) of an RGB array."""
    import cv2

    ok, encoded = cv2.imencode(".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ImageEncodingError(f"OpenCV could not encode a {rgb.shape} array as JPEG")
    msg = CompressedImage()
    if header is not None:
        msg.header = header
    msg.format = "rgb8; jpeg compressed bgr8"
    msg.data = encoded.tobytes()
    return msg


def from_compressed(msg: CompressedImage) -> np.ndarray:
    """The RGB pixels of a JPEG or PNG ``CompressedImage``."""
    import cv2

    decoded = cv2.imdecode(np.frombuffer(msg.data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if decoded is None:
        raise ImageEncodingError(f"compressed image ({msg.format!r}, {len(msg.data)} bytes) does not decode")
    return decoded[:, :, ::-1]


__all__ = ["ENCODINGS", "ImageEncodingError", "to_array", "to_rgb", "to_depth_m", "from_array",
           "compressed_jpeg", "from_compressed"]
