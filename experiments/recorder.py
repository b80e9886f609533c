"""What an experiment records while a robot runs: its true path, its collisions (each traced: when, where, who drove,
where the nearest person was for the camera) and who held each arbiter.

The recorder is an ordinary participant of the graph: it gets a :class:`~subsumption.runtime.NodeHandle`,
so the very same code records an in-process run and a run on ROS. It listens to the simulator's
``ground_truth`` and ``collisions`` topics and to every active arbiter's ``~status``: who holds an arbiter is
what the arbiter itself says (it reports a change at once, a window that ran out within 0.1 s), sampled at a
fixed period of runtime time. An arbiter whose status has been silent for STATUS_SILENT seconds is gone:
nobody holds it (a dead suppressor's upper line does not "hold" anything), and the silence is recorded.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseArray, Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32

from subsumption import ArbiterKind, NodeHandle
from subsumption.arbiter import STATUS_PERIOD
from subsumption.network.wiring import Wiring
from subsumption.planar import yaw_of

SAMPLE_PERIOD = 0.1  # s of runtime time between samples of the arbiters' state
MOTOR_TYPE = "geometry_msgs/Twist"
DROVE_WITHIN = 1.0  # s: a motor line's command this recent before a contact counts as driving then
STATUS_SILENT = 3 * STATUS_PERIOD  # s without a status after which an arbiter counts as gone


@dataclass
class ArbiterShare:
    """What one arbiter's ~status said over the run, sampled every SAMPLE_PERIOD."""

    name: str
    kind: ArbiterKind
    since: float  # when recording began
    holder: str | None = None  # "upper" or "lower" as last reported; None before the first status
    heard_at: float | None = None
    samples: int = 0
    upper_samples: int = 0
    silent_samples: int = 0

    @property
    def fraction(self) -> float:
        return self.upper_samples / self.samples if self.samples else 0.0

    @property
    def silent_fraction(self) -> float:
        return self.silent_samples / self.samples if self.samples else 0.0

    def hear(self, msg: DiagnosticStatus, now: float) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        self.holder, self.heard_at = values.get("in_control"), now

    def sample(self, now: float) -> None:
        last = self.since if self.heard_at is None else self.heard_at
        self.samples += 1
        if now - last > STATUS_SILENT:
            self.silent_samples += 1
            return
        # before its first status an arbiter is as it starts: the upper line holds only a defaulter
        holder = self.holder or ("upper" if self.kind is ArbiterKind.DEFAULTER else "lower")
        self.upper_samples += holder == "upper"


@dataclass(frozen=True)
class CameraView:
    """Where the robot's camera looks, for a contact's "was the person in view": its place and heading in
    base_link, horizontal field of view, and the depth nearer than which it sees nothing."""
    x: float
    yaw: float
    hfov: float  # rad
    min_depth: float  # m

    def where(self, forward: float, left: float, radius: float) -> tuple[str, float]:
        """``view``, ``near`` (inside min_depth), ``beside`` (out of the view, ahead) or ``behind`` for a body of
        `radius` at (forward, left) in base_link; and its bearing from the camera's axis (rad)."""
        dx, dy = forward - self.x, left
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        fx, fy = c * dx + s * dy, -s * dx + c * dy
        bearing = math.atan2(fy, fx)
        if abs(bearing) <= self.hfov / 2:
            return ("view" if fx - radius >= self.min_depth else "near"), bearing
        return ("beside" if fx > 0 else "behind"), bearing


@dataclass
class RunRecorder:
    node: NodeHandle
    wiring: Wiring
    namespace: str = ""
    path: list[tuple[float, float, float]] = field(default_factory=list)  # (t, x, y) in the map frame
    collisions: int = 0
    collision_points: list[tuple[float, float]] = field(default_factory=list)
    shares: dict[str, ArbiterShare] = field(default_factory=dict)
    agents: list[list[tuple[float, float]]] = field(default_factory=list)  # other robots and people, map frame
    agent_names: list[str] = field(default_factory=list)  # the world's agents, in /agents' order
    agent_radii: list[float] = field(default_factory=list)
    robot_radius: float = 0.18
    camera: CameraView | None = None  # the robot's camera; without one a contact has no "camera" label
    contacts: list[dict] = field(default_factory=list)  # one per collision: see _trace
    deaths: list[dict] = field(default_factory=list)  # {node, at_s, how, modules, critical, motors_stopped}: reports
    respawns: list[dict] = field(default_factory=list)  # {node, at_s, pid}: a dead node back under a new pid

    def __post_init__(self) -> None:
        prefix = self.namespace.strip("/") + "/" if self.namespace.strip("/") else ""
        self._heading = 0.0
        self._agent_poses: list[tuple[float, float]] = []
        self._commands: dict[str, tuple[float, float, float]] = {}  # motor source module -> (t, v, w) last sent
        self.node.subscribe(f"/{prefix}ground_truth", Odometry, self._on_pose)
        self.node.subscribe(f"/{prefix}collisions", UInt32, self._on_collisions)
        self.node.subscribe("/agents", PoseArray, self._on_agents)
        for arbiter in self.wiring.arbiters:
            share = self.shares[arbiter.name] = ArbiterShare(arbiter.name, ArbiterKind(arbiter.kind),
                                                             self.node.now())
            self.node.subscribe(f"/{prefix}{arbiter.name}/status", DiagnosticStatus,
                                lambda msg, s=share: s.hear(msg, self.node.now()))
        # every node's death and return as the network monitor reports them (subsumption.ros.liveness); nothing
        # is sent in-process, where no module runs in a process of its own
        self.node.subscribe(f"/{prefix}{self.wiring.network.name}_monitor/liveness", DiagnosticStatus,
                            self._on_liveness)
        self._motor_chain = self._motor_arbiters()
        for module, topic in self._motor_sources():
            self.node.subscribe(f"/{prefix}{topic}", Twist, lambda msg, m=module: self._on_command(m, msg))
        self.node.call_every(SAMPLE_PERIOD, self._sample)

    def _motor_arbiters(self) -> list:
        """The arbiters on the base's motor line (Twist outputs), nearest the base last (the wiring's order)."""
        return [a for a in self.wiring.arbiters if a.line == "output" and a.line_type == MOTOR_TYPE]

    def _motor_sources(self) -> list[tuple[str, str]]:
        """(module, topic) of every command that may reach the base: each motor arbiter's upper and lower line."""
        found: dict[str, str] = {}
        if self._motor_chain:
            first = self._motor_chain[0]
            found[first.spec.lower.split(".")[0]] = first.lower  # the module at the bottom of the line
        for arbiter in self._motor_chain:
            if ArbiterKind(arbiter.kind) is ArbiterKind.INHIBITOR:
                continue  # an inhibitor's upper line only silences (level 4's pursuit/stop is a Bool): no command
            found.setdefault(arbiter.spec.upper.split(".")[0], arbiter.upper)
        return list(found.items())

    def _on_liveness(self, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        try:
            at = round(float(values.get("at", "")), 2)
        except ValueError:
            at = round(self.node.now(), 2)
        node = msg.name.lstrip("/")
        if values.get("event") == "death":
            self.deaths.append({"node": node, "at_s": at, "how": values.get("how", ""),
                                "modules": [m for m in values.get("modules", "").split(",") if m],
                                "critical": values.get("critical", ""),
                                # critical: true: the motor lines were held from this death until the node was back
                                "motors_stopped": values.get("stops_motors") == "true"})
        elif values.get("event") == "respawn":
            self.respawns.append({"node": node, "at_s": at, "pid": values.get("pid", "")})

    def _on_command(self, module: str, msg: Twist) -> None:
        self._commands[module] = (self.node.now(), msg.linear.x, msg.angular.z)

    def _on_pose(self, msg: Odometry) -> None:
        position = msg.pose.pose.position
        self._heading = yaw_of(msg.pose.pose.orientation)
        self.path.append((self.node.now(), position.x, position.y))

    def _on_agents(self, msg: PoseArray) -> None:
        while len(self.agents) < len(msg.poses):
            self.agents.append([])
        for path, pose in zip(self.agents, msg.poses):
            path.append((pose.position.x, pose.position.y))
        self._agent_poses = [(p.position.x, p.position.y) for p in msg.poses]

    def _on_collisions(self, msg: UInt32) -> None:
        if msg.data > self.collisions and self.path:
            self.collision_points.append(self.path[-1][1:])
            self.contacts.append(self._trace())
        self.collisions = max(self.collisions, msg.data)

    def _driver(self, now: float) -> str:
        """Whose command the motor line passed to the base in the last DROVE_WITHIN s: down the chain from the base,
        the first arbiter whose upper line holds it (as its ~status said) names that module, else its lower line;
        'none' when that module sent nothing in that time."""
        for arbiter in reversed(self._motor_chain):
            share = self.shares.get(arbiter.name)
            if share is not None and share.holder == "upper":
                module = arbiter.spec.upper.split(".")[0]
                break
        else:
            module = self._motor_chain[0].spec.lower.split(".")[0] if self._motor_chain else "none"
        sent = self._commands.get(module)
        return module if sent is not None and now - sent[0] <= DROVE_WITHIN else "none"

    def _trace(self) -> dict:
        """A contact as the run saw it: time, true place and heading, who drove and its last command, and the
        nearest person (or robot) with, for a robot with a camera, where the camera would have seen it (see
        :meth:`CameraView.where`; the bearing is from the camera's axis then, else from the robot's heading)."""
        now, x, y = self.path[-1]
        driver = self._driver(now)
        sent = self._commands.get(driver)
        contact = {"t": round(now, 2), "x": round(x, 3), "y": round(y, 3),
                   "heading": round(self._heading, 3), "driver": driver,
                   "v": round(sent[1], 3) if sent else 0.0, "w": round(sent[2], 3) if sent else 0.0,
                   "recent": {m: [round(c[1], 2), round(c[2], 2)] for m, c in sorted(self._commands.items())
                              if now - c[0] <= DROVE_WITHIN}}
        if self._agent_poses:
            c, s = math.cos(self._heading), math.sin(self._heading)
            gaps = []
            for i, (ax, ay) in enumerate(self._agent_poses):
                radius = self.agent_radii[i] if i < len(self.agent_radii) else 0.25
                gaps.append((math.hypot(ax - x, ay - y) - radius - self.robot_radius, i, ax, ay, radius))
            gap, i, ax, ay, radius = min(gaps)
            dx, dy = ax - x, ay - y
            forward, left = c * dx + s * dy, -s * dx + c * dy  # in base_link
            if self.camera is not None:
                seen, bearing = self.camera.where(forward, left, radius)
                contact["camera"] = seen
            else:
                bearing = math.atan2(left, forward)
            contact.update({"nearest": self.agent_names[i] if i < len(self.agent_names) else f"agent{i}",
                            "gap_m": round(gap, 3), "bearing_deg": round(math.degrees(bearing), 1),
                            "with": "agent" if gap < 0.03 else "wall"})
        else:
            contact["with"] = "wall"
        return contact

    def _sample(self) -> None:
        now = self.node.now()
        for share in self.shares.values():
            share.sample(now)

    def trajectory(self) -> np.ndarray:
        """(x, y) rows of the true path."""
        return np.array([p[1:] for p in self.path]).reshape(-1, 2)
