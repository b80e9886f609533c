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
    agents:
      - {name: bob, kind: person, motion: waypoints, waypoints: [[1, 1], [4, 1]], speed: 1.0}
      - {name: rover, kind: robot, motion: wander, start: [3, 3, 0], speed: 0.4}

Every problem is a :class:`WorldError` naming the file and the field (e.g. ``robots[0].limits.max_v``), so
a typo in an experiment's world is found before the experiment runs.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import yaml

from .mapio import GridMap, MapError, load_map


class WorldError(ValueError):
    """A world file is unusable; the message names the file and the field."""

    def __init__(self, path: str | Path, field_name: str, problem: str) -> None:
        super().__init__(f"{path}: field '{field_name}': {problem}")
        self.path, self.field, self.problem = str(path), field_name, problem


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


@dataclass
class World:
    map: GridMap
    robots: list[RobotSpec]
    agents: list[AgentSpec]
    source: str = ""


class _Reader:
    """Typed access to YAML values that turns every mistake into a WorldError with the field's path."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, where: str, problem: str) -> WorldError:
        return WorldError(self.path, where, problem)

    def mapping(self, value: Any, where: str, allowed: set[str]) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a mapping, got {value!r}")
        unknown = sorted(set(value) - allowed)
        if unknown:
            raise self.fail(f"{where}.{unknown[0]}" if where else unknown[0],
                            f"unknown field (known: {', '.join(sorted(allowed))})")
        return value

    def number(self, value: Any, where: str, positive: bool = False, nonneg: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(where, f"expected a number, got {value!r}")
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

    def section(self, cls: type, value: Any, where: str) -> Any:
        """A dataclass of numbers (limits, sensors) from a mapping; missing fields keep their defaults."""
        if value is None or value is True:
            return cls()
        names = {f.name for f in fields(cls)}
        data = self.mapping(value, where, names)
        out = {}
        for key, raw in data.items():
            if key in ("count", "rays", "beams"):
                if isinstance(raw, bool) or not isinstance(raw, int) or raw < 1:
                    raise self.fail(f"{where}.{key}", f"expected a positive integer, got {raw!r}")
                out[key] = raw
            else:
                out[key] = self.number(raw, f"{where}.{key}", nonneg=True)
        return replace(cls(), **out)


_ROBOT_FIELDS = {"name", "namespace", "start", "radius", "limits", "sensors", "odom_noise"}
_AGENT_FIELDS = {"name", "kind", "motion", "waypoints", "loop", "speed", "radius", "start"}


def _robot(r: _Reader, raw: Any, where: str) -> RobotSpec:
    data = r.mapping(raw, where, _ROBOT_FIELDS)
    name = data.get("name")
    if not isinstance(name, str) or not name.strip("/"):
        raise r.fail(f"{where}.name", f"expected a non-empty name, got {name!r}")
    namespace = data.get("namespace", name)
    if not isinstance(namespace, str):
        raise r.fail(f"{where}.namespace", f"expected a string, got {namespace!r}")
    sensors = r.mapping(data.get("sensors", {}) or {}, f"{where}.sensors", {"sonar", "laser"})
    sonar = None if sensors.get("sonar", True) is False else r.section(SonarSpec, sensors.get("sonar"),
                                                                       f"{where}.sensors.sonar")
    laser = None if sensors.get("laser", True) is False else r.section(LaserSpec, sensors.get("laser"),
                                                                       f"{where}.sensors.laser")
    if sonar is not None and sonar.min_range >= sonar.max_range:
        raise r.fail(f"{where}.sensors.sonar.min_range", "must be below max_range")
    if laser is not None and laser.min_range >= laser.max_range:
        raise r.fail(f"{where}.sensors.laser.min_range", "must be below max_range")
    return RobotSpec(
        name=name.strip("/"), namespace=namespace.strip("/"),
        start=r.pose(data.get("start"), f"{where}.start"),
        radius=r.number(data.get("radius", 0.18), f"{where}.radius", positive=True),
        limits=r.section(Limits, data.get("limits"), f"{where}.limits"),
        sonar=sonar, laser=laser,
        odom_noise=r.number(data.get("odom_noise", 0.0), f"{where}.odom_noise", nonneg=True))


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
    defaults = AgentSpec(name=name) if kind == "person" else AgentSpec(name=name, speed=0.4, radius=0.18)
    loop = data.get("loop", True)
    if not isinstance(loop, bool):
        raise r.fail(f"{where}.loop", f"expected true or false, got {loop!r}")
    return AgentSpec(
        name=name, kind=kind, motion=motion, waypoints=waypoints, loop=loop, start=start,  # type: ignore[arg-type]
        speed=r.number(data.get("speed", defaults.speed), f"{where}.speed", nonneg=True),
        radius=r.number(data.get("radius", defaults.radius), f"{where}.radius", positive=True))


def load_world(path: str | Path) -> World:
    """Read a world file and its map. Raises WorldError (or MapError for the map) naming file and field."""
    path = Path(path)
    r = _Reader(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise r.fail("(file)", f"cannot read: {exc.strerror or exc}") from None
    except yaml.YAMLError as exc:
        raise r.fail("(file)", f"not valid YAML: {exc}") from None
    data = r.mapping(data, "", {"map", "robots", "agents"})
    map_name = data.get("map")
    if not isinstance(map_name, str):
        raise r.fail("map", f"expected the path of a map_server YAML file, got {map_name!r}")
    map_path = Path(map_name) if Path(map_name).is_absolute() else path.parent / map_name
    if not map_path.exists():
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
    namespaces = [x.namespace for x in robots]
    if "" in namespaces and len(robots) > 1:
        raise r.fail(f"robots[{namespaces.index('')}].namespace", "namespace '' is only for a single robot")
    return World(grid, robots, agents, str(path))


__all__ = ["World", "WorldError", "MapError", "RobotSpec", "AgentSpec", "Limits", "SonarSpec", "LaserSpec",
           "load_world"]
