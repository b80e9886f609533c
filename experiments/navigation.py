"""`subsumption navigate`: a robot drives to random reachable goals through move_base, localizing with AMCL.

    subsumption navigate (--world W | --map M) --goals N --seed S --runtime local|ros --out D

The robot runs :class:`navigation.move_base.MoveBase` and :class:`navigation.amcl.Amcl` (started at the world's
start pose); the simulator publishes the map (as a map server would) but not ``map -> odom``: AMCL does. Goals go
one after another through the ``move_base`` action (:class:`subsumption.actions.ActionClient`), each a random
free pose at least ``clearance`` m from walls, reachable from the start, drawn with the seed. The truth
(``ground_truth``) only scores: per goal the travelled length over the shortest collision-free length
(``path_ratio``), whether the server said SUCCEEDED and whether the robot truly stood within the tolerance;
``loc_rmse_m`` is AMCL's RMS error over the run.

Writes ``D/navigation.png`` (the map, the true path, the goals: green reached, red not) and ``D/metrics.json``.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib
import numpy as np
import rospy
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from scipy.ndimage import distance_transform_edt, label

from navigation.costmap import Costmap, InflationParams
from navigation.move_base import MoveBase
from navigation.planner import PlanError, PlannerParams, plan
from subsim.mapio import MapError, load_map
from subsim.world import WorldDocument, WorldError, load_world
from subsumption import arguments
from subsumption.actions import ActionClient, ClientGoal, GoalStatus
from subsumption.mapfile import OCCUPIED, OccupancyMap
from subsumption.metricsfile import write_metrics
from subsumption.network.spec import Network
from subsumption.planar import pose_msg, wrap
from subsumption.runtime import NodeHandle

from .launch_local import launch_local
from .launch_ros import ros_session, simulator_command
from .localization import localization_error
from .mapping import MOVE_BASE_LOCAL, MappingRecorder, move_base_params, navigation_network, prepare_world
from .runner import param_overrides, world_for_map

matplotlib.use("Agg")  # headless: figures are files, on CI and over ssh alike
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

ROBOT_RADIUS = 0.18
GOAL_CLEARANCE = 0.35  # m from walls: goals a robot can stand on with room to turn
MIN_GOAL_DISTANCE = 1.0  # m between consecutive goals


class NavigationError(ValueError):
    """A run cannot be set up (bad option or file); the message says which."""


def reachable_free(grid: OccupancyMap, start: tuple[float, float], clearance: float) -> np.ndarray:
    """Cells at least `clearance` m from any wall (unknown counts as wall) and connected to `start` through
    cells the robot's centre may occupy."""
    walls = grid.occupancy != 0
    distance = distance_transform_edt(~walls) * grid.resolution
    passable = distance > ROBOT_RADIUS + 0.02
    labels, _ = label(passable, structure=np.ones((3, 3)))
    row, col = grid.cell_of(*start)
    if not (0 <= row < grid.shape[0] and 0 <= col < grid.shape[1]) or labels[row, col] == 0:
        raise NavigationError(f"the start ({start[0]:.2f}, {start[1]:.2f}) is not on free space of the map")
    return (labels == labels[row, col]) & (distance >= clearance)


def draw_goals(grid: OccupancyMap, start: tuple[float, float], count: int, seed: int) -> np.ndarray:
    """`count` goals (x, y, yaw), each MIN_GOAL_DISTANCE m or more from the one before (the first from the
    start), on reachable free space, from `seed`."""
    rng = np.random.default_rng(seed)
    rows, cols = np.nonzero(reachable_free(grid, start, GOAL_CLEARANCE))
    if len(rows) == 0:
        raise NavigationError(f"{grid.source}: no free space {GOAL_CLEARANCE} m from the walls is reachable")
    xy = np.column_stack((grid.origin[0] + (cols + 0.5) * grid.resolution,
                          grid.origin[1] + (rows + 0.5) * grid.resolution))
    goals, previous = [], np.asarray(start, dtype=float)
    for _ in range(count):
        far = np.hypot(*(xy - previous).T) >= MIN_GOAL_DISTANCE
        pool = xy[far] if far.any() else xy
        pick = pool[rng.integers(len(pool))]
        goals.append([pick[0], pick[1], float(rng.uniform(-math.pi, math.pi))])
        previous = pick
    return np.array(goals)


def shortest_length(grid: OccupancyMap, start: np.ndarray, goal: np.ndarray) -> float:
    """The shortest path length between two points keeping the robot's radius off the walls (A* with no cost
    for nearness, shortened by line of sight): the denominator of path_ratio."""
    costmap = Costmap(grid, InflationParams(robot_radius=ROBOT_RADIUS, inflation_radius=ROBOT_RADIUS))
    try:
        return plan(costmap, (start[0], start[1]), (goal[0], goal[1]),
                    PlannerParams(cost_factor=0.0, allow_unknown=False, lookahead_cells=100000)).length()
    except PlanError:
        return math.nan


@dataclass
class GoalRecord:
    goal: list[float]
    start_time: float
    status: str = "PENDING"
    text: str = ""
    end_time: float | None = None
    travelled_m: float = 0.0
    shortest_m: float = math.nan
    true_error_m: float = math.nan
    true_yaw_error_rad: float = math.nan


@dataclass
class GoalRunner:
    """Sends the goals one after another through the move_base action on `node`, with a time limit each."""

    node: NodeHandle
    goals: np.ndarray
    timeout: float
    client: ActionClient = field(init=False)
    records: list[GoalRecord] = field(default_factory=list)
    active: ClientGoal | None = None
    finished: bool = False

    def __post_init__(self) -> None:
        self.client = ActionClient(self.node, "/move_base", MoveBaseAction)
        self.node.call_every(0.5, self._tick)

    def _tick(self) -> None:
        if self.finished or not self.client.server_seen:
            return
        now = self.node.now()
        if self.active is not None:
            record = self.records[-1]
            if not self.active.done and now - record.start_time > self.timeout:
                self.active.cancel()
                record.text = f"time limit {self.timeout:.0f} s"
            return
        if len(self.records) == len(self.goals):
            self.finished = True
            return
        goal = self.goals[len(self.records)]
        msg = MoveBaseGoal()
        msg.target_pose.header.frame_id = "map"
        msg.target_pose.header.stamp.secs = int(now)
        msg.target_pose.pose = pose_msg(goal)
        self.records.append(GoalRecord([round(float(v), 3) for v in goal], now))
        self.active = self.client.send_goal(msg, done=self._done)

    def _done(self, handle: ClientGoal) -> None:
        record = self.records[-1]
        record.status = handle.status_name
        record.text = (record.text + "; " if record.text else "") + handle.text
        record.end_time = self.node.now()
        self.active = None


def score(recorder: MappingRecorder, runner: GoalRunner, grid: OccupancyMap, tolerance: tuple[float, float],
          wall: float, cpu: float | None) -> dict:
    stamps = np.array(sorted(recorder.truth))
    poses = np.array([recorder.truth[t] for t in stamps]).reshape(-1, 3)
    for record in runner.records:
        end = record.end_time if record.end_time is not None else recorder.last_time
        inside = (stamps >= record.start_time) & (stamps <= end)
        if inside.sum() >= 2:
            xy = poses[inside, :2]
            record.travelled_m = float(np.hypot(*np.diff(xy, axis=0).T).sum())
            record.shortest_m = shortest_length(grid, poses[inside][0], np.array(record.goal))
            final = poses[inside][-1]
            record.true_error_m = float(math.hypot(final[0] - record.goal[0], final[1] - record.goal[1]))
            record.true_yaw_error_rad = abs(float(wrap(final[2] - record.goal[2])))
    reached = [r for r in runner.records if r.status == "SUCCEEDED"]
    # truly there: the estimate was within tolerance; the truth may differ by the localization error
    truly = [r for r in reached if r.true_error_m <= tolerance[0] + 0.1]
    ratios = [r.travelled_m / r.shortest_m for r in reached if r.shortest_m and r.shortest_m > 0.3]
    loc = localization_error(recorder, settle=0.0)
    metrics = {
        "goals": len(runner.goals),
        "reached": len(reached),
        "reached_truly": len(truly),
        "aborted": sum(r.status == "ABORTED" for r in runner.records),
        "preempted": sum(r.status in ("PREEMPTED", "RECALLED") for r in runner.records),
        "collisions": recorder.collisions,
        "path_ratio": round(float(np.mean(ratios)), 3) if ratios else None,
        "path_ratio_max": round(float(np.max(ratios)), 3) if ratios else None,
        **loc,
        "sim_time_s": round(recorder.last_time, 3),
        "wall_time_s": round(wall, 3),
        "cpu_time_s": round(cpu, 3) if cpu is not None else None,
        "per_goal": [{k: (round(v, 3) if isinstance(v, float) else v) for k, v in vars(r).items()}
                     for r in runner.records],
    }
    return metrics


def navigate_network(start: list, seed: int, move_base: dict) -> Network:
    """navigation/networks/navigate.yaml (amcl and move_base) with the run's own parameters: amcl starts at the
    world's start pose with the run's seed, move_base gets `move_base`."""
    return navigation_network("navigate", {"amcl": _amcl_params(start, seed), "move_base": dict(move_base)})


def run_local(world: Path, start: list, goals: np.ndarray, seed: int, timeout: float,
              move_base_params: dict | None = None) -> tuple[MappingRecorder, GoalRunner, float, float, object]:
    """The run in one process (:func:`~experiments.launch_local.launch_local`), until every goal is done or a
    time limit. Returns the recorder, the goal runner, wall and CPU time, and the simulator's bridge."""
    network = navigate_network(start, seed, {**MOVE_BASE_LOCAL, **(move_base_params or {})})
    run = launch_local(world, [(network, None)], timeout * (len(goals) + 1) + 10.0, seed,
                       {"map_to_odom": False, "publish_map": True},
                       setup=lambda runtime: MappingRecorder(runtime.node("navigation_recorder")),
                       observe=lambda runtime, _built: GoalRunner(runtime.node("goal_sender"), goals, timeout),
                       stop=lambda run: run.observed.finished, step=5.0)
    return run.prepared, run.observed, run.wall, run.cpu, run.bridge


def _amcl_params(start: list, seed: int) -> dict:
    return {"initial_pose_x": float(start[0]), "initial_pose_y": float(start[1]), "initial_pose_a": float(start[2]),
            "initial_cov_xx": 0.01, "initial_cov_yy": 0.01, "initial_cov_aa": 0.01, "seed": seed}


def run_ros(world: Path, start: list, goals: np.ndarray, seed: int, timeout: float, rate: float,
            move_base_params: dict | None = None, progress: bool = True) -> tuple[MappingRecorder, GoalRunner, float]:
    """The real graph (:func:`~experiments.launch_ros.ros_session`): a private master, the simulator, amcl and
    move_base (navigation/networks/navigate.yaml through roslaunch), and this process sending the goals with the
    action client and recording the truth; everything started here is stopped here, by pid; the logs stay in
    $TMPDIR/subsumption_navigate_PID/."""
    network = navigate_network(start, seed, move_base_params or {})
    duration = timeout * (len(goals) + 1) + 10.0
    simulator = simulator_command(world, rate, seed, duration, map_to_odom=False, publish_map=True)
    log_dir = Path(os.environ.get("TMPDIR", "/tmp")) / f"subsumption_navigate_{os.getpid()}"
    with ros_session("navigation_recorder", log_dir, progress=progress) as session:
        recorder = MappingRecorder(session.node)
        with session.node.lock:
            runner = GoalRunner(session.node, goals, timeout)
        session.launch(network, None, f"{network.name}.log")
        running = session.start(simulator, "simulator.log", "KILL")
        wall = session.follow(running, lambda elapsed: f"navigating: simulated {rospy.get_time():6.1f} s, goal "
                                                       f"{len(runner.records)} / {len(goals)}, wall {elapsed:5.1f} s",
                              done=lambda: runner.finished)
        if running.poll() not in (0, None):
            raise RuntimeError(f"simulator exited with status {running.returncode}; see {log_dir}/simulator.log")
        return recorder, runner, wall


def draw(grid: OccupancyMap, recorder: MappingRecorder, runner: GoalRunner, bridge, out_path: Path,
         title: str) -> Path:
    stamps = sorted(recorder.truth)
    xy = np.array([recorder.truth[t][:2] for t in stamps]).reshape(-1, 2)
    aspect = grid.height_m / max(grid.width_m, 1e-9)
    fig, ax = plt.subplots(figsize=(8, max(3.0, min(12.0, 8 * aspect)) + 0.6))
    grid.draw(ax)
    if len(xy):
        ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:blue", lw=0.8, label="true path")
    for i, record in enumerate(runner.records):
        ok = record.status == "SUCCEEDED"
        ax.plot(record.goal[0], record.goal[1], "o", color="tab:green" if ok else "tab:red", ms=5)
        ax.annotate(str(i + 1), (record.goal[0], record.goal[1]), fontsize=6, xytext=(3, 3),
                    textcoords="offset points")
    if bridge is not None:
        hits = [p for points in bridge.collision_points().values() for p in points]
        if hits:
            pts = np.asarray(hits)
            ax.plot(pts[:, 0], pts[:, 1], "x", color="red", ms=9, mew=2, label=f"collisions ({len(hits)})")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out_path, dpi=100)
    plt.close(fig)
    return out_path


def pick_start(grid: OccupancyMap, seed: int) -> list[float]:
    """A start pose for a bare map: a free cell well clear of walls (the one furthest from them, ties by seed)."""
    walls = grid.occupancy != 0
    distance = distance_transform_edt(~walls) * grid.resolution
    rows, cols = np.nonzero(distance >= min(0.5, float(distance.max())))
    if len(rows) == 0:
        raise NavigationError(f"{grid.source}: no free space to start on")
    i = np.random.default_rng(seed).integers(len(rows))
    x, y = grid.centre_of(int(rows[i]), int(cols[i]))
    return [x, y, 0.0]


def navigate(world: Path | None, map_yaml: Path | None, goals: int, seed: int, runtime: str, out: Path,
             timeout: float = 90.0, rate: float = 5.0, odom_noise: float = 0.02,
             params: dict | None = None, sensor: str | None = None, extra: dict | None = None) -> dict:
    if goals < 1:
        raise NavigationError(f"--goals must be >= 1, got {goals}")
    out.mkdir(parents=True, exist_ok=True)
    if world is None:
        grid = load_map(map_yaml)
        world = world_for_map(map_yaml, out, tuple(pick_start(grid, seed)))
    doc = WorldDocument(world)
    grid = load_map(doc.map_path)
    if not doc.start:
        doc.robot["start"] = pick_start(grid, seed)
    world_file, start = prepare_world(doc, out, sensor, odom_noise)
    robot = load_world(world_file).robots[0]
    if robot.laser is None:
        raise NavigationError(f"{world}: robots[0] ({robot.name!r}, a {robot.kind}) has no range scan "
                              f"(sensors.laser): amcl and move_base read one; give it one in the world file, or "
                              f"run with --sensor laser or --sensor depth")
    # a narrow scan (a depth camera's) drives as frontier exploration's does: its hits remembered, onto ground seen
    # free, off the corners of wall cells (the office with the depth scan, 5 goals: 3 collisions before, 0 after)
    params = {**move_base_params(world_file), **(params or {})}
    targets = draw_goals(grid, (start[0], start[1]), goals, seed)
    bridge = None
    if runtime == "ros":
        recorder, runner, wall = run_ros(world_file, start, targets, seed, timeout, rate, params)
        cpu = None
    else:
        recorder, runner, wall, cpu, bridge = run_local(world_file, start, targets, seed, timeout, params)
    metrics = score(recorder, runner, grid, (0.1, 0.1), wall, cpu)
    title = (f"navigate on {doc.map_path.stem}, {goals} goals, seed {seed}, {runtime}: reached "
             f"{metrics['reached']}/{goals}, {metrics['collisions']} collisions, path ratio {metrics['path_ratio']}, "
             f"AMCL RMS {metrics['loc_rmse_m']} m")
    draw(grid, recorder, runner, bridge, out / "navigation.png", title)
    result = {"world": str(world), "map": doc.data["map"], "seed": seed, "runtime": runtime, "odom_noise": odom_noise,
              **metrics, **(extra or {})}  # extra: a caller's own keys (a bench's world name), in the one write
    write_metrics(out, result)
    return result


# The command -------------------------------------------------------------------------------------------------
def register_navigate(commands: argparse._SubParsersAction) -> None:
    cmd = commands.add_parser(
        "navigate", help="drive to N random reachable goals through move_base, localizing with AMCL; "
                         "write a picture and metrics.json",
        description="A robot in a simulator world is sent to random reachable goals one after another through "
                    "the move_base action (navigation.move_base:MoveBase), localizing with AMCL "
                    "(navigation.amcl:Amcl), never with the truth; the truth scores the run.")
    where = cmd.add_mutually_exclusive_group(required=True)
    where.add_argument("--world", type=Path, help="a simulator world file (people and robots in it walk about)")
    where.add_argument("--map", type=Path, help="a map_server map (YAML); one robot is put on it")
    cmd.add_argument("--goals", type=arguments.count(1, "a number of goals >= 1"), default=10, help="number of goals, one after another (default 10)")
    cmd.add_argument("--seed", type=arguments.seed, default=0, help="random seed of the goals and the simulator (default 0)")
    cmd.add_argument("--runtime", choices=("local", "ros"), default="local",
                     help="local: one process, fast, reproducible; ros: simulator, amcl and move_base as ROS nodes "
                          "on a private master (default local)")
    cmd.add_argument("--rate", type=arguments.number(0.0, True, "simulated s per wall s, >= 0"), default=5.0,
                     help="ros: simulated s per wall s (default 5)")
    cmd.add_argument("--timeout", type=arguments.number(0.0, False, "simulated seconds > 0"), default=90.0,
                     help="simulated s a goal may take before it is cancelled (default 90)")
    cmd.add_argument("--odom-noise", type=arguments.number(0.0, True, "a relative noise >= 0"), default=0.02, help="relative odometry noise (default 0.02)")
    cmd.add_argument("--sensor", choices=("laser", "depth"), default=None,
                     help="the robot's range scan: the 270-degree laser, or a 58-degree depth-camera scan as "
                          "`subsumption map` has (default: the world file's)")
    cmd.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                     help="a move_base parameter (e.g. xy_goal_tolerance=0.2); repeatable")
    cmd.add_argument("--out", type=Path, required=True,
                     help="folder for navigation.png and metrics.json (made if missing)")
    cmd.set_defaults(func=cmd_navigate)


def _parse_params(items: list[str]) -> dict:
    return param_overrides(items, MoveBase, NavigationError)


def cmd_navigate(args: argparse.Namespace) -> int:
    try:
        params = _parse_params(args.param)
        m = navigate(args.world, args.map, args.goals, args.seed, args.runtime, args.out, args.timeout, args.rate,
                     args.odom_noise, params, args.sensor)
    except (MapError, WorldError, NavigationError, FileNotFoundError) as error:
        print(f"subsumption navigate: {error}", file=sys.stderr)
        return 2
    print(f"{args.out}/metrics.json: reached {m['reached']}/{m['goals']} ({m['reached_truly']} truly within "
          f"tolerance), {m['collisions']} collisions, path ratio {m['path_ratio']}, AMCL RMS {m['loc_rmse_m']} m, "
          f"{m['sim_time_s']:.0f} s simulated in {m['wall_time_s']:.1f} s")
    return 0
