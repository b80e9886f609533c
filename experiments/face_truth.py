"""Where a face truly is in the simulated camera's image: the ground truth that level 4's scorer
(:mod:`experiments.patrol_vision`) and the vision tests measure detect and track against. Never used to drive
the robot.

Each agent that carries a face card (a picture from ``subsim/pictures`` whose face rectangle ``faces.json`` gives)
is projected into the camera with the simulator's own pinhole and mounting: the face's box in pixels, or None
when it is behind the camera, turned away or hidden by a wall.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from sensor_msgs.msg import RegionOfInterest

from subsumption.pinhole import Pinhole
from subsumption.planar import wrap
from vision.boxes import Box

ROOT = Path(__file__).resolve().parent.parent
PICTURES = ROOT / "subsim" / "pictures"      # the simulator's face cards and where their faces are (faces.json)
IN_VIEW_MIN_PX = 24                         # a face smaller than the detector's smallest is not "in view"
FACING_MAX_DEG = 60.0                       # a card turned further from the camera shows no face


@dataclass(frozen=True)
class FaceCard:
    """An agent's picture that holds a face: its place on the agent and the face's rectangle in the card
    (fractions of the card's width and height)."""

    agent: int
    name: str
    radius: float
    height: float
    centre: float
    yaw: float
    aspect: float
    face: tuple[float, float, float, float]  # u0, v0, u1, v1 (v from the top)


def _known_faces() -> dict[str, tuple[float, float, float, float]]:
    """Face rectangles of the simulator's face cards, as subsim/pictures/faces.json gives them (written with the
    cards by tests/support/make_pictures.py)."""
    faces = json.loads((PICTURES / "faces.json").read_text())
    return {name: tuple(box) for name, box in faces.items()}


def face_cards(world) -> list[FaceCard]:
    """Every agent carrying a known face card, from a loaded subsim World."""
    known = _known_faces()
    cards = []
    for i, agent in enumerate(world.agents):
        picture = agent.picture
        if picture is None or Path(picture.file).stem not in known:
            continue
        image = cv2.imread(picture.file)
        aspect = image.shape[1] / image.shape[0]
        cards.append(FaceCard(i, agent.name, agent.radius, picture.height, picture.centre, picture.yaw, aspect,
                              known[Path(picture.file).stem]))
    return cards


@dataclass(frozen=True)
class CameraModel:
    """The simulated camera as the scorer sees it: its intrinsics (the simulator's own) and where it sits on the
    base, to project the true face box into the image."""

    pinhole: Pinhole
    x: float   # on the base
    y: float
    z: float

    @classmethod
    def of(cls, spec) -> "CameraModel":
        """The model of a subsim camera spec."""
        return cls(Pinhole.from_fov(spec.width, spec.height, math.radians(spec.hfov_deg)), spec.x, spec.y, spec.z)


def project_face(camera: CameraModel, robot: tuple[float, float, float], card: FaceCard,
                 agent: tuple[float, float, float], solid=None,
                 max_turn_deg: float = FACING_MAX_DEG) -> tuple[np.ndarray | None, float]:
    """The true face box (x0, y0, x1, y1) in the image of a camera on a robot at `robot`, and the distance to the
    card; None when the face is behind the camera, turned away more than `max_turn_deg`, or hidden by a solid
    cell of `solid` (a (grid, cells) pair) between the camera and the card."""
    rx, ry, rt = robot
    cam_x = rx + math.cos(rt) * camera.x - math.sin(rt) * camera.y
    cam_y = ry + math.sin(rt) * camera.x + math.cos(rt) * camera.y
    ax, ay, at = agent
    facing = at + card.yaw
    reach = card.radius + 0.01
    mx, my = ax + reach * math.cos(facing), ay + reach * math.sin(facing)
    to_cam = math.atan2(cam_y - my, cam_x - mx)
    turned = abs(math.degrees(wrap(to_cam - facing)))
    distance = math.hypot(mx - cam_x, my - cam_y)
    if turned > max_turn_deg:
        return None, distance
    half = card.height * card.aspect / 2.0
    right = np.array([-math.sin(facing), math.cos(facing)])
    left_end = np.array([mx, my]) - right * half
    top = card.centre + card.height / 2.0
    u0, v0, u1, v1 = card.face
    c, s = math.cos(rt), math.sin(rt)
    us, vs = [], []
    for u in (u0, u1):
        px, py = left_end + right * (2 * half * u)
        dx, dy = px - cam_x, py - cam_y
        forward, lateral = c * dx + s * dy, -s * dx + c * dy
        if forward < 0.1:
            return None, distance
        for v in (v0, v1):
            z = top - v * card.height
            u, v = camera.pinhole.pixel(-lateral, camera.z - z, forward)  # optical frame: x right, y down
            us.append(u)
            vs.append(v)
    if solid is not None and _blocked(solid, cam_x, cam_y, mx, my):
        return None, distance
    return np.array([min(us), min(vs), max(us), max(vs)]), distance


def _blocked(solid, x0: float, y0: float, x1: float, y1: float) -> bool:
    """Whether a solid cell of `solid` (a (grid, cells) pair) lies on the segment between the two points."""
    grid, cells = solid
    steps = max(2, int(math.hypot(x1 - x0, y1 - y0) / (grid.resolution / 2)))
    xs = np.linspace(x0, x1, steps)[1:-1]
    ys = np.linspace(y0, y1, steps)[1:-1]
    cols = ((xs - grid.origin[0]) / grid.resolution).astype(int)
    rows = ((ys - grid.origin[1]) / grid.resolution).astype(int)
    inside = (rows >= 0) & (rows < cells.shape[0]) & (cols >= 0) & (cols < cells.shape[1])
    return bool(cells[rows[inside], cols[inside]].any())


def in_view(box: np.ndarray | None, camera: CameraModel, min_px: float = IN_VIEW_MIN_PX) -> bool:
    """The face box is wholly in the image (a pixel's slack) and at least `min_px` tall."""
    if box is None:
        return False
    x0, y0, x1, y1 = box
    return (x0 >= -1 and y0 >= -1 and x1 <= camera.pinhole.width + 1 and y1 <= camera.pinhole.height + 1
            and y1 - y0 >= min_px)


def visible_part(box: np.ndarray | None, camera: CameraModel, min_px: float) -> np.ndarray | None:
    """The part of the face box inside the image, if it is at least `min_px` tall and wide: what a detector can
    find of a face that the image cuts off (the target close by, its face above the top edge)."""
    if box is None:
        return None
    part = _box(box).clipped(camera.pinhole.width, camera.pinhole.height)
    if part.area == 0 or min(part.w, part.h) < min_px:
        return None
    return _corners(part)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boxes (x0, y0, x1, y1)."""
    return _box(a).iou(_box(b))


def _box(corners: np.ndarray) -> Box:
    """A box given by its corners (x0, y0, x1, y1), as vision's Box."""
    return Box(float(corners[0]), float(corners[1]), float(corners[2] - corners[0]), float(corners[3] - corners[1]))


def _corners(box: Box) -> np.ndarray:
    """A vision Box as its corners (x0, y0, x1, y1), the scorer's form."""
    return np.array([box.x, box.y, box.x + box.w, box.y + box.h])


def roi_box(roi: RegionOfInterest) -> np.ndarray | None:
    """A RegionOfInterest as a box (x0, y0, x1, y1); None for an empty one (no target)."""
    if roi.width == 0 or roi.height == 0:
        return None
    return _corners(Box.from_roi(roi))
