"""Who a face is: enrolled people by name, anyone else *unknown* (the patrol robot's suspicious target).

Enrolment turns a folder of photos into a model file (``subsumption enrol PHOTOS -o staff.npz``): every photo's
face is found by the same detector the robot uses, then seen again as the robot's camera would see it, small and
large (26 to 100 px), a little turned (the photo at up to 30 degrees), darker and brighter, with sensor noise;
each view is cut to a normalised chip. A *cohort* of faces that are nobody enrolled, the first half of
scikit-image's LFW subset (the other half is kept for testing), goes through the same steps: at run time a face
whose nearest chip belongs to the cohort, or is farther than any enrolled view was from its own person, is
unknown. So "unknown" is learned from real other faces, not from a guessed distance.

The model file is an ``.npz`` of the chips, labels, names and the settings: the recognizer (OpenCV's
``cv2.face`` LBPH by default, chosen on measurements in ``bench/vision``) is trained from it when loaded, in a
fraction of a second, so the file does not depend on OpenCV's own storage format.
"""
from __future__ import annotations

import json
import math
from functools import lru_cache
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .boxes import Box
from .faces import FaceDetector, to_gray

CHIP_PX = 48
RECOGNIZERS = ("lbph", "eigen")
UNKNOWN = ""
COHORT_LABEL = 0
COHORT_FACES = range(0, 50)  # LFW subset faces used as the cohort; 50-99 are kept for tests
VIEW_SIZES_PX = (26, 32, 40, 52, 70, 100)
VIEWS_PER_SIZE = 6  # 2 turns x 3 lighting gains
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")


class ModelError(ValueError):
    """A model file or photo folder that cannot be used; the message names it and says why."""


def face_chip(gray: np.ndarray, box: Box) -> np.ndarray:
    """The face in `box` as a CHIP_PX square, histogram-equalised (lighting matters less than pattern)."""
    rows, cols = box.slices(gray.shape[1], gray.shape[0])
    crop = gray[rows, cols]
    if crop.size == 0:
        raise ValueError(f"face box {box} lies outside the {gray.shape[1]}x{gray.shape[0]} image")
    chip = cv2.resize(crop, (CHIP_PX, CHIP_PX), interpolation=cv2.INTER_AREA if crop.shape[0] > CHIP_PX
                      else cv2.INTER_LINEAR)
    return cv2.equalizeHist(chip)


def _make(method: str):
    if method == "lbph":
        return cv2.face.LBPHFaceRecognizer_create(radius=1, neighbors=8, grid_x=6, grid_y=6)
    if method == "eigen":
        return cv2.face.EigenFaceRecognizer_create(num_components=40)
    raise ModelError(f"unknown recognizer {method!r} (choose from {', '.join(RECOGNIZERS)})")


@dataclass(frozen=True)
class Identity:
    """A recognised face: `name` ("" when unknown), the distance to the nearest enrolled view, and the
    person's threshold (unknown beyond it)."""

    name: str
    distance: float
    threshold: float

    @property
    def known(self) -> bool:
        """True for an enrolled person."""
        return bool(self.name)


class FaceModel:
    """Enrolled people's face chips, a cohort of other faces, and a recognizer trained on both."""

    def __init__(self, chips: np.ndarray, labels: np.ndarray, names: dict[int, str], method: str = "lbph",
                 margin: float = 1.1, groups: np.ndarray | None = None) -> None:
        if chips.ndim != 3 or chips.shape[1:] != (CHIP_PX, CHIP_PX) or len(chips) != len(labels):
            raise ModelError(f"face model: chips {chips.shape} and labels {labels.shape} do not match")
        if not any(label != COHORT_LABEL for label in labels):
            raise ModelError("face model: nobody is enrolled")
        self.chips, self.labels = chips.astype(np.uint8), labels.astype(np.int32)
        # which view size each chip was made at (calibration holds out one size at a time)
        self.groups = (np.zeros(len(labels), np.int32) if groups is None else groups.astype(np.int32))
        self.names = dict(names)
        self.method = method
        self.margin = float(margin)
        self.recognizer = _make(method)
        self.recognizer.train(list(self.chips), self.labels)
        self.thresholds = self._calibrate()
        self._enrolled_only = None

    def _calibrate(self) -> dict[int, float]:
        """Per person, how far a view can be from the person's views of other sizes (each size held out in
        turn; the largest such distance) times `margin`: a face farther than that from everyone enrolled is
        unknown. Holding out a whole size, not one view, keeps near-twins of the probe out of the reference."""
        thresholds = {}
        for label in sorted(set(self.labels.tolist()) - {COHORT_LABEL}):
            own = self.labels == label
            distances = []
            for group in sorted(set(self.groups[own].tolist())):
                held_out = own & (self.groups == group)
                reference = own & ~held_out
                if not reference.any():
                    continue
                probe = _make(self.method)
                probe.train(list(self.chips[reference]), self.labels[reference])
                distances.extend(probe.predict(chip)[1] for chip in self.chips[held_out])
            thresholds[label] = float(np.max(distances)) * self.margin if distances else math.inf
        return thresholds

    # Use ------------------------------------------------------------------------------------------
    def identify_chip(self, chip: np.ndarray) -> Identity:
        """Nearest enrolled person within their threshold, unless a cohort face is nearer still."""
        label, distance = self._nearest_enrolled(chip)
        threshold = self.thresholds[label]
        if distance > threshold:
            return Identity(UNKNOWN, distance, threshold)
        overall_label, overall_distance = self.recognizer.predict(chip)
        if overall_label == COHORT_LABEL and overall_distance < distance:
            return Identity(UNKNOWN, distance, threshold)  # looks more like one of the cohort
        return Identity(self.names[label], distance, threshold)

    def _nearest_enrolled(self, chip: np.ndarray) -> tuple[int, float]:
        if self._enrolled_only is None:
            keep = self.labels != COHORT_LABEL
            self._enrolled_only = _make(self.method)
            self._enrolled_only.train(list(self.chips[keep]), self.labels[keep])
        label, distance = self._enrolled_only.predict(chip)
        return int(label), float(distance)

    def identify(self, gray: np.ndarray, box: Box) -> Identity:
        """Who the face in `box` of the grey image is (or a stranger)."""
        return self.identify_chip(face_chip(gray, box))

    @property
    def people(self) -> list[str]:
        """The names of the enrolled people."""
        return [self.names[label] for label in sorted(self.thresholds)]

    # Files ----------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the model to `path` (numpy's npz, no pickles) and return the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        meta = {"method": self.method, "margin": self.margin, "chip_px": CHIP_PX,
                "names": {str(k): v for k, v in self.names.items()}}
        with open(path, "wb") as handle:
            np.savez_compressed(handle, chips=self.chips, labels=self.labels, groups=self.groups, meta=np.array(json.dumps(meta)))
        return path

    @staticmethod
    def load(path: str | Path) -> "FaceModel":
        """Read a model written by save(); a ModelError naming the file when it is not one."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                chips, labels, groups = data["chips"], data["labels"], data["groups"]
                meta = json.loads(str(data["meta"]))
        except FileNotFoundError:
            raise ModelError(f"{path}: no such face model file (make one with `subsumption enrol PHOTOS -o {path}`)") from None
        except (OSError, ValueError, KeyError) as error:
            raise ModelError(f"{path}: not a face model file ({type(error).__name__}: {error})") from None
        if meta.get("chip_px") != CHIP_PX:
            raise ModelError(f"{path}: chips of {meta.get('chip_px')} px, this version uses {CHIP_PX}")
        names = {int(k): v for k, v in meta["names"].items()}
        return FaceModel(chips, labels, names, meta.get("method", "lbph"), meta.get("margin", 1.1), groups)


# Enrolment ------------------------------------------------------------------------------------------
def face_views(gray: np.ndarray, face: Box, detector: FaceDetector, seed: int = 0,
               sizes: tuple[int, ...] = VIEW_SIZES_PX, turns_deg: tuple[float, ...] = (0.0, 30.0),
               gains: tuple[float, ...] = (0.7, 1.0, 1.3)) -> list[np.ndarray]:
    """Chips of one face as the robot's camera would see it: at several sizes, turned up to 30 degrees
    (narrower), darker and brighter, with noise; each boxed by the detector itself where it finds the face."""
    rng = np.random.default_rng(seed)
    pad = int(face.w)
    padded = cv2.copyMakeBorder(gray, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    face = Box(face.x + pad, face.y + pad, face.w, face.h)
    chips = []
    for size in sizes:
        for squeeze in (math.cos(math.radians(turn)) for turn in turns_deg):
            for gain in gains:
                scale = size / face.h
                view = cv2.resize(padded, None, fx=scale * squeeze, fy=scale,
                                  interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
                view = np.clip(view.astype(np.float32) * gain + rng.normal(0, 3, view.shape), 0, 255).astype(np.uint8)
                truth = Box(face.x * scale * squeeze, face.y * scale, face.w * scale * squeeze, face.h * scale)
                found = [b for b in detector.detect(view, truth.scaled(1.6), min_face_px=max(12, int(0.7 * size)),
                                                    max_face_px=int(1.4 * size) + 1)
                         if b.iou(truth) > 0.4]
                chips.append(face_chip(view, found[0] if found else truth))
    return chips


def _read_photo(path: Path) -> np.ndarray:
    pixels = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if pixels is None:
        raise ModelError(f"{path}: not an image OpenCV can read")
    return pixels


def photos_by_person(folder: str | Path) -> dict[str, list[Path]]:
    """The photos of a folder, by person: one subfolder per person (``staff/grace/*.jpg``), or files named
    ``person.png`` / ``person_2.jpg`` directly in the folder."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ModelError(f"{folder}: no such folder of photos")
    people: dict[str, list[Path]] = {}
    for entry in sorted(folder.iterdir()):
        if entry.is_dir():
            photos = sorted(p for p in entry.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
            if photos:
                people.setdefault(entry.name, []).extend(photos)
        elif entry.suffix.lower() in IMAGE_SUFFIXES:
            people.setdefault(entry.stem.rsplit("_", 1)[0] if entry.stem.rsplit("_", 1)[-1].isdigit()
                              else entry.stem, []).append(entry)
    if not people:
        raise ModelError(f"{folder}: no photos (png, jpg, ...) in it or in subfolders")
    return people


def cohort_chips(detector: FaceDetector) -> list[np.ndarray]:
    """Views of the cohort: LFW subset faces 0-49, each on a plain border so the detector can box it (made once
    per detector kind and process)."""
    return list(_cohort_chips(detector.method, detector.min_neighbors))


@lru_cache(maxsize=4)
def _cohort_chips(method: str, min_neighbors: int) -> tuple[np.ndarray, ...]:
    detector = FaceDetector(method, min_neighbors=min_neighbors)
    from skimage import data
    faces = (data.lfw_subset()[:100] * 255).round().astype(np.uint8)
    chips = []
    for index in COHORT_FACES:
        card = cv2.copyMakeBorder(cv2.resize(faces[index], (100, 100), interpolation=cv2.INTER_CUBIC),
                                  40, 80, 60, 60, cv2.BORDER_REPLICATE)
        chips.extend(face_views(card, Box(60, 40, 100, 100), detector, seed=index, sizes=(26, 40, 70),
                                turns_deg=(0.0, 30.0), gains=(1.0,)))
    return tuple(chips)


def enrol(folder: str | Path, method: str = "lbph", detector: FaceDetector | None = None,
          log=print) -> FaceModel:
    """A face model of the people photographed in `folder` (see :func:`photos_by_person`)."""
    detector = detector or FaceDetector()
    chips: list[np.ndarray] = []
    labels: list[int] = []
    groups: list[int] = []
    names: dict[int, str] = {COHORT_LABEL: UNKNOWN}
    for label, (person, photos) in enumerate(photos_by_person(folder).items(), start=1):
        names[label] = person
        for index, photo in enumerate(photos):
            gray = _read_photo(photo)
            faces = detector.detect(gray, min_face_px=max(24, min(gray.shape[:2]) // 20))
            if not faces:
                raise ModelError(f"{photo}: no face found in this photo (a frontal face, at least 24 px tall)")
            views = face_views(gray, faces[0], detector, seed=1000 * label + index)
            chips.extend(views)
            labels.extend([label] * len(views))
            groups.extend(i // VIEWS_PER_SIZE for i in range(len(views)))
            log(f"{photo}: {person}, face {faces[0].ints()}, {len(views)} views")
    cohort = cohort_chips(detector)
    chips.extend(cohort)
    labels.extend([COHORT_LABEL] * len(cohort))
    groups.extend([0] * len(cohort))
    return FaceModel(np.array(chips), np.array(labels), names, method, groups=np.array(groups))


__all__ = ["CHIP_PX", "RECOGNIZERS", "UNKNOWN", "Identity", "FaceModel", "ModelError", "enrol", "face_chip",
           "face_views", "photos_by_person", "cohort_chips"]
