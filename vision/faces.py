"""Face detection in camera pixels: OpenCV's boosted cascades, chosen on measurements (``bench/vision``).

Candidates, all shipped inside installed wheels (nothing is downloaded):

- ``haar_alt2``, ``haar_alt``, ``haar_default``: OpenCV's Haar frontal-face cascades from the pinned
  ``opencv-contrib-python-headless`` (``cv2.data.haarcascades``);
- ``lbp``: OpenCV's LBP frontal-face cascade as scikit-image ships it (its file has one misspelt tag,
  ``featuhreParams``, which OpenCV's reader rejects; it is read from memory with the tag corrected).

On composited frames (``bench/vision``) ``haar_alt2`` finds every face 26 px and taller, where ``haar_default``
fires on coins, clocks and gravel; it is the default. Alone it still finds a face in a cat's head and in the
heads on Roman coins (``skimage.data.chelsea``, ``coins``): each box it finds is therefore *verified* by a second
cascade (``haar_alt``, trained apart from ``alt2``) run on that spot only, at that size; measured, this keeps
every true face 26-120 px (56 of 56 at 1-3.6 m, head-on and turned 30 degrees) and drops every such false one
(``lbp`` as verifier drops them too but misses some 31 px faces).
"""
from __future__ import annotations

import os
from functools import lru_cache

import cv2
import numpy as np

from .boxes import Box

_HAAR_FILES = {"haar_alt2": "haarcascade_frontalface_alt2.xml", "haar_alt": "haarcascade_frontalface_alt.xml",
               "haar_default": "haarcascade_frontalface_default.xml"}
DETECTORS = (*_HAAR_FILES, "lbp")


class DetectorError(ValueError):
    """An unknown detector name or a cascade file that cannot be read."""


@lru_cache(maxsize=None)
def _cascade_source(method: str) -> tuple[str, bool]:
    """(file path or XML text, whether it is text) of a named cascade."""
    if method in _HAAR_FILES:
        return os.path.join(cv2.data.haarcascades, _HAAR_FILES[method]), False
    if method == "lbp":
        import skimage.data
        path = os.path.join(os.path.dirname(skimage.data.__file__), "lbpcascade_frontalface_opencv.xml")
        with open(path, encoding="utf-8") as handle:
            return handle.read().replace("featuhreParams", "featureParams"), True
    raise DetectorError(f"unknown face detector {method!r} (choose from {', '.join(DETECTORS)})")


def load_cascade(method: str) -> cv2.CascadeClassifier:
    """A fresh cascade classifier for `method` (one per user: OpenCV cascades are not shared across threads)."""
    source, is_text = _cascade_source(method)
    cascade = cv2.CascadeClassifier()
    if is_text:
        storage = cv2.FileStorage(source, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
        ok = cascade.read(storage.getFirstTopLevelNode())
    else:
        ok = cascade.load(source)
    if not ok or cascade.empty():
        raise DetectorError(f"face detector {method!r}: cannot read its cascade"
                            f"{'' if is_text else ' file ' + source}")
    return cascade


def to_gray(rgb: np.ndarray) -> np.ndarray:
    """Grayscale uint8 of an RGB (or already gray) image."""
    return rgb if rgb.ndim == 2 else cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)


class FaceDetector:
    """Frontal faces in a grayscale image, as boxes. `min_face_px` is the smallest face sought (the cost of a
    scan grows as it shrinks); `region` restricts a scan to part of the image (a cheap local search)."""

    def __init__(self, method: str = "haar_alt2", min_face_px: int = 24, scale_factor: float = 1.1,
                 min_neighbors: int = 3, verifier: str | None = "haar_alt") -> None:
        if min_face_px < 12:
            raise DetectorError(f"face detector: min_face_px must be >= 12, got {min_face_px}")
        if not scale_factor > 1.0:
            raise DetectorError(f"face detector: scale_factor must be > 1, got {scale_factor}")
        self.method = method
        self.cascade = load_cascade(method)
        self.min_face_px = int(min_face_px)
        self.scale_factor = float(scale_factor)
        self.min_neighbors = int(min_neighbors)
        self.verifier = None if not verifier else FaceDetector(verifier, 12, scale_factor, 3, verifier=None)

    def detect(self, gray: np.ndarray, region: Box | None = None, min_face_px: int | None = None,
               max_face_px: int | None = None) -> list[Box]:
        """Faces in `gray` (or in its `region`), largest first; optionally only sizes in [min, max] px."""
        height, width = gray.shape[:2]
        x0 = y0 = 0
        image = gray
        if region is not None:
            rows, cols = region.slices(width, height)
            image = gray[rows, cols]
            x0, y0 = cols.start, rows.start
        smallest = int(min_face_px or self.min_face_px)
        if image.shape[0] < smallest or image.shape[1] < smallest:
            return []
        largest = (int(max_face_px),) * 2 if max_face_px else (0, 0)
        found = self.cascade.detectMultiScale(image, self.scale_factor, self.min_neighbors,
                                              minSize=(smallest, smallest), maxSize=largest)
        boxes = [Box(float(x + x0), float(y + y0), float(w), float(h)) for x, y, w, h in found]
        if self.verifier is not None:
            boxes = [box for box in boxes if self.verified(gray, box)]
        return sorted(boxes, key=lambda b: -b.area)

    def verified(self, gray: np.ndarray, box: Box) -> bool:
        """Whether the verifier cascade, run round `box` at about its size, finds the same face."""
        found = self.verifier.detect(gray, box.scaled(1.6), min_face_px=max(12, int(0.7 * box.h)),
                                     max_face_px=int(1.4 * box.h) + 1)
        return any(other.iou(box) > 0.4 for other in found)


__all__ = ["DETECTORS", "DetectorError", "FaceDetector", "load_cascade", "to_gray"]
