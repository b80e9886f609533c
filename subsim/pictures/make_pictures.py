"""Writes the simulator's pictures from images that installed packages ship: ``python -m subsim.pictures.make_pictures``.

Faces without downloads: the head-and-shoulders cards of :mod:`vision.photoscene` (Eileen Collins from
``skimage.data.astronaut()`` and Grace Hopper from matplotlib's ``grace_hopper.jpg``, cut round the face the same
way the vision tests cut them), and posters with no face in them (skimage's cat, coffee, rocket, clock). The
PNGs are checked in, so the simulator itself never imports vision; this script is how they were made
(deterministic: it writes the same bytes every time).

A card is square-ish and its face is 0.16 m tall when the card is printed ``CARD_HEIGHT_M`` (0.45 m) tall: give
``height: 0.45`` in a world file for a life-size face.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
FACES = ("astronaut", "grace_hopper")
POSTERS = ("chelsea", "coffee", "rocket", "clock")


def write_all(folder: Path = HERE) -> list[Path]:
    from vision import photoscene as ps

    written = []
    for photo in (ps.astronaut(), ps.grace_hopper()):
        rgb = photo.rgb
        if rgb.shape[0] > 320:  # never needed larger: 0.45 m seen from 0.5 m spans about 530 px at most
            scale = 320 / rgb.shape[0]
            rgb = cv2.resize(rgb, (round(rgb.shape[1] * scale), 320), interpolation=cv2.INTER_AREA)
        written.append(_save(folder / f"face_{photo.name}.png", rgb))
    for name in POSTERS:
        written.append(_save(folder / f"poster_{name}.png", ps.non_face(name, 0.5).rgb))
    return written


def _save(path: Path, rgb: np.ndarray) -> Path:
    cv2.imwrite(str(path), np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path


if __name__ == "__main__":
    for p in write_all():
        print(p)
