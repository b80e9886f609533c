"""A TLD-style tracker (Tracking-Learning-Detection, Kalal et al.): the paper's way of following its target.

Three parts run on every frame, as in TLD:

- **tracking**: a fast short-term tracker carries the box from frame to frame (OpenCV's MOSSE, MedianFlow, KCF
  or CSRT; ``bench/vision`` measures them side by side, and the legacy TLD itself);
- **detection**: a detector proposes where the target may be: faces from :class:`~vision.faces.FaceDetector`,
  near the box every few frames (to correct drift) and over the whole image while the target is lost (to find
  it again after an occlusion or after it left the view), plus the best matches of the target's latest view
  (normalised cross-correlation, so that a target that is not a frontal face, chosen by the operator, can be
  found again too);
- **learning**: an :class:`~vision.appearance.AppearanceModel` of the target, grown while the track is sure
  (positives) and from whatever else the detector finds (negatives: other faces, the background round it). Every
  box, the tracker's or a detection, must look like the target to be believed: a short-term tracker dragged
  along by a person walking in front (MedianFlow does that, measured) fails this check, and the target is lost
  rather than replaced; when it comes back it is *this* target that is taken up again, not another face.

Pure numpy/OpenCV, no ROS: :class:`vision.modules.Track` wraps it as a module.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from .appearance import AppearanceModel, Descriptor, describe
from .boxes import Box
from .faces import FaceDetector, to_gray


def _legacy(name: str):
    return lambda: getattr(cv2.legacy, name)()


SHORT_TERM = {
    "mosse": _legacy("TrackerMOSSE_create"),
    "medianflow": _legacy("TrackerMedianFlow_create"),
    "kcf": lambda: cv2.TrackerKCF_create(),
    "csrt": lambda: cv2.TrackerCSRT_create(),
    "tld": _legacy("TrackerTLD_create"),
}


class TrackerError(ValueError):
    """An unknown short-term tracker or a bad setting."""


@dataclass
class TrackerSettings:
    short_term: str = "mosse"
    accept_distance: float = 0.75   # a box farther than this from every positive is not the target
    accept_relative: float = 0.6    # ... nor one not clearly nearer the positives than the negatives
    check_every: int = 5            # frames between local detector checks while tracking
    search_every: int = 3           # frames between searches while lost
    slow_after: int = 90            # frames lost (3 s at 30 frames/s) after which searches come only every
    slow_search_every: int = 15     # ... this many frames: by then detect takes a face seen again for a new suspect
    #                                 (its forget_s) and hands track its box, so the tracker's own search matters less
    full_search_every: int = 2      # ... of which every Nth covers the whole image, the others round the last place
    learn_novelty: float = 0.08     # a new positive must be at least this far from the stored ones
    min_face_px: int = 24
    scale_factor: float = 1.1       # the face detector's step between scan sizes

    def __post_init__(self) -> None:
        if self.short_term not in SHORT_TERM:
            raise TrackerError(f"unknown short-term tracker {self.short_term!r} (choose from {', '.join(SHORT_TERM)})")
        if self.check_every < 1 or self.search_every < 1 or self.slow_search_every < 1:
            raise TrackerError("check_every, search_every and slow_search_every must be >= 1 frame")
        if self.full_search_every < 1:
            raise TrackerError("full_search_every must be >= 1")


@dataclass
class TrackState:
    """The tracker's answer for one frame: the box (None when lost), whether it is confident, and how it knows
    ('track', 'detect', 'template', 'start' or 'lost')."""

    box: Box | None
    confident: bool
    source: str
    relative: float = 0.0


@dataclass
class _Candidate:
    box: Box
    descriptor: Descriptor
    source: str
    relative: float = 1.0
    positive: float | None = None  # distance to the nearest positive, once matched


@dataclass
class TargetTracker:
    """Tracks one target through occlusions; `start(rgb, box)` then `update(rgb)` every frame."""

    settings: TrackerSettings = field(default_factory=TrackerSettings)
    detector: FaceDetector | None = None

    def __post_init__(self) -> None:
        if self.detector is None:
            self.detector = FaceDetector(min_face_px=self.settings.min_face_px, scale_factor=self.settings.scale_factor)
        self.model: AppearanceModel | None = None
        self._short = None
        self.box: Box | None = None
        self._frame = 0
        self._lost_frames = 0
        self._template: np.ndarray | None = None
        self._last_place: Box | None = None  # where the target was last seen (the local searches look round it)

    @property
    def active(self) -> bool:
        """True while a target is being tracked (found or lost)."""
        return self.model is not None

    def stop(self) -> None:
        """Drop the target."""
        self.model, self._short, self.box, self._template = None, None, None, None
        self._last_place = None

    # Starting -------------------------------------------------------------------------------------
    def start(self, rgb: np.ndarray, box: Box) -> TrackState:
        """Take up a new target in `box` of this frame (it is the target by definition: the model starts from it)."""
        gray = to_gray(rgb)
        descriptor = describe(rgb, box, gray)
        if descriptor is None:
            raise TrackerError(f"target box {box.ints()} is too small or outside the {rgb.shape[1]}x{rgb.shape[0]} image")
        self.model = AppearanceModel()
        self.model.learn_positive(descriptor, novelty=-1.0)
        self._restart_short(rgb, box)
        self._learn_background(rgb, gray, box)
        self._remember(gray, box)
        self.box, self._lost_frames = box, 0
        return TrackState(box, True, "start", 1.0)

    def settle(self, rgb: np.ndarray, box: Box, reach: float = 3.0, sideways: float = 9.0) -> Box:
        """The given target box moved onto the face it was drawn round, in this frame. A box comes from an older
        image than the newest (detect's scan finished a detection's time later; the operator drew it on the
        terminal's picture, which comes through the web socket): on a turning robot the face has moved on by
        then, often by more than its own size at 20-50 px. Started there, the tracker learns the hair or the wall
        beside the face as the target and never lets go of it. So: the face the detector finds within `reach`
        box heights above and below it and `sideways` box widths across (a turning robot moves faces sideways:
        at 1x on ROS the operator's box was 2.2 widths off the face), of a size like it (0.6-1.6 times), the one
        nearest; the box as given when there is none (a target that is not a face)."""
        gray = to_gray(rgb)
        cx, cy = box.centre
        around = Box(cx - box.w * sideways / 2, cy - box.h * reach / 2, box.w * sideways, box.h * reach)
        faces = self.detector.detect(gray, around, min_face_px=max(12, int(0.6 * box.h)),
                                     max_face_px=int(1.6 * box.h) + 1)
        if not faces:
            return box
        return min(faces, key=lambda f: (f.centre[0] - cx) ** 2 + (f.centre[1] - cy) ** 2)

    def _restart_short(self, rgb: np.ndarray, box: Box) -> None:
        self._short = SHORT_TERM[self.settings.short_term]()
        self._short.init(rgb, tuple(int(v) for v in box.ints()))

    # Every frame ----------------------------------------------------------------------------------
    def update(self, rgb: np.ndarray) -> TrackState:
        """Find the target in a new frame: the short-term tracker, checked and re-found by the detector and the
        appearance model."""
        if self.model is None:
            return TrackState(None, False, "lost")
        self._frame += 1
        gray = to_gray(rgb)
        height, width = gray.shape
        tracked: _Candidate | None = None
        if self._short is not None:
            ok, found = self._short.update(rgb)
            box = Box.of(found) if ok else None
            if box is not None and box.inside(width, height, 0.6):
                descriptor = describe(rgb, box, gray)
                if descriptor is not None:
                    tracked = _Candidate(box, descriptor, "track")
        if tracked is not None and self._accept(tracked):
            if self._frame % self.settings.check_every == 0:
                tracked = self._check_locally(rgb, gray, tracked)
            return self._confident(rgb, gray, tracked)
        # Lost: the short-term tracker failed or follows something else. Search the image now and then.
        if self.box is not None:
            self._last_place = self.box
        self._short = None
        self.box = None
        self._lost_frames += 1
        every = self.settings.search_every
        if self._lost_frames > self.settings.slow_after:
            every = self.settings.slow_search_every
        if self._lost_frames % every == 1 or every == 1:
            # every full_search_every-th search the whole image (the target may come back anywhere), the others
            # round where it was last seen (where it comes out from behind a passer-by), a region that grows with
            # the time lost as the target may have moved on meanwhile: a whole-image face scan costs about 80 ms
            # of a core, a look round the last place a few
            whole = ((self._lost_frames - 1) // every) % self.settings.full_search_every == 0
            region = None if whole or self._last_place is None else \
                self._last_place.scaled(3.0 + 0.1 * self._lost_frames)
            found = self._search(rgb, gray, region)
            if found is not None:
                self._restart_short(rgb, found.box)
                return self._confident(rgb, gray, found)
        return TrackState(None, False, "lost")

    def _accept(self, candidate: _Candidate) -> bool:
        match = self.model.match(candidate.descriptor)
        candidate.relative, candidate.positive = match.relative, match.positive
        return match.positive <= self.settings.accept_distance and match.relative >= self.settings.accept_relative

    def _confident(self, rgb: np.ndarray, gray: np.ndarray, candidate: _Candidate) -> TrackState:
        """Believe the candidate: learn from it and report it."""
        self.model.learn_positive(candidate.descriptor, self.settings.learn_novelty, candidate.positive)
        if self._frame % self.settings.check_every == 0:
            self._learn_background(rgb, gray, candidate.box)
        self._remember(gray, candidate.box)
        self.box, self._lost_frames = candidate.box, 0
        return TrackState(candidate.box, True, candidate.source, candidate.relative)

    def _check_locally(self, rgb: np.ndarray, gray: np.ndarray, tracked: _Candidate) -> _Candidate:
        """Run the face detector round the tracked box: a face there that looks like the target corrects the
        box (short-term trackers drift in position and scale); other faces seen become negatives."""
        box = tracked.box
        faces = self.detector.detect(gray, box.scaled(2.2), min_face_px=max(self.settings.min_face_px - 4, int(0.6 * box.h)),
                                     max_face_px=int(1.6 * box.h) + 1)
        best = tracked
        for face in faces:
            descriptor = describe(rgb, face, gray)
            if descriptor is None:
                continue
            candidate = _Candidate(face, descriptor, "detect")
            cx, cy = face.centre
            same_place = face.iou(box) >= 0.3 or (box.x <= cx <= box.x + box.w and box.y <= cy <= box.y + box.h)
            if same_place and self._accept(candidate):
                if best is tracked:
                    best = candidate
                    self._restart_short(rgb, face)
            elif face.iou(box) < 0.1:
                self.model.learn_negative(descriptor)
        return best

    def _search(self, rgb: np.ndarray, gray: np.ndarray, region: Box | None = None) -> _Candidate | None:
        """The whole image (or `region`): faces, and the places most like the target's last view; the best that
        passes."""
        candidates: list[_Candidate] = []
        for face in self.detector.detect(gray, region, min_face_px=self.settings.min_face_px):
            descriptor = describe(rgb, face, gray)
            if descriptor is not None:
                candidates.append(_Candidate(face, descriptor, "detect"))
        for box in self._template_matches(gray, region):
            descriptor = describe(rgb, box, gray)
            if descriptor is not None:
                candidates.append(_Candidate(box, descriptor, "template"))
        accepted = [c for c in candidates if self._accept(c)]
        if not accepted:
            for candidate in candidates:
                if candidate.source == "detect" and self.model.match(candidate.descriptor).positive > 1.0:
                    self.model.learn_negative(candidate.descriptor)  # surely someone else: remember them
            return None
        faces = [c for c in accepted if c.source == "detect"]  # a face box is better drawn than a template's
        return max(faces or accepted, key=lambda c: c.relative)

    # Learning -------------------------------------------------------------------------------------
    def _learn_background(self, rgb: np.ndarray, gray: np.ndarray, box: Box) -> None:
        """The N-expert's share: the patches beside the target are not the target."""
        height, width = gray.shape
        for dx, dy in ((-1.5, 0.0), (1.5, 0.0), (0.0, 1.5)):
            patch = Box(box.x + dx * box.w, box.y + dy * box.h, box.w, box.h)
            if patch.inside(width, height, 1.0):
                descriptor = describe(rgb, patch, gray)
                if descriptor is not None:
                    self.model.learn_negative(descriptor)

    def _remember(self, gray: np.ndarray, box: Box) -> None:
        """Keep the target's latest look (at half resolution) for the template search."""
        rows, cols = box.slices(gray.shape[1], gray.shape[0])
        patch = gray[rows, cols]
        if patch.size:
            self._template = cv2.resize(patch, (max(6, int(box.w) // 2), max(6, int(box.h) // 2)),
                                        interpolation=cv2.INTER_AREA)

    def _template_matches(self, gray: np.ndarray, region: Box | None = None, best: int = 3) -> list[Box]:
        """The `best` places of the half-resolution image (or its `region`) most like the target's last view,
        at three sizes."""
        if self._template is None:
            return []
        x0 = y0 = 0
        if region is not None:
            rows, cols = region.slices(gray.shape[1], gray.shape[0])
            gray, x0, y0 = gray[rows, cols], cols.start, rows.start
            if gray.shape[0] < 12 or gray.shape[1] < 12:
                return []
        small = cv2.resize(gray, (gray.shape[1] // 2, gray.shape[0] // 2), interpolation=cv2.INTER_AREA)
        found: list[tuple[float, Box]] = []
        for scale in (0.8, 1.0, 1.25):
            template = cv2.resize(self._template, None, fx=scale, fy=scale, interpolation=cv2.INTER_LINEAR)
            th, tw = template.shape
            if th < 6 or tw < 6 or th >= small.shape[0] or tw >= small.shape[1]:
                continue
            scores = cv2.matchTemplate(small, template, cv2.TM_CCOEFF_NORMED)
            for _ in range(best):
                _, value, _, (x, y) = cv2.minMaxLoc(scores)
                if value < 0.5:
                    break
                found.append((value, Box(x0 + 2.0 * x, y0 + 2.0 * y, 2.0 * tw, 2.0 * th)))
                cv2.rectangle(scores, (x - tw // 2, y - th // 2), (x + tw // 2, y + th // 2), -1.0, -1)
        found.sort(key=lambda item: -item[0])
        return [box for _, box in found[:best]]


__all__ = ["SHORT_TERM", "TrackerError", "TrackerSettings", "TrackState", "TargetTracker"]
