"""A strip of camera frames with the tracked box drawn: what the robot saw and what it believed, at a glance."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .boxes import Box


@dataclass
class StripFrame:
    t: float
    rgb: np.ndarray
    box: Box | None = None       # the tracked box (green when confident, orange when not)
    confident: bool = False
    truth: Box | None = None     # for scoring pictures only: drawn thin, white
    note: str = ""


def camera_strip(frames: list[StripFrame], path: str | Path, columns: int = 4, width: int = 320) -> Path:
    """Write the frames as a grid of `columns`, each scaled to `width` px, with time and note written on it."""
    tiles = []
    for frame in frames:
        image = np.ascontiguousarray(frame.rgb[:, :, ::-1])  # OpenCV draws and writes BGR
        if frame.truth is not None:
            x, y, w, h = frame.truth.ints()
            cv2.rectangle(image, (x, y), (x + w, y + h), (255, 255, 255), 1)
        if frame.box is not None:
            x, y, w, h = frame.box.ints()
            cv2.rectangle(image, (x, y), (x + w, y + h), (0, 200, 0) if frame.confident else (0, 140, 255), 3)
        text = f"t={frame.t:.2f}s {frame.note}".strip()
        cv2.putText(image, text, (8, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (0, 0, 0), 4)
        cv2.putText(image, text, (8, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (255, 255, 255), 2)
        scale = width / image.shape[1]
        tiles.append(cv2.resize(image, (width, int(round(image.shape[0] * scale))), interpolation=cv2.INTER_AREA))
    while len(tiles) % columns:
        tiles.append(np.zeros_like(tiles[0]))
    grid = np.vstack([np.hstack(tiles[row:row + columns]) for row in range(0, len(tiles), columns)])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), grid):
        raise OSError(f"cannot write {path}")
    return path


__all__ = ["StripFrame", "camera_strip"]
