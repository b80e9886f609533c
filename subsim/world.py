"""World files: which map, which robots (pose, size, sensors, limits), which other moving agents.

A world file is YAML, with the map's path relative to the world file::

    map: room.yaml
    robots:
      - name: robot0
        namespace: ""            # optional; default is the name. "" puts topics at /cmd_vel, /scan, ...
        start: [1.0, 1.0, 0.0]   # x, y, yaw (rad); optional: a free pose is picked deterministically
        radius: 0.18
        limits: {max_v: 0.7, max_w: 2.0, acc_v: 1.5, acc_w: 6.0, cmd_timeout: 0.5}
        sensors:
          sonar: {count: 12, fov_deg: 30, rays: 5, min_range: 0.3, max_range: 3.0, noise: 0.0}
          laser: {fov_deg: 270, beams: 541, min_range: 0.05, max_range: 8.0, noise: 0.0}
        odom_noise: 0.0          # relative std of measured wheel speeds
        odom_turn_noise: 0.0     # optional: the same for the turning part alone (default odom_noise; a gyro's is less)
    agents:
      - {name: bob, kind: person, motion: waypoints, waypoints: [[1, 1], [4, 1]], speed: 1.0}
      - {name: rover, kind: robot, motion: wander, start: [3, 3, 0], speed: 0.4}
      - {name: eve, waypoints: [[9, 7], [1, 7]], loop: false, cue: {robot: robot0, near: [9, 1], within: 1.0}}

Every problem is a :class:`WorldError` naming the file and the field (e.g. ``robots[0].limits.max_v``), so
a typo in an experiment's world is found before the experiment runs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import yaml

from subsumption import yamlfile
from subsumption.errors import InputFileError

from .mapio import GridMap, MapError, load_map


WorldError = InputFileError  # the one bad-input-file error, under this module's name


@dataclass(frozen=True)
class Limits:
    max_v: float = 0.7  # m/s
    max_w: float = 2.0  # rad/s
    acc_v: float = 1.5  # m/s^2
    acc_w: float = 6.0  # rad/s^2
    cmd_timeout: float = 0.5  # s without a command -> the robot stops


@dataclass(frozen=True)
class SonarSpec:
    """A ring of sonars on the body edge: sonar i points at i * 360/count degrees, counter-clockwise."""
    count: int = 12
    fov_deg: float = 30.0
    rays: int = 5
    min_range: float = 0.3
    max_range: float = 3.0
    noise: float = 0.0  # std (m) of additive Gaussian noise


@dataclass(frozen=True)
class LaserSpec:
    """A laser at the body centre, beams spread evenly over fov_deg, centred on the heading."""
    fov_deg: float = 270.0
    beams: int = 541
    min_range: float = 0.05
    max_range: float = 8.0
    noise: float = 0.0
    start_deg: float | None = None  # direction of the first beam (deg, counter-clockwise); None: -fov_deg / 2

    @property
    def full_circle(self) -> bool:
        """360 degrees: beams fov/beams apart (the last one short of the first), as a spinning laser sends them."""
        return self.fov_deg >= 360.0

    def angles(self) -> tuple[float, float, float]:
        """(angle_min, angle_increment, angle_max) in radians, as LaserScan states them."""
        fov = math.radians(self.fov_deg)
        start = -fov / 2 if self.start_deg is None else math.radians(self.start_deg)
        if self.full_circle:
            return start, fov / self.beams, start + fov  # hls_lfcd_lds_driver's: angle_max = 2 pi
        step = fov / max(1, self.beams - 1)
        return start, step, start + step * (self.beams - 1)


DEPTH_ENCODINGS = ("16UC1", "32FC1")  # REP 118: millimetres as uint16 (0 = no reading), or metres as float32


@dataclass(frozen=True)
class CameraSpec:
    """A level RGB-D camera (Kinect-like defaults) on the robot: pose in base_link (x, y, z m, yaw rad),
    image size, horizontal field of view (the vertical one follows: square pixels), depth limits (metres;
    depth outside them is NaN, as an OpenNI driver gives it), depth noise (std in m at 1 m, growing with the
    square of the depth, as a structured-light sensor's does), frame rate, and what is rendered:
    ``rgbd`` (colour and depth, full frames) or ``depth_band`` (only ``band_rows`` rows of depth round the
    optical centre: what a depth-to-scan needs, for long runs without vision). The depth image is published as
    ``depth_encoding``: ``16UC1`` millimetres (0 = no reading), what OpenNI and a TurtleBot publish on
    ``camera/depth/image_raw`` and half the bytes, or ``32FC1`` metres (NaN = no reading); REP 118 allows both."""
    x: float = -0.087
    y: float = 0.0
    z: float = 0.287
    yaw: float = 0.0
    width: int = 640
    height: int = 480
    hfov_deg: float = 57.0
    min_range: float = 0.45
    max_range: float = 6.0
    noise: float = 0.0
    rate: float = 30.0
    mode: str = "rgbd"
    band_rows: int = 10
    compressed: bool = True  # also publish camera/rgb/image_raw/compressed (JPEG)
    depth_encoding: str = "16UC1"  # or "32FC1"


@dataclass(frozen=True)
class CueSpec:
    """A stage cue: the agent stands still until robot `robot` comes within `within` m of the point `near`.
    An experiment's encounter (an intruder coming in ahead of the patrol robot) then happens whatever the robot's
    schedule, on either runtime. It is the world's script reacting, as an actor on stage does; the robot itself
    never learns where it truly is from it."""
    robot: str
    near: tuple[float, float]
    within: float


@dataclass(frozen=True)
class PictureSpec:
    """A printed picture (a PNG file, path resolved against the world file) standing upright: `height` m tall
    (its width follows from the image's aspect), its centre `centre` m above the floor. On an agent it is
    carried on the rim, facing `yaw` rad from the agent's heading. Hung in the scene, `at` is the point
    [x, y] of its middle and `yaw` the direction it faces (hang it a little off the wall, in the room)."""
    file: str
    height: float = 0.45
    centre: float = 0.55
    yaw: float = 0.0
    at: tuple[float, float] | None = None  # only for pictures hung in the scene


@dataclass(frozen=True)
class BoxSpec:
    """A box standing on the floor (a table, a cupboard): the rectangle [x0, y0, x1, y1] in metres, its height
    and colour. Its cells are solid for physics and the 2D sensors whatever its height; the camera sees over
    it when it is low."""
    name: str
    rect: tuple[float, float, float, float]
    height: float
    colour: tuple[int, int, int] = (40, 90, 60)


@dataclass(frozen=True)
class SceneSpec:
    """What the camera needs beyond the 2D map: how tall and what colour walls, floor and ceiling are, boxes
    with their own height (tables) and pictures hung in the room."""
    wall_height: float = 2.5
    wall_colour: tuple[int, int, int] = (196, 192, 180)
    floor_colour: tuple[int, int, int] = (128, 112, 96)
    ceiling_colour: tuple[int, int, int] = (225, 225, 230)
    boxes: tuple[BoxSpec, ...] = ()
    pictures: tuple[PictureSpec, ...] = ()


ROBOT_KINDS = ("robot", "turtlebot", "turtlebot2", "turtlebot3")


@dataclass(frozen=True)
class RobotSpec:
    name: str
    namespace: str
    start: tuple[float, float, float] | None = None
    radius: float = 0.18
    limits: Limits = field(default_factory=Limits)
    sonar: SonarSpec | None = field(default_factory=SonarSpec)
    laser: LaserSpec | None = field(default_factory=LaserSpec)
    odom_noise: float = 0.0
    odom_turn_noise: float | None = None  # None: odom_noise
    # "robot" (Brooks' sonar ring and a laser), "turtlebot" (Kobuki base, Kinect, the project's topic names), or
    # posing as a real robot's driver (subsim.drivers): "turtlebot2" (Kobuki, Kinect), "turtlebot3" (Burger, LDS-01)
    kind: str = "robot"
    camera: CameraSpec | None = None
    body_height: float = 0.45  # m: how tall the camera of another robot sees it
    colour: tuple[int, int, int] = (50, 50, 55)
    # [start, end) spans of simulated time while someone holds the robot up off the floor: its wheels drop (a
    # Kobuki reports it), and it moves no more until it is put down where it was
    lifted: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class AgentSpec:
    """Another moving body the robots must live with: a scripted robot or a walking person."""
    name: str
    kind: str = "person"  # "person" or "robot": only the defaults and the plot differ
    motion: str = "waypoints"  # "waypoints" (visit in order) or "wander" (straight, turn at obstacles)
    waypoints: tuple[tuple[float, float], ...] = ()
    loop: bool = True
    speed: float = 1.0
    radius: float = 0.25
    start: tuple[float, float, float] | None = None
    wait: float = 0.0  # s of simulated time the agent stands still before it starts its script
    cue: CueSpec | None = None  # and, if given, until this cue (whichever comes later)
    height: float = 1.7  # m: the upright body the camera sees (person 1.7, robot 0.45)
    colour: tuple[int, int, int] = (60, 70, 110)
    picture: PictureSpec | None = None


@dataclass
class World:
    map: GridMap
    robots: list[RobotSpec]
    agents: list[AgentSpec]
    source: str = ""
    scene: SceneSpec = field(default_factory=SceneSpec)
    # where the floor drops away (a stair down, a loading dock): polygons of (x, y) in the map frame. Free space to
    # every range sensor (a drop is no wall); a robot's cliff sensors (a Kobuki's) see it, and a robot whose centre
    # goes over one has fallen (it counts as a collision and moves no more)
    cliffs: tuple[tuple[tuple[float, float], ...], ...] = ()


class _Reader:
    """Typed access to YAML values that turns every mistake into a WorldError with the field's path."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, where: str, problem: str) -> WorldError:
        return WorldError.at(self.path, where, problem)

    def mapping(self, value: Any, where: str, allowed: set[str]) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a mapping, got {value!r}")
        unknown = sorted(set(value) - allowed)
        if unknown:
            raise self.fail(f"{where}.{unknown[0]}" if where else unknown[0],
                            f"unknown field (known: {', '.join(sorted(allowed))})")
        return value

    def number(self, value: Any, where: str, positive: bool = False, nonneg: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(where, f"expected a finite number, got {value!r}")
        if positive and not value > 0:
            raise self.fail(where, f"must be > 0, got {value}")
        if nonneg and not value >= 0:
            raise self.fail(where, f"must be >= 0, got {value}")
        return float(value)

    def vector(self, value: Any, where: str, n: int) -> tuple[float, ...]:
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise self.fail(where, f"expected a list of {n} numbers, got {value!r}")
        return tuple(self.number(v, f"{where}[{i}]") for i, v in enumerate(value))

    def pose(self, value: Any, where: str) -> tuple[float, float, float] | None:
        if value is None:
            return None
        if isinstance(value, (list, tuple)) and len(value) == 2:
            value = [*value, 0.0]
        return self.vector(value, where, 3)  # type: ignore[return-value]

    def section(self, cls: type, value: Any, where: str, base: Any = None) -> Any:
        """A dataclass of numbers (limits, sensors) from a mapping; missing fields keep their defaults (those
        of `base` if given)."""
        base = cls() if base is None else base
        if value is None or value is True:
            return base
        names = {f.name for f in fields(cls)}
        data = self.mapping(value, where, names)
        out = {}
        for key, raw in data.items():
            if key in ("count", "rays", "beams"):
                if isinstance(raw, bool) or not isinstance(raw, int) or raw < 1:
                    raise self.fail(f"{where}.{key}", f"expected a positive integer, got {raw!r}")
                out[key] = raw
            else:
                out[key] = self.number(raw, f"{where}.{key}", nonneg=key not in SIGNED_FIELDS)
        return replace(base, **out)

    def colour(self, value: Any, where: str, default: tuple[int, int, int]) -> tuple[int, int, int]:
        if value is None:
            return default
        if (not isinstance(value, (list, tuple)) or len(value) != 3
                or not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 255 for v in value)):
            raise self.fail(where, f"expected [r, g, b] with integers 0-255, got {value!r}")
        return tuple(value)  # type: ignore[return-value]

    def integer(self, value: Any, where: str, lo: int, hi: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise self.fail(where, f"expected an integer from {lo} to {hi}, got {value!r}")
        return value

    def flag(self, value: Any, where: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(where, f"expected true or false, got {value!r}")
        return value

    def is_file(self, path: Path, where: str) -> bool:
        """Whether `path` names a file; a name the system will not look up (ENAMETOOLONG: longer than PATH_MAX) is
        an error on `where`, not an OSError."""
        try:
            return path.is_file()
        except OSError as exc:
            raise self.fail(where, f"cannot look up {yamlfile.brief(str(path))}: {exc.strerror}") from None

    def picture_file(self, value: Any, where: str) -> str:
        """The absolute path of a picture, checked to be a readable image now (not at the first frame)."""
        if not isinstance(value, str) or not value:
            raise self.fail(where, f"expected the path of a PNG picture, got {value!r}")
        path = Path(value) if Path(value).is_absolute() else self.path.parent / value
        if not self.is_file(path, where):
            raise self.fail(where, f"no such picture file {str(path)!r}")
        import cv2
        if cv2.imread(str(path), cv2.IMREAD_COLOR) is None:
            raise self.fail(where, f"cannot read {str(path)!r} as an image")
        return str(path.resolve())


_ROBOT_FIELDS = {"name", "namespace", "start", "radius", "limits", "sensors", "odom_noise", "odom_turn_noise", "kind",
                 "body_height", "colour", "lifted"}
_AGENT_FIELDS = {"name", "kind", "motion", "waypoints", "loop", "speed", "radius", "start", "wait", "cue",
                 "height", "colour", "picture"}
_CUE_FIELDS = {"robot", "near", "within"}
_CAMERA_FIELDS = {f.name for f in fields(CameraSpec)}
_PICTURE_FIELDS = {"file", "height", "centre", "yaw"}
# A Kobuki base: 0.177 m radius, 0.7 m/s, 3 rad/s (its specification's 180 deg/s)
TURTLEBOT_RADIUS = 0.177
TURTLEBOT_LIMITS = Limits(max_v=0.7, max_w=3.0)
SIGNED_FIELDS = {"start_deg"}


@dataclass(frozen=True)
class KindDefaults:
    """What a robot kind has unless its world entry says otherwise."""
    radius: float = 0.18
    limits: Limits = Limits()
    sensors: tuple[str, ...] = ("sonar", "laser")  # the sensors it has when the world file names none
    laser: LaserSpec = LaserSpec()
    camera: CameraSpec = CameraSpec()
    odom_noise: float = 0.0
    odom_turn_noise: float | None = None


# The real robots the simulator poses as (subsim.drivers has their drivers' names and rates). TurtleBot 2: the
# Kobuki's wheel odometry with its gyro's heading (noise 2 % of distance, 0.5 % of turns), the Kinect's depth
# noise (about 1.5 mm at 1 m, growing with the square of the depth: Nguyen, Izadi, Lovell 2012), the driver's
# 0.6 s command timeout. TurtleBot 3 Burger: 0.105 m radius (its navigation's robot_radius), 0.22 m/s and
# 2.84 rad/s (its specification), the LDS-01 (360 beams of 1 degree, 0.12-3.5 m, about 1 cm of noise: its
# specification's +-10 mm precision), wheel odometry with the IMU's heading, 0.5 s command timeout.
KIND_DEFAULTS = {
    "robot": KindDefaults(),
    "turtlebot": KindDefaults(radius=TURTLEBOT_RADIUS, limits=TURTLEBOT_LIMITS, sensors=("camera",)),
    "turtlebot2": KindDefaults(radius=TURTLEBOT_RADIUS, limits=replace(TURTLEBOT_LIMITS, cmd_timeout=0.6),
                               sensors=("camera",), camera=CameraSpec(noise=0.0015), odom_noise=0.02,
                               odom_turn_noise=0.005),
    "turtlebot3": KindDefaults(radius=0.105, limits=Limits(max_v=0.22, max_w=2.84, cmd_timeout=0.5),
                               sensors=("laser",), odom_noise=0.02, odom_turn_noise=0.01,
                               laser=LaserSpec(fov_deg=360.0, beams=360, min_range=0.12, max_range=3.5, noise=0.01,
                                               start_deg=0.0)),
}


def _camera(r: _Reader, raw: Any, where: str, radius: float, base: CameraSpec = CameraSpec()) -> CameraSpec:
    """A camera section; checks the pose is on the robot and the optics make sense."""
    data = r.mapping({} if raw is None or raw is True else raw, where, _CAMERA_FIELDS)
    out: dict[str, Any] = {}
    for key, value in data.items():
        at = f"{where}.{key}"
        if key in ("width", "height"):
            out[key] = r.integer(value, at, 16, 4096)
        elif key == "band_rows":
            out[key] = r.integer(value, at, 1, 4096)
        elif key == "mode":
            if value not in ("rgbd", "depth_band"):
                raise r.fail(at, f"expected rgbd or depth_band, got {value!r}")
            out[key] = value
        elif key == "compressed":
            out[key] = r.flag(value, at)
        elif key == "depth_encoding":
            if value not in DEPTH_ENCODINGS:
                raise r.fail(at, f"expected one of {', '.join(DEPTH_ENCODINGS)}, got {value!r}")
            out[key] = value
        else:
            out[key] = r.number(value, at, nonneg=key not in ("x", "y", "yaw"))
    cam = replace(base, **out)
    if math.hypot(cam.x, cam.y) > radius:
        raise r.fail(f"{where}.x", f"camera at ({cam.x}, {cam.y}) is outside the robot (radius {radius})")
    if not 0.05 <= cam.z <= 2.5:
        raise r.fail(f"{where}.z", f"camera height must be from 0.05 to 2.5 m, got {cam.z}")
    if not 10.0 <= cam.hfov_deg <= 150.0:
        raise r.fail(f"{where}.hfov_deg", f"field of view must be from 10 to 150 degrees, got {cam.hfov_deg}")
    if not 0.0 < cam.min_range < cam.max_range:
        raise r.fail(f"{where}.min_range", f"must be > 0 and below max_range ({cam.max_range}), got {cam.min_range}")
    if not cam.rate > 0:
        raise r.fail(f"{where}.rate", f"must be > 0, got {cam.rate}")
    if cam.band_rows > cam.height:
        raise r.fail(f"{where}.band_rows", f"must be at most the image height {cam.height}, got {cam.band_rows}")
    return cam


def _picture(r: _Reader, raw: Any, where: str, hung: bool = False) -> PictureSpec:
    data = r.mapping(raw, where, _PICTURE_FIELDS | ({"at"} if hung else set()))
    if "file" not in data:
        raise r.fail(f"{where}.file", "missing: the path of a PNG picture")
    at = r.vector(data.get("at"), f"{where}.at", 2) if hung else None
    if hung and at is None:
        raise r.fail(f"{where}.at", "missing: where the picture hangs, [x, y]")
    return PictureSpec(file=r.picture_file(data["file"], f"{where}.file"),
                       height=r.number(data.get("height", 0.45), f"{where}.height", positive=True),
                       centre=r.number(data.get("centre", 0.55), f"{where}.centre", nonneg=True),
                       yaw=r.number(data.get("yaw", 0.0), f"{where}.yaw"), at=at)  # type: ignore[arg-type]


def _scene(r: _Reader, raw: Any, where: str = "scene") -> SceneSpec:
    data = r.mapping({} if raw is None else raw, where,
                     {"wall_height", "wall_colour", "floor_colour", "ceiling_colour", "boxes", "pictures"})
    base = SceneSpec()
    boxes_raw = data.get("boxes", []) or []
    pictures_raw = data.get("pictures", []) or []
    if not isinstance(boxes_raw, list):
        raise r.fail(f"{where}.boxes", f"expected a list of boxes, got {boxes_raw!r}")
    if not isinstance(pictures_raw, list):
        raise r.fail(f"{where}.pictures", f"expected a list of pictures, got {pictures_raw!r}")
    boxes = []
    for i, box in enumerate(boxes_raw):
        at = f"{where}.boxes[{i}]"
        b = r.mapping(box, at, {"name", "rect", "height", "colour"})
        rect = r.vector(b.get("rect"), f"{at}.rect", 4)
        if not (rect[0] < rect[2] and rect[1] < rect[3]):
            raise r.fail(f"{at}.rect", f"expected [x0, y0, x1, y1] with x0 < x1 and y0 < y1, got {list(rect)}")
        boxes.append(BoxSpec(name=str(b.get("name", f"box{i}")), rect=rect,  # type: ignore[arg-type]
                             height=r.number(b.get("height"), f"{at}.height", positive=True),
                             colour=r.colour(b.get("colour"), f"{at}.colour", BoxSpec.colour)))
    return SceneSpec(
        wall_height=r.number(data.get("wall_height", base.wall_height), f"{where}.wall_height", positive=True),
        wall_colour=r.colour(data.get("wall_colour"), f"{where}.wall_colour", base.wall_colour),
        floor_colour=r.colour(data.get("floor_colour"), f"{where}.floor_colour", base.floor_colour),
        ceiling_colour=r.colour(data.get("ceiling_colour"), f"{where}.ceiling_colour", base.ceiling_colour),
        boxes=tuple(boxes),
        pictures=tuple(_picture(r, p, f"{where}.pictures[{i}]", hung=True) for i, p in enumerate(pictures_raw)))


def _robot(r: _Reader, raw: Any, where: str) -> RobotSpec:
    data = r.mapping(raw, where, _ROBOT_FIELDS)
    name = data.get("name")
    if not isinstance(name, str) or not name.strip("/"):
        raise r.fail(f"{where}.name", f"expected a non-empty name, got {name!r}")
    namespace = data.get("namespace", name)
    if not isinstance(namespace, str):
        raise r.fail(f"{where}.namespace", f"expected a string, got {namespace!r}")
    kind = data.get("kind", "robot")
    if kind not in ROBOT_KINDS:
        raise r.fail(f"{where}.kind", f"expected one of {', '.join(ROBOT_KINDS)}, got {kind!r}")
    defaults = KIND_DEFAULTS[kind]
    sensors = r.mapping(data.get("sensors", {}) or {}, f"{where}.sensors", {"sonar", "laser", "camera"})

    def wanted(key: str) -> bool:
        """A robot has its kind's sensors unless told not to (a robot: its sonar ring and laser; a TurtleBot: its
        Kinect; a TurtleBot 3: its LDS), and any other one it is given."""
        if key not in sensors:
            return key in defaults.sensors
        return sensors[key] is not False

    sonar = r.section(SonarSpec, sensors.get("sonar"), f"{where}.sensors.sonar") if wanted("sonar") else None
    laser = (r.section(LaserSpec, sensors.get("laser"), f"{where}.sensors.laser", defaults.laser)
             if wanted("laser") else None)
    radius = r.number(data.get("radius", defaults.radius), f"{where}.radius", positive=True)
    camera = (_camera(r, sensors.get("camera"), f"{where}.sensors.camera", radius, defaults.camera)
              if wanted("camera") else None)
    if sonar is not None and sonar.min_range >= sonar.max_range:
        raise r.fail(f"{where}.sensors.sonar.min_range", "must be below max_range")
    if laser is not None and laser.min_range >= laser.max_range:
        raise r.fail(f"{where}.sensors.laser.min_range", "must be below max_range")
    return RobotSpec(
        name=name.strip("/"), namespace=namespace.strip("/"),
        start=r.pose(data.get("start"), f"{where}.start"),
        radius=radius,
        limits=r.section(Limits, data.get("limits"), f"{where}.limits", defaults.limits),
        sonar=sonar, laser=laser,
        odom_noise=r.number(data.get("odom_noise", defaults.odom_noise), f"{where}.odom_noise", nonneg=True),
        # the kind's own turn noise only with its own odom_noise: a world that sets odom_noise alone gets it for both
        odom_turn_noise=(defaults.odom_turn_noise if "odom_noise" not in data else None)
        if data.get("odom_turn_noise") is None else
        r.number(data["odom_turn_noise"], f"{where}.odom_turn_noise", nonneg=True),
        kind=kind, camera=camera,
        body_height=r.number(data.get("body_height", 0.45), f"{where}.body_height", positive=True),
        colour=r.colour(data.get("colour"), f"{where}.colour", (50, 50, 55)),
        lifted=_spans(r, data.get("lifted", []), f"{where}.lifted"))


def _spans(r: _Reader, raw: Any, where: str) -> tuple[tuple[float, float], ...]:
    """[[start, end], ...] of simulated seconds, each start >= 0 and below its end."""
    if not isinstance(raw, list):
        raise r.fail(where, f"expected a list of [start, end] spans (s), got {raw!r}")
    spans = []
    for i, span in enumerate(raw):
        if not isinstance(span, list) or len(span) != 2:
            raise r.fail(f"{where}[{i}]", f"expected [start, end] (s), got {span!r}")
        start = r.number(span[0], f"{where}[{i}][0]", nonneg=True)
        end = r.number(span[1], f"{where}[{i}][1]", nonneg=True)
        if not end > start:
            raise r.fail(f"{where}[{i}]", f"the end {end} must come after the start {start}")
        spans.append((start, end))
    return tuple(spans)


def _cliffs(r: _Reader, raw: Any) -> tuple[tuple[tuple[float, float], ...], ...]:
    """cliffs: [[[x, y], [x, y], [x, y], ...], ...]: polygons of at least three corners, in metres."""
    if not isinstance(raw, list):
        raise r.fail("cliffs", f"expected a list of polygons [[x, y], ...], got {raw!r}")
    polygons = []
    for i, polygon in enumerate(raw):
        if not isinstance(polygon, list) or len(polygon) < 3:
            raise r.fail(f"cliffs[{i}]", f"expected a polygon of at least 3 corners [[x, y], ...], got {polygon!r}")
        corners = []
        for j, corner in enumerate(polygon):
            if not isinstance(corner, list) or len(corner) != 2:
                raise r.fail(f"cliffs[{i}][{j}]", f"expected [x, y] (m), got {corner!r}")
            corners.append((r.number(corner[0], f"cliffs[{i}][{j}][0]"), r.number(corner[1], f"cliffs[{i}][{j}][1]")))
        polygons.append(tuple(corners))
    return tuple(polygons)


def _agent(r: _Reader, raw: Any, where: str) -> AgentSpec:
    data = r.mapping(raw, where, _AGENT_FIELDS)
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise r.fail(f"{where}.name", f"expected a non-empty name, got {name!r}")
    kind = data.get("kind", "person")
    if kind not in ("person", "robot"):
        raise r.fail(f"{where}.kind", f"expected person or robot, got {kind!r}")
    motion = data.get("motion", "waypoints")
    if motion not in ("waypoints", "wander"):
        raise r.fail(f"{where}.motion", f"expected waypoints or wander, got {motion!r}")
    raw_points = data.get("waypoints", [])
    if not isinstance(raw_points, list):
        raise r.fail(f"{where}.waypoints", f"expected a list of [x, y], got {raw_points!r}")
    waypoints = tuple(r.vector(p, f"{where}.waypoints[{i}]", 2) for i, p in enumerate(raw_points))
    start = r.pose(data.get("start"), f"{where}.start")
    if motion == "waypoints" and not waypoints:
        raise r.fail(f"{where}.waypoints", "motion 'waypoints' needs at least one waypoint")
    if motion == "wander" and start is None:
        raise r.fail(f"{where}.start", "motion 'wander' needs a start pose")
    defaults = (AgentSpec(name=name) if kind == "person" else
                AgentSpec(name=name, speed=0.4, radius=0.18, height=0.45, colour=(50, 50, 55)))
    loop = data.get("loop", True)
    if not isinstance(loop, bool):
        raise r.fail(f"{where}.loop", f"expected true or false, got {loop!r}")
    return AgentSpec(
        name=name, kind=kind, motion=motion, waypoints=waypoints, loop=loop, start=start,  # type: ignore[arg-type]
        speed=r.number(data.get("speed", defaults.speed), f"{where}.speed", nonneg=True),
        radius=r.number(data.get("radius", defaults.radius), f"{where}.radius", positive=True),
        wait=r.number(data.get("wait", 0.0), f"{where}.wait", nonneg=True),
        cue=_cue(r, data["cue"], f"{where}.cue") if data.get("cue") is not None else None,
        height=r.number(data.get("height", defaults.height), f"{where}.height", positive=True),
        colour=r.colour(data.get("colour"), f"{where}.colour", defaults.colour),
        picture=_picture(r, data["picture"], f"{where}.picture") if data.get("picture") is not None else None)


def _cue(r: _Reader, raw: Any, where: str) -> CueSpec:
    data = r.mapping(raw, where, _CUE_FIELDS)
    robot = data.get("robot")
    if not isinstance(robot, str) or not robot:
        raise r.fail(f"{where}.robot", f"expected the name of a robot of this world, got {robot!r}")
    return CueSpec(robot=robot, near=r.vector(data.get("near"), f"{where}.near", 2),  # type: ignore[arg-type]
                   within=r.number(data.get("within"), f"{where}.within", positive=True))


def absolute_paths(data: Any, world: str | Path) -> None:
    """Make a parsed world file's file references (``map``, and every picture's ``file``) absolute, in place, so
    that a copy of the world file written to another folder (a run's own world.yaml) still finds them."""
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else []
    for key, value in list(items):
        if key in ("map", "file") and isinstance(value, str):
            path = Path(value)
            data[key] = str(path if path.is_absolute() else (Path(world).parent / path).resolve())
        elif isinstance(value, (dict, list)):
            absolute_paths(value, world)


def load_world(path: str | Path) -> World:
    """Read a world file and its map. Raises WorldError (or MapError for the map) naming file and field."""
    path = Path(path)
    r = _Reader(path)
    try:
        data = yamlfile.load(path, "world file")
    except yamlfile.YamlFileError as exc:
        raise r.fail("(file)", f"line {exc.line}: {exc.problem}" if exc.line else exc.problem) from None
    data = r.mapping(data, "", {"map", "robots", "agents", "scene", "cliffs"})
    map_name = data.get("map")
    if not isinstance(map_name, str):
        raise r.fail("map", f"expected the path of a map_server YAML file, got {map_name!r}")
    map_path = Path(map_name) if Path(map_name).is_absolute() else path.parent / map_name
    if not r.is_file(map_path, "map"):  # False for a folder too ("map: ''" names the world's own folder)
        raise r.fail("map", f"no such file {str(map_path)!r}")
    grid = load_map(map_path)
    robots_raw = data.get("robots", [])
    agents_raw = data.get("agents", []) or []
    if not isinstance(robots_raw, list) or not robots_raw:
        raise r.fail("robots", "expected a non-empty list of robots")
    if not isinstance(agents_raw, list):
        raise r.fail("agents", "expected a list of agents")
    robots = [_robot(r, raw, f"robots[{i}]") for i, raw in enumerate(robots_raw)]
    agents = [_agent(r, raw, f"agents[{i}]") for i, raw in enumerate(agents_raw)]
    names = [x.name for x in robots] + [a.name for a in agents]
    for i, name in enumerate(names):
        if name in names[:i]:
            where = f"robots[{i}].name" if i < len(robots) else f"agents[{i - len(robots)}].name"
            raise r.fail(where, f"duplicate name {name!r}")
    for i, agent in enumerate(agents):
        if agent.cue is not None and agent.cue.robot not in {x.name for x in robots}:
            raise r.fail(f"agents[{i}].cue.robot", f"no robot named {agent.cue.robot!r} in this world "
                                                    f"(robots: {', '.join(x.name for x in robots)})")
    namespaces = [x.namespace for x in robots]
    if "" in namespaces and len(robots) > 1:
        raise r.fail(f"robots[{namespaces.index('')}].namespace", "namespace '' is only for a single robot")
    scene = _scene(r, data.get("scene"))
    grid = _with_boxes(grid, scene, r)
    return World(grid, robots, agents, str(path), scene, _cliffs(r, data.get("cliffs", []) or []))


class WorldDocument:
    """A world file a run writes its own copy of: read and checked once, edited in memory, written once.

    The file is checked by :func:`load_world` first (every problem named by field before anything runs; the typed
    result is :attr:`world`), then held as its YAML mapping with every file reference made absolute, so the copy
    finds the map and the pictures from any folder. A run's preparation edits the mapping (sensors, start,
    agents) through this one object and calls :meth:`write` once; nothing reads the copy back to edit it again.
    """

    def __init__(self, path: str | Path) -> None:
        self.source = Path(path)
        self.world = load_world(self.source)
        self.data: dict[str, Any] = yamlfile.load(self.source, "world file")
        absolute_paths(self.data, self.source)

    @property
    def robot(self) -> dict[str, Any]:
        """The first robot's mapping (the one a run drives), to edit in place."""
        return self.data["robots"][0]

    @property
    def sensors(self) -> dict[str, Any]:
        """The first robot's ``sensors`` mapping (made if the file has none), to edit in place."""
        sensors = self.robot.get("sensors")
        if not isinstance(sensors, dict):
            sensors = self.robot["sensors"] = {}
        return sensors

    @property
    def map_path(self) -> Path:
        """The map file's absolute path."""
        return Path(self.data["map"])

    @property
    def start(self) -> list[float]:
        """The first robot's start pose from the file ([] when the simulator chooses it)."""
        return [float(v) for v in self.robot.get("start") or []]

    def write(self, path: str | Path) -> Path:
        """Writes the edited world to `path` (its folder made) and returns the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(yaml.safe_dump(self.data, sort_keys=False))
        return path


def _with_boxes(grid: GridMap, scene: SceneSpec, r: _Reader) -> GridMap:
    """The map with the scene's boxes made solid (so that physics and every sensor meet them, and /map shows
    them), whether or not the map's image already has them."""
    if not scene.boxes:
        return grid
    from .mapio import OCCUPIED
    occupancy = grid.occupancy.copy()
    for i, box in enumerate(scene.boxes):
        cells = box_cells(grid, box.rect)
        if cells is None:
            raise r.fail(f"scene.boxes[{i}].rect", f"{list(box.rect)} is not inside the map")
        occupancy[cells] = OCCUPIED
    return GridMap(occupancy, grid.resolution, grid.origin, grid.source)


def box_cells(grid: GridMap, rect: tuple[float, float, float, float]) -> tuple[slice, slice] | None:
    """(rows, cols) slices of the cells whose centres lie in the rectangle [x0, y0, x1, y1], None if empty."""
    x0, y0, x1, y1 = rect
    res, (ox, oy) = grid.resolution, grid.origin
    c0, c1 = max(0, math.ceil((x0 - ox) / res - 0.5)), min(grid.shape[1], math.floor((x1 - ox) / res - 0.5) + 1)
    r0, r1 = max(0, math.ceil((y0 - oy) / res - 0.5)), min(grid.shape[0], math.floor((y1 - oy) / res - 0.5) + 1)
    if c0 >= c1 or r0 >= r1:
        return None
    return slice(r0, r1), slice(c0, c1)


__all__ = ["World", "WorldDocument", "WorldError", "MapError", "RobotSpec", "AgentSpec", "Limits", "SonarSpec", "LaserSpec",
           "CameraSpec", "PictureSpec", "BoxSpec", "SceneSpec", "ROBOT_KINDS", "load_world", "box_cells"]
