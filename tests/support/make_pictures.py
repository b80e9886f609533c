"""Writes the simulator's pictures from images that installed packages ship: ``python -m tests.support.make_pictures``.

Faces without downloads: the head-and-shoulders cards of :mod:`support.photoscene` (Eileen Collins from
``skimage.data.astronaut()`` and Grace Hopper from matplotlib's ``grace_hopper.jpg``, cut round the face the same
way the vision tests cut them), and posters with no face in them (skimage's cat, coffee, rocket, clock). The
PNGs are checked in, so the simulator never imports this test support; this script is how they were made
(deterministic: it writes the same bytes every time), with ``faces.json``: where the face is on each face card
(u0, v0, u1, v1 as fractions of the card's width and height, v from the top), which the experiments' vision
scorer projects into the camera.

A card is square-ish and its face is 0.16 m tall when the card is printed ``CARD_HEIGHT_M`` (0.45 m) tall: give
``height: 0.45`` in a world file for a life-size face.
"""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from . import photoscene as ps

HERE = Path(__file__).resolve().parents[2] / "subsim" / "pictures"
FACES = ("astronaut", "grace_hopper")
POSTERS = ("chelsea", "coffee", "rocket", "clock")


def write_all(folder: Path = HERE) -> list[Path]:
    written, faces = [], {}
    for photo in (ps.astronaut(), ps.grace_hopper()):
        h, w = photo.rgb.shape[:2]
        x, y, fw, fh = photo.face
        faces[f"face_{photo.name}"] = [x / w, y / h, (x + fw) / w, (y + fh) / h]
        rgb = photo.rgb
        if rgb.shape[0] > 320:  # never needed larger: 0.45 m seen from 0.5 m spans about 530 px at most
            scale = 320 / rgb.shape[0]
            rgb = cv2.resize(rgb, (round(rgb.shape[1] * scale), 320), interpolation=cv2.INTER_AREA)
        written.append(_save(folder / f"face_{photo.name}.png", rgb))
    for name in POSTERS:
        written.append(_save(folder / f"poster_{name}.png", ps.non_face(name, 0.5).rgb))
    (folder / "faces.json").write_text(json.dumps(faces, indent=1) + "\n")
    return written + [folder / "faces.json"]


def _save(path: Path, rgb: np.ndarray) -> Path:
    cv2.imwrite(str(path), np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path


if __name__ == "__main__":
    for p in write_all():
        print(p)
