"""What an experiment records while a robot runs: its true path, its collisions and who held each arbiter.

The recorder is an ordinary participant of the graph: it gets a :class:`~subsumption.runtime.NodeHandle`,
so the very same code records an in-process run and a run on ROS. It listens to the simulator's
``ground_truth`` and ``collisions`` topics and to every active arbiter's ``~status``: who holds an arbiter is
what the arbiter itself says (it reports a change at once, a window that ran out within 0.1 s), sampled at a
fixed period of runtime time. An arbiter whose status has been silent for STATUS_SILENT seconds is gone:
nobody holds it (a dead suppressor's upper line does not "hold" anything), and the silence is recorded.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32

from subsumption import ArbiterKind, NodeHandle
from subsumption.arbiter import STATUS_PERIOD
from subsumption.network.wiring import Wiring

SAMPLE_PERIOD = 0.1  # s of runtime time between samples of the arbiters' state
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

    def __post_init__(self) -> None:
        prefix = self.namespace.strip("/") + "/" if self.namespace.strip("/") else ""
        self.node.subscribe(f"/{prefix}ground_truth", Odometry, self._on_pose)
        self.node.subscribe(f"/{prefix}collisions", UInt32, self._on_collisions)
        self.node.subscribe("/agents", PoseArray, self._on_agents)
        for arbiter in self.wiring.arbiters:
            share = self.shares[arbiter.name] = ArbiterShare(arbiter.name, ArbiterKind(arbiter.kind),
                                                             self.node.now())
            self.node.subscribe(f"/{prefix}{arbiter.name}/status", DiagnosticStatus,
                                lambda msg, s=share: s.hear(msg, self.node.now()))
        self.node.call_every(SAMPLE_PERIOD, self._sample)

    def _on_pose(self, msg: Odometry) -> None:
        position = msg.pose.pose.position
        self.path.append((self.node.now(), position.x, position.y))

    def _on_agents(self, msg: PoseArray) -> None:
        while len(self.agents) < len(msg.poses):
            self.agents.append([])
        for path, pose in zip(self.agents, msg.poses):
            path.append((pose.position.x, pose.position.y))

    def _on_collisions(self, msg: UInt32) -> None:
        if msg.data > self.collisions and self.path:
            self.collision_points.append(self.path[-1][1:])
        self.collisions = max(self.collisions, msg.data)

    def _sample(self) -> None:
        now = self.node.now()
        for share in self.shares.values():
            share.sample(now)

    def trajectory(self) -> np.ndarray:
        """(x, y) rows of the true path."""
        return np.array([p[1:] for p in self.path]).reshape(-1, 2)
