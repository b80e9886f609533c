"""What the tracked target looks like, learned while tracking: TLD's object model, on robust features.

TLD keeps the patches it has seen of the object (positives) and of things that are not it (negatives) and
judges a new patch by its *relative similarity*: how much nearer it is to the nearest positive than to the
nearest negative. Plain normalised patches (TLD's 15x15 NCC) separate faces poorly once boxes jitter and faces
turn (measured: the same face 0.38-0.9, another face up to 0.64), so each patch is described here by

- a spatial histogram of uniform local binary patterns (6x6 cells of a 48 px equalised chip; chi-square), the
  texture of the face itself, robust to a few pixels of shift and to lighting; and
- a hue-saturation histogram of the box enlarged 1.6 times (Bhattacharyya), the colours of hair, skin and
  clothes round it, which tell two people apart at a glance.

The distance between two patches is the sum of both. Positives are capped: the first ones (the conservative
core, never forgotten) plus the most recent; negatives (other faces, the background round the target) likewise.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from skimage.feature import local_binary_pattern

from .boxes import Box
from .faces import to_gray
from .recognition import face_chip

GRID = 6
LBP_BINS = 59  # non-rotation-invariant uniform patterns of 8 neighbours
HUE_BINS, SAT_BINS = 16, 8
CONTEXT = 1.6  # the colour histogram looks at the box enlarged this much


@dataclass(frozen=True)
class Descriptor:
    texture: np.ndarray  # (GRID*GRID*LBP_BINS,) each cell's histogram sums to 1/GRID^2
    colour: np.ndarray  # (HUE_BINS*SAT_BINS,) sums to 1


def describe(rgb: np.ndarray, box: Box, gray: np.ndarray | None = None) -> Descriptor | None:
    """The descriptor of what `box` holds, or None when too little of it is inside the image."""
    height, width = rgb.shape[:2]
    if not box.inside(width, height, 0.6) or box.w < 8 or box.h < 8:
        return None
    chip = face_chip(gray if gray is not None else to_gray(rgb), box)
    codes = local_binary_pattern(chip, 8, 1, "nri_uniform").astype(np.int32)
    cell = chip.shape[0] // GRID
    cells = codes[:cell * GRID, :cell * GRID].reshape(GRID, cell, GRID, cell).transpose(0, 2, 1, 3).reshape(GRID * GRID, -1)
    texture = np.zeros((GRID * GRID, LBP_BINS), np.float32)
    np.add.at(texture, (np.repeat(np.arange(GRID * GRID), cells.shape[1]), cells.ravel()), 1.0)
    texture /= texture.sum()
    rows, cols = box.scaled(CONTEXT).slices(width, height)
    hsv = cv2.cvtColor(np.ascontiguousarray(rgb[rows, cols]), cv2.COLOR_RGB2HSV)
    colour = cv2.calcHist([hsv], [0, 1], None, [HUE_BINS, SAT_BINS], [0, 180, 0, 256]).ravel()
    colour /= max(colour.sum(), 1e-9)
    return Descriptor(texture.ravel(), colour.astype(np.float32))


def distances(probe: Descriptor, textures: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """Distance of `probe` to each stored patch: chi-square of textures (0..1) plus Bhattacharyya of colours (0..1)."""
    if len(textures) == 0:
        return np.empty(0, np.float32)
    # where both bins are empty the term is 0 / eps = 0: no masking needed (it cost a third of the tracker's time)
    chi2 = 0.5 * np.sum((textures - probe.texture) ** 2 / (textures + probe.texture + np.float32(1e-12)), axis=1)
    bhattacharyya = np.sqrt(np.maximum(0.0, 1.0 - np.sqrt(colours * probe.colour).sum(axis=1)))
    return chi2 + bhattacharyya


class _PatchSet:
    """Descriptors kept in arrays: the first `core` forever, then the `recent` latest."""

    def __init__(self, core: int, recent: int) -> None:
        self.core, self.recent = core, recent
        self.textures = np.empty((0, GRID * GRID * LBP_BINS), np.float32)
        self.colours = np.empty((0, HUE_BINS * SAT_BINS), np.float32)

    def __len__(self) -> int:
        return len(self.textures)

    def add(self, descriptor: Descriptor) -> None:
        self.textures = np.vstack([self.textures, descriptor.texture[None]])
        self.colours = np.vstack([self.colours, descriptor.colour[None]])
        if len(self.textures) > self.core + self.recent:
            keep = np.r_[0:self.core, len(self.textures) - self.recent:len(self.textures)]
            self.textures, self.colours = self.textures[keep], self.colours[keep]

    def nearest(self, probe: Descriptor, first: int | None = None) -> float:
        """Distance to the nearest stored patch (of the first `first` only, if given); inf when empty."""
        textures, colours = (self.textures, self.colours) if first is None else (self.textures[:first], self.colours[:first])
        found = distances(probe, textures, colours)
        return float(found.min()) if found.size else float("inf")


@dataclass(frozen=True)
class Match:
    """How a patch compares with the model: distance to the nearest positive (and to the conservative core)
    and to the nearest negative, and TLD's relative similarity d- / (d+ + d-) (1: surely the target)."""

    positive: float
    conservative: float
    negative: float

    @property
    def relative(self) -> float:
        """How much nearer the probe is to the target than to anything else: 0 (like the others) to 1 (only like the
        target)."""
        if self.negative == float("inf"):
            return 1.0 if self.positive < float("inf") else 0.0
        return self.negative / max(self.positive + self.negative, 1e-9)


class AppearanceModel:
    """Positive and negative patches of one target, learned while tracking."""

    def __init__(self, core: int = 10, recent: int = 40, negatives: int = 60) -> None:
        self.positives = _PatchSet(core, recent)
        self.negatives = _PatchSet(negatives // 3, negatives - negatives // 3)

    def match(self, probe: Descriptor) -> Match:
        """How near a probe is to the target's appearances (all, and the first ones) and to the negatives."""
        found = distances(probe, self.positives.textures, self.positives.colours)  # once for both minima
        positive = float(found.min()) if found.size else float("inf")
        core = found[:self.positives.core]
        return Match(positive, float(core.min()) if core.size else float("inf"), self.negatives.nearest(probe))

    def learn_positive(self, probe: Descriptor, novelty: float = 0.05, nearest: float | None = None) -> bool:
        """Keep `probe` as a view of the target unless the model already has one within `novelty` (`nearest`:
        its distance to the nearest positive when a match just measured it)."""
        if (self.positives.nearest(probe) if nearest is None else nearest) <= novelty:
            return False
        self.positives.add(probe)
        return True

    def learn_negative(self, probe: Descriptor, novelty: float = 0.05) -> bool:
        """Keep `probe` as something that is not the target, if it is new enough (returns whether it was kept)."""
        if self.negatives.nearest(probe) <= novelty:
            return False
        self.negatives.add(probe)
        return True


__all__ = ["Descriptor", "describe", "distances", "AppearanceModel", "Match"]
