"""The pure simulation: a world, its robots and agents, advanced by ``step(dt)``; no ROS transport at all.

Physics is kinematic with solid walls. A robot's motion in one step is cut into sub-steps no longer than half
a map cell, and every sub-step is checked exactly against the cells around the robot and against the other
circles; a blocked sub-step is shortened by bisection until the robot just touches. Nothing can therefore
tunnel through a wall, however thin or fast. A new contact counts as one collision.

Everything random (sensor and odometry noise, wanderers' turns) comes from one seeded numpy Generator, and
the order of updates is fixed, so a run is reproducible to the bit from its seed and its commands.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.path import Path as MplPath

from . import raycast
from subsumption.planar import wrap

from .bodies import Agent, Robot, arc, start_pose_of_agent
from .camera import Camera, CameraFrame, Scene
from .mapio import GridMap
from .world import RobotSpec, World, WorldError, load_world

TOUCH = 0.005  # m: a rim this close to something is in contact with it
RELEASE = 0.01  # m: contact ends only when the gap grows beyond this (hysteresis against flicker)
START_MARGIN = 0.3  # m of clearance wanted around a start pose that the world does not give
AGENT_MARGIN = 0.02  # m an agent keeps from everything: agents never touch; robots may run into them
ROBOT_CLEARANCE = 0.3  # m an agent keeps from every robot's rim (a person does not brush past a machine)


@dataclass
class SensorGeometry:
    """Where a robot's rays start and point, relative to its body, precomputed once per robot."""

    laser_angles: np.ndarray  # (beams,) relative to the heading
    sonar_mounts: np.ndarray  # (count,) mount angle of each sonar on the rim
    sonar_ray_offsets: np.ndarray  # (rays,) offsets of the rays within a cone
    laser_max: float
    sonar_max: float

    @classmethod
    def of(cls, spec: RobotSpec) -> "SensorGeometry":
        laser, mounts, offsets = np.zeros(0), np.zeros(0), np.zeros(1)
        if spec.laser is not None:
            start, step, last = spec.laser.angles()
            if spec.laser.full_circle:
                laser = start + step * np.arange(spec.laser.beams)
            else:
                laser = np.linspace(start, last, spec.laser.beams)
        if spec.sonar is not None:
            mounts = np.arange(spec.sonar.count) * (2 * math.pi / spec.sonar.count)
            half = math.radians(spec.sonar.fov_deg) / 2
            offsets = np.linspace(-half, half, spec.sonar.rays) if spec.sonar.rays > 1 else np.zeros(1)
        return cls(laser, mounts, offsets, spec.laser.max_range if spec.laser else 0.0,
                   spec.sonar.max_range if spec.sonar else 0.0)


@dataclass
class Reading:
    """One sweep of a robot's sensors. Ranges follow REP 117: -inf too close, +inf nothing within range."""

    time: float
    laser: np.ndarray  # (beams,) metres
    sonar: np.ndarray  # (count,) metres


def _rep117(ranges: np.ndarray, lo: float, hi: float) -> np.ndarray:
    out = ranges.copy()
    out[~(ranges <= hi)] = math.inf  # also NaN-safe
    out[ranges < lo] = -math.inf
    return out


class Simulation:
    """World + robots + agents on a simulated clock. All state is plain Python and numpy, readable by tests
    and experiment code (``sim.robots['robot0'].x``, ``sim.collisions()``, ``sim.trajectories()``)."""

    def __init__(self, world: World | str | Path, seed: int | None = 0, record: bool = True) -> None:
        self.world = world if isinstance(world, World) else load_world(world)
        self.map: GridMap = self.world.map
        self.rng = np.random.default_rng(seed)
        self.time = 0.0
        self.record = record
        raycast.warm_up()
        self.agents: dict[str, Agent] = {}
        self.robots: dict[str, Robot] = {}
        for i, aspec in enumerate(self.world.agents):
            pose = start_pose_of_agent(aspec)
            self._check_free(pose, aspec.radius, f"agents[{i}].{'start' if aspec.start else 'waypoints[0]'}")
            self.agents[aspec.name] = Agent(aspec, *pose)
        for i, rspec in enumerate(self.world.robots):
            pose = rspec.start if rspec.start is not None else self.free_pose(rspec.radius)
            self._check_free(pose, rspec.radius, f"robots[{i}].start")
            self.robots[rspec.name] = Robot(rspec, *pose)
        # the floor's drops (world cliffs), as matplotlib paths for their point-in-polygon test
        self._cliffs = [MplPath(np.array(polygon, dtype=float)) for polygon in self.world.cliffs]
        for i, rspec in enumerate(self.world.robots):
            if self.over_cliff(self.robots[rspec.name].x, self.robots[rspec.name].y):
                raise WorldError.at(self.world.source or "(world)", f"robots[{i}].start",
                                    "is over a cliff: the robot would start at the bottom of it")
        self.geometry = {name: SensorGeometry.of(r.spec) for name, r in self.robots.items()}
        self._history: dict[str, list[tuple[float, float, float, float]]] = {
            name: [(0.0, *body.pose())] for name, body in self._bodies()}
        self._cameras: dict[str, Camera] | None = None  # built at the first frame: worlds without one pay nothing

    def _check_free(self, pose: tuple[float, float, float], radius: float, where: str) -> None:
        """A body that starts inside a wall or another body could never move: say so, naming the field."""
        if self.gap(pose[0], pose[1], radius, self.circles()) < 0:
            raise WorldError.at(self.world.source or "(world)", where,
                                f"{tuple(pose)} is not free: a circle of radius {radius} there overlaps a wall "
                                "or another body")

    # Queries ------------------------------------------------------------------------------------------
    def _bodies(self):
        yield from self.robots.items()
        yield from self.agents.items()

    def circles(self, exclude: str | None = None, agents: bool = True) -> np.ndarray:
        """(n, 3) array of (x, y, radius) of every body except `exclude` (and the agents, if not `agents`)."""
        bodies = self._bodies() if agents else iter(self.robots.items())
        rows = [(b.x, b.y, b.radius) for name, b in bodies if name != exclude]
        return np.array(rows, dtype=np.float64).reshape(-1, 3) if rows else raycast.NO_CIRCLES

    def gap(self, x: float, y: float, r: float, others: np.ndarray, reach: float = 0.05) -> float:
        """Free distance from the rim of circle (x, y, r) to walls and `others`, capped at `reach`."""
        m = self.map
        return raycast.body_gap(m.solid, m.wall_distance, m.origin[0], m.origin[1], m.resolution, x, y, r,
                                reach, others)

    def over_cliff(self, x: float, y: float) -> bool:
        """True when the floor at (x, y) drops away (inside one of the world's cliffs)."""
        return any(path.contains_point((x, y)) for path in self._cliffs)

    def free_pose(self, radius: float) -> tuple[float, float, float]:
        """A deterministic free start: the cell nearest the map centre with room around it, facing +x."""
        m = self.map
        ok = m.wall_distance >= radius + START_MARGIN + m.resolution
        rows, cols = np.nonzero(ok)
        if rows.size == 0:
            raise ValueError(f"{m.source}: no free place for a robot of radius {radius}")
        xs = m.origin[0] + (cols + 0.5) * m.resolution
        ys = m.origin[1] + (rows + 0.5) * m.resolution
        others = self.circles()
        if len(others):
            d = np.hypot(xs[:, None] - others[:, 0], ys[:, None] - others[:, 1]) - others[:, 2]
            keep = d.min(axis=1) >= radius + START_MARGIN
            xs, ys = xs[keep], ys[keep]
            if xs.size == 0:
                raise ValueError(f"{m.source}: no free place left for a robot of radius {radius}")
        cx, cy = m.origin[0] + m.width_m / 2, m.origin[1] + m.height_m / 2
        best = int(np.argmin(np.hypot(xs - cx, ys - cy)))
        return float(xs[best]), float(ys[best]), 0.0

    # Commands and time ------------------------------------------------------------------------------
    def set_command(self, robot: str, v: float, w: float) -> None:
        """Ask `robot` to drive at v m/s and turn at w rad/s (clipped to its limits) from now on."""
        self.robots[robot].command(v, w, self.time)

    def step(self, dt: float) -> None:
        """Advance the world by dt seconds: agents follow their scripts, robots their commands."""
        if not dt > 0:
            raise ValueError(f"step needs dt > 0, got {dt!r}")
        robots = self.circles(agents=False)  # they stand still while the agents step
        for agent in self.agents.values():
            self._move_agent(agent, dt, robots)
        for robot in self.robots.values():
            robot.lifted = any(start <= self.time < end for start, end in robot.spec.lifted)
            robot.accelerate(self.time, dt)
            if robot.lifted or robot.fallen:  # wheels off the floor: they spin, the robot goes nowhere
                robot.v = robot.w = 0.0
                continue
            self._move_robot(robot, dt)
            if self._cliffs and self.over_cliff(robot.x, robot.y):
                robot.fallen = True  # over the edge: a collision with the floor below, and the end of its run
                robot.collisions += 1
                robot.collision_points.append((robot.x, robot.y))
        self.time += dt
        if self.record:
            t = self.time
            for name, body in self._bodies():
                self._history[name].append((t, body.x, body.y, body.theta))

    def _move_agent(self, agent: Agent, dt: float, robots: np.ndarray) -> None:
        """One agent's step, in sub-steps short enough not to tunnel. An agent never touches anything and keeps
        ROBOT_CLEARANCE from every robot (a step that leaves it nearer a robot than that is not taken unless it
        moves away from the robot). A walker blocked by another agent steps aside, right first, if that is free;
        one blocked by a wall turns back to its lane; one a robot is in the way of waits, then gives way."""
        if not agent.started and not self._cue_given(agent):
            return
        agent.started = True
        others = self.circles(exclude=agent.name)
        substeps = max(1, math.ceil(agent.spec.speed * dt / (0.5 * self.map.resolution)))  # no tunnelling
        r = agent.radius
        held = False  # a robot, or an agent it cannot step round, was in its way
        for _ in range(substeps):
            x, y, th = agent.proposal(dt / substeps)
            if self._nearing_robot(agent, x, y, robots):
                held = True  # a walker waits for the robot (a way round one that may move any moment is no way)
                agent.blocked(self.rng)  # and a wanderer turns away
                break
            if self.gap(x, y, r, others) < AGENT_MARGIN:
                by_agent = self.gap(x, y, r, raycast.NO_CIRCLES) >= AGENT_MARGIN
                ways = agent.sidesteps(x, y) if by_agent else [p for p in [agent.to_lane(x, y)] if p is not None]
                aside = next((p for p in ways if self.gap(p[0], p[1], r, others) >= AGENT_MARGIN
                              and not self._nearing_robot(agent, p[0], p[1], robots)), None)
                if aside is None:
                    # two walkers who cannot step round each other (a door, a corner): the first to run out of
                    # patience gives way, the other waits for it
                    blocker = self._blocker(agent, x, y) if by_agent else None
                    held = blocker is not None and not blocker.giving_way
                    agent.blocked(self.rng)
                    break
                x, y, th = aside
            agent.moved(x, y, th)
        agent.hold(held, dt)

    def _blocker(self, agent: Agent, x: float, y: float) -> Agent | None:
        """The other agent in the way of `agent` stepping to (x, y), if one is (not a robot, not a wall)."""
        gaps = [(math.hypot(a.x - x, a.y - y) - a.radius - agent.radius, a) for a in self.agents.values()
                if a is not agent]
        gap, nearest = min(gaps, key=lambda g: g[0], default=(math.inf, None))
        return nearest if gap < AGENT_MARGIN else None

    @staticmethod
    def _nearing_robot(agent: Agent, x: float, y: float, robots: np.ndarray) -> bool:
        """Whether the step to (x, y) brings the agent nearer than ROBOT_CLEARANCE to a robot it is coming closer to."""
        if len(robots) == 0:
            return False
        after = np.hypot(robots[:, 0] - x, robots[:, 1] - y) - robots[:, 2] - agent.radius
        before = np.hypot(robots[:, 0] - agent.x, robots[:, 1] - agent.y) - robots[:, 2] - agent.radius
        return bool(np.any((after < ROBOT_CLEARANCE) & (after < before)))

    def _cue_given(self, agent: Agent) -> bool:
        """Whether a standing agent may start: its `wait` is over and its cue's robot is near enough (if it has one)."""
        if self.time < agent.spec.wait - 1e-9:
            return False
        cue = agent.spec.cue
        if cue is None:
            return True
        robot = self.robots[cue.robot]
        return math.hypot(robot.x - cue.near[0], robot.y - cue.near[1]) <= cue.within

    def _move_robot(self, robot: Robot, dt: float) -> None:
        others = self.circles(exclude=robot.name)
        r = robot.radius
        substeps = max(1, math.ceil(abs(robot.v) * dt / (0.5 * self.map.resolution)))
        h = dt / substeps
        ds, dth = robot.v * h, robot.w * h
        moved, turned = 0.0, 0.0
        blocked = False
        for _ in range(substeps):
            x, y, th = arc(robot.x, robot.y, robot.theta, ds, dth)
            if ds == 0.0 or self.gap(x, y, r, others) >= 0.0:
                robot.x, robot.y, robot.theta = x, y, th
                moved, turned = moved + ds, turned + dth
                continue
            # Blocked: find by bisection how much of this sub-step is free; turning alone is always free.
            lo, hi = 0.0, 1.0
            for _ in range(12):
                mid = 0.5 * (lo + hi)
                mx, my, _th = arc(robot.x, robot.y, robot.theta, ds * mid, dth * mid)
                if self.gap(mx, my, r, others) >= 0.0:
                    lo = mid
                else:
                    hi = mid
            x, y, _th = arc(robot.x, robot.y, robot.theta, ds * lo, dth * lo)
            robot.x, robot.y, robot.theta = x, y, th
            moved, turned = moved + ds * lo, turned + dth
            blocked = True
            break
        if blocked:
            robot.v = 0.0
            remaining = substeps * dth - turned  # finish the turn of the sub-steps not taken
            robot.theta += remaining
            turned += remaining
        robot.theta = wrap(robot.theta)
        robot.update_odometry(moved, turned, self.rng)
        self._settle_contact(robot, others, blocked)

    def _settle_contact(self, robot: Robot, others: np.ndarray, blocked: bool) -> None:
        gap = self.gap(robot.x, robot.y, robot.radius, others)
        touching = blocked or gap <= (RELEASE if robot.in_contact else TOUCH)
        if touching and not robot.in_contact:
            robot.collisions += 1
            robot.collision_points.append((robot.x, robot.y))
        robot.in_contact = touching
        if touching:
            m = self.map
            robot.bumper = int(raycast.contact_bits(m.solid, m.origin[0], m.origin[1], m.resolution, robot.x,
                                                    robot.y, robot.theta, robot.radius, RELEASE, others))
        else:
            robot.bumper = 0

    # Sensors ---------------------------------------------------------------------------------------------
    def sense(self, robot: str) -> Reading:
        """Laser and sonar ranges of `robot` now, with its seeded noise, as numpy arrays (REP 117)."""
        body = self.robots[robot]
        spec, geo, m = body.spec, self.geometry[robot], self.map
        laser, sonar = raycast.sweep(m.solid, m.wall_distance, m.origin[0], m.origin[1], m.resolution, body.x, body.y, body.theta,
                                     body.radius, geo.laser_angles, geo.laser_max, geo.sonar_mounts,
                                     geo.sonar_ray_offsets, geo.sonar_max, self.circles(exclude=robot))
        if spec.laser is not None:
            if spec.laser.noise > 0:
                laser = laser + self.rng.normal(0.0, spec.laser.noise, laser.shape)
            laser = _rep117(laser, spec.laser.min_range, spec.laser.max_range)
        if spec.sonar is not None:
            if spec.sonar.noise > 0:
                sonar = sonar + self.rng.normal(0.0, spec.sonar.noise, sonar.shape)
            sonar = _rep117(sonar, spec.sonar.min_range, spec.sonar.max_range)
        return Reading(self.time, laser, sonar)

    def camera(self, robot: str) -> Camera:
        """The camera of `robot` (KeyError if its spec has none)."""
        if self._cameras is None:
            from . import render
            render.warm_up()
            scene = Scene(self.world)
            self._cameras = {name: Camera(r.spec.camera, scene) for name, r in self.robots.items()
                             if r.spec.camera is not None}
        return self._cameras[robot]

    def render(self, robot: str, rgb: bool = True) -> CameraFrame:
        """What `robot`'s camera sees now (same state as :meth:`sense`): depth, and colour unless the camera is
        in ``depth_band`` mode or `rgb` is False. Depth noise, if any, comes from the simulation's seeded
        generator (drawn whether or not colour is rendered, so that the run does not depend on who watches)."""
        return self.camera(robot).render(self, robot, self.rng, rgb)

    # Records for experiments --------------------------------------------------------------------------------
    def history(self, name: str) -> np.ndarray:
        """(N, 4) array of (t, x, y, yaw) of robot or agent `name`, one row per physics step (if recording)."""
        return np.array(self._history[name], dtype=np.float64)

    def trajectories(self) -> dict[str, np.ndarray]:
        """{name: (N, 2) array of x, y} for every robot and agent, as plot_run wants them."""
        return {name: self.history(name)[:, 1:3] for name in self._history}

    def collisions(self) -> dict[str, int]:
        return {name: r.collisions for name, r in self.robots.items()}

    def collision_points(self) -> dict[str, list[tuple[float, float]]]:
        return {name: list(r.collision_points) for name, r in self.robots.items()}
