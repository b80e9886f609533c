"""Camera frames composited from real photographs, for vision tests and benchmarks (test support).

From before the simulator's camera rendered its worlds: the vision modules are exercised on real photos that
installed packages ship (``skimage.data.astronaut()``, matplotlib's ``grace_hopper.jpg``, ``skimage.data.lfw_subset()``
faces, and non-face pictures such as ``chelsea``, ``coffee`` or ``clock``), pasted into a 640x480 view of a
room by a pinhole camera: a picture of height H metres at distance d metres spans ``f * H / d`` pixels, nearer
things hide farther ones, and the registered depth image (32FC1, metres) says how far each pixel is. This is
test data, honest about what it is: real faces, exact geometry, the true boxes known for scoring. It never
reaches a module through anything but an image.

The camera is a Kinect-like one: 640x480, 57 degrees horizontal field of view, 0.3 m above the floor (the
TurtleBot's), looking level.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import cv2
import numpy as np

from subsumption.pinhole import Pinhole
from vision.replay import camera_messages

WIDTH, HEIGHT = 640, 480
HFOV_DEG = 57.0
FOCAL_PX = (WIDTH / 2) / math.tan(math.radians(HFOV_DEG / 2))  # about 589 px
CAMERA_HEIGHT_M = 0.30
WALL_DEPTH_M = 6.0


CAMERA = Pinhole(FOCAL_PX, FOCAL_PX, (WIDTH - 1) / 2.0, (HEIGHT - 1) / 2.0, WIDTH, HEIGHT)


def intrinsics(width: int = WIDTH, height: int = HEIGHT, focal_px: float = FOCAL_PX) -> np.ndarray:
    """The 3x3 pinhole matrix K of the camera (square pixels, principal point at the centre)."""
    return Pinhole(focal_px, focal_px, (width - 1) / 2.0, (height - 1) / 2.0, width, height).matrix


@dataclass(frozen=True)
class Photo:
    """A printed picture: RGB pixels, its physical height in metres, and where the face is in it (or None)."""

    name: str
    rgb: np.ndarray
    height_m: float
    face: tuple[int, int, int, int] | None  # x, y, w, h in the photo's pixels

    @property
    def width_m(self) -> float:
        return self.height_m * self.rgb.shape[1] / self.rgb.shape[0]


# Face boxes of the source photos (x, y, w, h), as a careful look at each places them.
_ASTRONAUT_FACE = (177, 66, 96, 96)
_GRACE_FACE = (150, 102, 228, 228)


def _portrait(rgb: np.ndarray, face: tuple[int, int, int, int], name: str, face_height_m: float) -> Photo:
    """A head-and-shoulders card cut round a face: 0.9 face widths either side, 0.6 above, 1.2 below."""
    x, y, w, h = face
    left, top = max(0, int(x - 0.9 * w)), max(0, int(y - 0.6 * h))
    right, bottom = min(rgb.shape[1], int(x + 1.9 * w)), min(rgb.shape[0], int(y + 2.2 * h))
    card = np.ascontiguousarray(rgb[top:bottom, left:right, :3])
    scale = face_height_m / h  # metres per photo pixel
    return Photo(name, card, card.shape[0] * scale, (x - left, y - top, w, h))


@lru_cache(maxsize=None)
def astronaut(face_height_m: float = 0.16) -> Photo:
    """Eileen Collins (skimage.data.astronaut), a head-and-shoulders card whose face is `face_height_m` tall."""
    from skimage import data
    return _portrait(data.astronaut(), _ASTRONAUT_FACE, "astronaut", face_height_m)


@lru_cache(maxsize=None)
def grace_hopper(face_height_m: float = 0.16) -> Photo:
    """Grace Hopper (matplotlib's sample grace_hopper.jpg), a head-and-shoulders card."""
    import matplotlib.cbook
    from PIL import Image
    with matplotlib.cbook.get_sample_data("grace_hopper.jpg") as handle:
        rgb = np.asarray(Image.open(handle).convert("RGB"))
    return _portrait(rgb, _GRACE_FACE, "grace_hopper", face_height_m)


@lru_cache(maxsize=None)
def lfw_faces() -> np.ndarray:
    """The 100 face crops (25x25, grayscale uint8) of skimage's LFW subset: 100 other people's faces."""
    from skimage import data
    return (data.lfw_subset()[:100] * 255).round().astype(np.uint8)


def lfw_portrait(index: int, face_height_m: float = 0.16) -> Photo:
    """LFW face `index` as a card: the 25x25 crop enlarged (it is blurry, as a far face is) with a plain border."""
    crop = cv2.resize(lfw_faces()[index], (100, 100), interpolation=cv2.INTER_CUBIC)
    card = cv2.copyMakeBorder(crop, 40, 80, 60, 60, cv2.BORDER_REPLICATE)
    rgb = np.repeat(card[:, :, None], 3, axis=2)
    return Photo(f"lfw{index}", rgb, card.shape[0] * face_height_m / 100, (60, 40, 100, 100))


NON_FACES = ("chelsea", "coffee", "rocket", "clock", "coins", "horse", "hubble_deep_field", "immunohistochemistry",
             "brick", "gravel", "cell", "text", "page", "moon", "retina", "grass")


@lru_cache(maxsize=None)
def non_face(name: str, height_m: float = 0.4) -> Photo:
    """A picture with no face in it from skimage.data (a cat, coffee, a rocket, a clock, coins, textures...)."""
    from skimage import data
    pixels = getattr(data, name)()
    if pixels.dtype != np.uint8:
        pixels = (np.clip(pixels, 0, 1) * 255).astype(np.uint8) if pixels.max() <= 1.0 else pixels.astype(np.uint8)
    if pixels.ndim == 2:
        pixels = np.repeat(pixels[:, :, None], 3, axis=2)
    if pixels.shape[0] > 200:  # it never spans more on screen; a smaller source pastes faster
        pixels = cv2.resize(pixels, (int(pixels.shape[1] * 200 / pixels.shape[0]), 200), interpolation=cv2.INTER_AREA)
    return Photo(name, np.ascontiguousarray(pixels[:, :, :3]), height_m, None)


@dataclass
class Placed:
    """A photo standing in the scene: lateral offset x (m, right positive), distance d (m), centre height (m)."""

    photo: Photo
    x_m: float
    d_m: float
    centre_height_m: float = 0.5
    turn_deg: float = 0.0  # turned about its upright axis: it looks narrower by cos(turn)

    def box(self, focal_px: float = FOCAL_PX) -> tuple[float, float, float, float]:
        squeeze = math.cos(math.radians(self.turn_deg))
        return _project(self.x_m, self.d_m, self.centre_height_m, self.photo.width_m * squeeze,
                        self.photo.height_m, focal_px)


@dataclass
class Occluder:
    """An upright body (a person walking between): a box of width w_m and height h_m at lateral x_m, distance d_m."""

    x_m: float
    d_m: float
    width_m: float = 0.45
    height_m: float = 1.7
    colour: tuple[int, int, int] = (60, 70, 90)


@dataclass
class Frame:
    """One camera frame: RGB (h, w, 3) uint8, depth (h, w) float32 metres, and the true face boxes by photo name."""

    rgb: np.ndarray
    depth: np.ndarray
    faces: dict[str, tuple[int, int, int, int]] = field(default_factory=dict)  # only faces at least half visible


def _room(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A plain room (copies of one of a few made once): a wall 6 m away above a floor; depth of every pixel."""
    rgb, depth = _made_room(seed % 4)
    return rgb.copy(), depth.copy()


@lru_cache(maxsize=4)
def _made_room(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    rgb = np.empty((HEIGHT, WIDTH, 3), np.float32)
    rows = np.arange(HEIGHT, dtype=np.float32)[:, None]
    horizon = (HEIGHT - 1) / 2.0 + FOCAL_PX * CAMERA_HEIGHT_M / WALL_DEPTH_M  # where the wall meets the floor
    wall = rows < horizon
    rgb[:] = np.where(wall[:, :, None], np.array([200, 196, 184], np.float32), np.array([120, 100, 80], np.float32))
    rgb += rng.normal(0, 4, (HEIGHT, WIDTH, 1)).astype(np.float32)
    depth = np.full((HEIGHT, WIDTH), WALL_DEPTH_M, np.float32)
    below = rows[:, 0] - (HEIGHT - 1) / 2.0
    floor_depth = np.where(below > 0, FOCAL_PX * CAMERA_HEIGHT_M / np.maximum(below, 1e-6), np.inf)
    depth[~wall[:, 0]] = np.minimum(WALL_DEPTH_M, floor_depth[~wall[:, 0]])[:, None]
    return rgb, depth


def _project(x_m: float, d_m: float, centre_height_m: float, width_m: float, height_m: float,
             focal_px: float = FOCAL_PX) -> tuple[float, float, float, float]:
    """Pixel box (left, top, width, height) of an upright rectangle facing the camera."""
    cx, cy = (WIDTH - 1) / 2.0, (HEIGHT - 1) / 2.0
    w, h = focal_px * width_m / d_m, focal_px * height_m / d_m
    u = cx + focal_px * x_m / d_m
    v = cy - focal_px * (centre_height_m - CAMERA_HEIGHT_M) / d_m
    return u - w / 2, v - h / 2, w, h


def _paste(rgb: np.ndarray, depth: np.ndarray, pixels: np.ndarray, box: tuple[float, float, float, float],
           d_m: float) -> None:
    """Draw `pixels` resized into `box` where it is nearer than what is there already."""
    left, top, w, h = box
    iw, ih = max(1, int(round(w))), max(1, int(round(h)))
    x0, y0 = int(round(left)), int(round(top))
    resized = cv2.resize(pixels, (iw, ih), interpolation=cv2.INTER_AREA if iw < pixels.shape[1] else cv2.INTER_LINEAR)
    xa, ya, xb, yb = max(0, x0), max(0, y0), min(WIDTH, x0 + iw), min(HEIGHT, y0 + ih)
    if xa >= xb or ya >= yb:
        return
    patch = resized[ya - y0:yb - y0, xa - x0:xb - x0].astype(np.float32)
    nearer = depth[ya:yb, xa:xb] > d_m
    rgb[ya:yb, xa:xb][nearer] = patch[nearer]
    depth[ya:yb, xa:xb][nearer] = d_m


def render(photos: list[Placed], occluders: list[Occluder] = (), seed: int = 0, noise: float = 3.0,
           focal_px: float = FOCAL_PX) -> Frame:
    """The frame a level camera 0.3 m above the floor sees: the room, then everything nearest last."""
    rgb, depth = _room(seed)
    things: list[tuple[float, object]] = [(p.d_m, p) for p in photos] + [(o.d_m, o) for o in occluders]
    for _, thing in sorted(things, key=lambda item: -item[0]):
        if isinstance(thing, Placed):
            box = thing.box(focal_px)
            _paste(rgb, depth, thing.photo.rgb, box, thing.d_m)
        else:
            box = _project(thing.x_m, thing.d_m, thing.height_m / 2, thing.width_m, thing.height_m, focal_px)
            body = np.empty((8, 8, 3), np.uint8)
            body[:] = thing.colour
            _paste(rgb, depth, body, box, thing.d_m)
    faces = {}
    for placed in photos:
        face = face_box(placed, focal_px)
        if face is not None and _visible_share(depth, face, placed.d_m) >= 0.5:
            faces[placed.photo.name] = tuple(int(round(v)) for v in face)
    if noise > 0:  # sensor noise: a fixed field, shifted differently each frame (drawing it anew is slow)
        shift = np.random.default_rng(seed + 1).integers(0, [HEIGHT, WIDTH])
        rgb += noise * np.roll(_unit_noise(), tuple(int(v) for v in shift), axis=(0, 1))
    return Frame(np.clip(rgb, 0, 255).astype(np.uint8), depth, faces)


@lru_cache(maxsize=1)
def _unit_noise() -> np.ndarray:
    return np.random.default_rng(12345).normal(0, 1, (HEIGHT, WIDTH, 3)).astype(np.float32)


def face_box(placed: Placed, focal_px: float = FOCAL_PX) -> tuple[float, float, float, float] | None:
    """Where the face of a placed photo falls in the image (whether or not something hides it); None if no face."""
    if placed.photo.face is None:
        return None
    box = placed.box(focal_px)
    sx, sy = box[2] / placed.photo.rgb.shape[1], box[3] / placed.photo.rgb.shape[0]
    fx, fy, fw, fh = placed.photo.face
    return box[0] + fx * sx, box[1] + fy * sy, fw * sx, fh * sy


def _visible_share(depth: np.ndarray, face: tuple[float, float, float, float], d_m: float) -> float:
    """How much of the face box (inside the image) shows the face's own depth, i.e. is not hidden."""
    x, y, w, h = face
    xa, ya, xb, yb = max(0, int(x)), max(0, int(y)), min(WIDTH, int(x + w)), min(HEIGHT, int(y + h))
    if xa >= xb or ya >= yb:
        return 0.0
    seen = np.count_nonzero(np.abs(depth[ya:yb, xa:xb] - d_m) < 1e-3)
    return seen / max(1.0, w * h)


def distance_for_face_height(face_px: float, face_height_m: float = 0.16, focal_px: float = FOCAL_PX) -> float:
    """The distance at which a face `face_height_m` tall spans `face_px` pixels: d = f * H / h."""
    return focal_px * face_height_m / face_px


__all__ = ["WIDTH", "HEIGHT", "FOCAL_PX", "HFOV_DEG", "CAMERA_HEIGHT_M", "Photo", "Placed", "Occluder", "Frame",
           "astronaut", "grace_hopper", "lfw_faces", "lfw_portrait", "non_face", "NON_FACES", "render", "intrinsics",
           "distance_for_face_height"]


def _at(keys: list[tuple[float, float]], t: float) -> float:
    """Piecewise-linear value of (time, value) keys at time t (held beyond the ends)."""
    times, values = zip(*keys)
    return float(np.interp(t, times, values))


@dataclass
class Walker:
    """A photo moving on a piecewise-linear path of (time s, value) keys for its lateral x and distance d."""

    photo: Photo
    x_keys: list[tuple[float, float]]
    d_keys: list[tuple[float, float]]
    centre_height_m: float = 0.5
    turn_deg: float = 0.0

    def at(self, t: float) -> Placed:
        return Placed(self.photo, _at(self.x_keys, t), _at(self.d_keys, t), self.centre_height_m, self.turn_deg)


@dataclass
class Passerby:
    """A person walking between (an occluder) on a piecewise-linear path of lateral x keys, at distance d."""

    x_keys: list[tuple[float, float]]
    d_m: float
    width_m: float = 0.5

    def at(self, t: float) -> Occluder:
        return Occluder(_at(self.x_keys, t), self.d_m, self.width_m)


def sequence(walkers: list[Walker], duration_s: float, fps: float = 30.0, passersby: list[Passerby] = (),
             still: list[Placed] = (), seed: int = 0, start_s: float = 0.0):
    """Frames of a moving scene, one every 1/fps s from `start_s` to `duration_s`: yields (t, Frame)."""
    for index in range(int(round(start_s * fps)), int(round(duration_s * fps))):
        t = index / fps
        photos = [w.at(t) for w in walkers] + list(still)
        yield t, render(photos, [p.at(t) for p in passersby], seed=seed * 100003 + index)


def occlusion_scene(seed: int = 0, target: Photo | None = None, distractor: Photo | None = None,
                    hidden_s: float = 3.0) -> tuple[list[Walker], list[Passerby], list[Placed], dict[str, float]]:
    """The issue's occlusion test: a target walking slowly across at about 2.5 m is hidden for `hidden_s`
    seconds by a person who walks in between (1.2 m from the camera), stops in front of it and walks on; another
    face (the distractor) stands still beside the target's path, and non-face pictures hang on the wall.
    The seed varies the target's path and the pictures. Returns the scene and its timing."""
    rng = np.random.default_rng(seed)
    target = target or astronaut()
    distractor = distractor or grace_hopper()
    d0 = rng.uniform(2.2, 2.8)
    x0 = rng.uniform(-0.7, -0.4)
    speed = rng.uniform(0.08, 0.15) * rng.choice([1, 1])
    walker = Walker(target, [(0.0, x0), (10.0, x0 + 10 * speed)], [(0.0, d0), (10.0, d0 - rng.uniform(0, 0.5))])
    # The passer-by is in front of the target (same bearing: x_p / d_p = x_t / d_t) from t_in to t_in + hidden_s.
    t_in = 2.0
    d_p = 1.2

    def shadow(t: float) -> float:
        return walker.at(t).x_m * d_p / walker.at(t).d_m

    passer = Passerby([(t_in - 1.0, shadow(t_in) - 1.6), (t_in, shadow(t_in)), (t_in + hidden_s, shadow(t_in + hidden_s)),
                       (t_in + hidden_s + 1.0, shadow(t_in + hidden_s) + 1.6)], d_p)
    still = [Placed(distractor, x0 + rng.uniform(1.2, 1.6), d0 + 0.4, 0.55),
             Placed(non_face(NON_FACES[seed % len(NON_FACES)], 0.5), rng.uniform(-2.5, -1.5), 5.5, 1.2),
             Placed(non_face(NON_FACES[(seed + 5) % len(NON_FACES)], 0.5), rng.uniform(1.5, 2.5), 5.5, 1.0)]
    return [walker], [passer], still, {"hidden_from_s": t_in, "hidden_until_s": t_in + hidden_s, "duration_s": t_in + hidden_s + 2.5}


def messages(frame: Frame, stamp_s: float, frame_id: str = "camera_rgb_optical_frame"):
    """The frame as a Kinect driver publishes it: (rgb8 Image, 32FC1 depth Image, CameraInfo), one header."""
    return camera_messages(frame.rgb, frame.depth, stamp_s, CAMERA, frame_id)


def entering_scene(seed: int = 0, target: Photo | None = None, bystander: Photo | None = None,
                   d_m: float | None = None) -> tuple[list[Walker], list[Passerby], list[Placed], dict[str, float]]:
    """A suspect walks into the view from one side at 0.3-0.5 m/s, 2.4-3.4 m away (face about 28-40 px), stops
    near the middle, then walks on; an enrolled person (the bystander) stands in view, pictures hang on the wall."""
    rng = np.random.default_rng(seed)
    target = target or astronaut()
    bystander = bystander or grace_hopper()
    d = d_m or rng.uniform(2.4, 3.4)
    side = rng.choice([-1.0, 1.0])
    edge = math.tan(math.radians(HFOV_DEG / 2)) * d + target.width_m
    speed = rng.uniform(0.3, 0.5)
    x_stop = side * rng.uniform(0.0, 0.3) * d
    t_stop = (edge - abs(x_stop)) / speed
    walker = Walker(target, [(0.0, side * edge), (t_stop, x_stop), (t_stop + 2.0, x_stop),
                             (t_stop + 6.0, x_stop - side * 4 * speed)], [(0.0, d), (30.0, d)])
    still = [Placed(bystander, -side * rng.uniform(0.6, 1.0) * d * 0.45, d + rng.uniform(-0.5, 0.5), 0.55),
             Placed(non_face(NON_FACES[seed % len(NON_FACES)], 0.6), side * rng.uniform(0.5, 1.2), 5.5, 1.0),
             Placed(non_face(NON_FACES[(seed + 3) % len(NON_FACES)], 0.6), -side * rng.uniform(1.5, 2.2), 5.5, 1.2)]
    return [walker], [], still, {"stops_at_s": t_stop, "duration_s": t_stop + 4.0}
