"""What an experiment records while a robot runs: its true path, its collisions and who held each arbiter.

The recorder is an ordinary participant of the graph: it gets a :class:`~subsumption.runtime.NodeHandle`,
so the very same code records an in-process run and a run on ROS. It listens to the simulator's
``ground_truth`` and ``collisions`` topics and to every active arbiter's upper line; the share of time an
upper line held its arbiter is replayed with the arbiter's own rule (:class:`~subsumption.ArbiterRule`) and
sampled at a fixed period of runtime time.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from roslib.message import get_message_class
from std_msgs.msg import UInt32

from subsumption import ArbiterKind, ArbiterRule, NodeHandle
from subsumption.network.wiring import Wiring

SAMPLE_PERIOD = 0.1  # s of runtime time between samples of the arbiters' state


@dataclass
class ArbiterShare:
    name: str
    rule: ArbiterRule
    samples: int = 0
    upper_samples: int = 0

    @property
    def fraction(self) -> float:
        return self.upper_samples / self.samples if self.samples else 0.0


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
            share = self.shares[arbiter.name] = ArbiterShare(
                arbiter.name, ArbiterRule(ArbiterKind(arbiter.kind), float(arbiter.time_constant)))
            if share.rule.kind is ArbiterKind.DEFAULTER:  # the lower line decides who holds a defaulter
                self.node.subscribe(f"/{prefix}{arbiter.lower.lstrip('/')}", get_message_class(arbiter.line_type),
                                    lambda _msg, s=share: s.rule.on_lower(self.node.now()))
            self.node.subscribe(f"/{prefix}{arbiter.upper.lstrip('/')}", get_message_class(arbiter.upper_type),
                                lambda _msg, s=share: s.rule.on_upper(self.node.now()))
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
            share.samples += 1
            share.upper_samples += share.rule.upper_in_control(now)

    def trajectory(self) -> np.ndarray:
        """(x, y) rows of the true path."""
        return np.array([p[1:] for p in self.path]).reshape(-1, 2)
