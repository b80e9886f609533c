"""`subsumption map`: a robot maps a world while it drives itself; the map is scored against the truth.

    subsumption map --world W --duration T --seed S --runtime local|ros --out D [--explore wander|frontier]
                    [--sensor laser|depth] [--odom-noise 0.02] [--odom-turn-noise N]

Writes ``D/map.yaml`` + ``D/map.pgm`` (a map_server map that subsim and the localizer load back),
``D/map_vs_truth.png`` (the built map with SLAM's trajectory beside the true map with the true path, and the
two overlaid) and ``D/metrics.json`` (``collisions``, ``sim_time_s``, ``wall_time_s``, ``ate_m`` and the map
scores of :mod:`experiments.mapping_metrics`).

SLAM (:class:`navigation.slam.Slam`) gets only the scan, odometry and /tf_static; the simulator runs with
its own ``map -> odom`` and ``/map`` switched off. The truth (``ground_truth``) is recorded for scoring only.
The driver is a choice: ``wander`` (the wander robot's levels 0-2: Brooks' explore level) or ``frontier``
(:class:`navigation.explore.Explore` sending goals to :class:`navigation.move_base.MoveBase`, on SLAM's map and
pose; the run ends early when nothing reachable is left unknown, with ``explore_done`` in metrics.json).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import rospy
import yaml
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import OccupancyGrid, Odometry, Path as PathMsg
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, UInt32
from tf2_msgs.msg import TFMessage

from navigation.bag_map import cli_map_bag
from navigation.explore import Explore
from navigation.scan_geometry import Beams, MountListener, beams_of
from navigation.slam import Slam
from subsim.mapio import MapError, load_map
from subsim.world import WorldDocument, WorldError
from subsumption import arguments
from subsumption.mapfile import OccupancyMap, save_map
from subsumption.metricsfile import write_metrics
from subsumption.network import load
from subsumption.network.spec import Network
from subsumption.planar import compose, from_pose_msg, yaw_of
from subsumption.runtime import NodeHandle

from .launch_local import launch_local
from .launch_ros import ros_session, simulator_command
from .mapping_metrics import map_quality, seen_cells, trajectory_error
from .runner import ROBOTS, ROOT, RunSpec, configured, map_of, param_overrides, world_for_map

matplotlib.use("Agg")  # headless: figures are files, on CI and over ssh alike
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

# The TurtleBot's depth camera turned into a scan (about 58 degrees, 0.45-4 m), on the current simulator. The
# sonars stay on: the wander driver avoids obstacles with them (SLAM never reads them).
DEPTH_SCAN = {"fov_deg": 58, "beams": 160, "min_range": 0.45, "max_range": 4.0}
DRIVERS = ("wander", "frontier")
# move_base for a narrow scan (less than half a turn: a depth camera's 58 degrees, nothing nearer than 0.45 m).
# Beside the robot and within the camera's minimum range, what it drives by is otherwise only on SLAM's map,
# placed by an estimate 2-9 cm off, and frontier exploration touched boxes 1-5 times a run (15 in 6 runs): every
# hit is remembered (s, in the odometry frame) while the scan cannot see its place, the local planner keeps off the
# corners of the map's wall cells (not their centres: 0.005 m from a box's corner), and the robot drives only
# onto ground seen free within NARROW_SEEN_KEEP s, counted within the minimum range + NARROW_SEEN_BEYOND m of it
# (ahead, the camera sees the ground it drives onto before it gets there; counted as far as an arc reaches, the
# depth robot's ATE was worse in 4 of 5 runs, 0.19 m mean against 0.10 m, for a reason not found).
# docs/navigation.md, "Frontier exploration with a narrow scan".
NARROW_HIT_MEMORY = 20.0
NARROW_SEEN_KEEP = 20.0
NARROW_SEEN_BEYOND = 0.3


class MappingError(ValueError):
    """A run cannot be set up (a bad option or file); the message says which."""


def prepare_world(world: Path | WorldDocument, out_dir: Path, sensor: str | None, odom_noise: float | None,
                  odom_turn_noise: float | None = None) -> tuple[Path, list]:
    """The run's world, `out_dir`/world.yaml: `world` (a file, or a WorldDocument a caller has edited already)
    with the robot's sensor and odometry noise set as asked, written once; and the robot's start pose ([] if the
    world lets the simulator choose it). A file is checked first: every problem named by field before anything
    runs."""
    doc = world if isinstance(world, WorldDocument) else WorldDocument(world)
    robot = doc.robot
    if odom_noise is not None:
        robot["odom_noise"] = float(odom_noise)
    if odom_turn_noise is not None:
        robot["odom_turn_noise"] = float(odom_turn_noise)
    sensors = doc.sensors
    if sensor == "depth":
        sensors["laser"] = dict(DEPTH_SCAN)
    elif sensor == "laser":
        sensors["laser"] = {} if not isinstance(sensors.get("laser"), dict) else sensors["laser"]
    return doc.write(out_dir / "world.yaml"), doc.start


@dataclass
class MappingRecorder:
    """Listens to the run: the truth by stamp, the scans, odometry with the map -> odom SLAM publishes (its
    online estimate), collisions, and SLAM's map and trajectory. Works on any NodeHandle."""

    node: NodeHandle
    map_topic: str = "/map"
    trajectory_topic: str = "/slam/trajectory"
    truth: dict[float, np.ndarray] = field(default_factory=dict)
    scans: list[tuple[float, Beams]] = field(default_factory=list)
    online: list[tuple[float, np.ndarray]] = field(default_factory=list)
    collisions: int = 0
    grid: OccupancyGrid | None = None
    path: PathMsg | None = None
    map_to_odom: np.ndarray | None = None
    last_time: float = 0.0
    cpu_time: float | None = None  # s of this process's CPU time (in-process runs: everything)
    explore_finished: bool | None = None  # frontier exploration said done (None: another driver)
    # frontier exploration: where the robot stood stuck at the end, and for how long (None: not stuck)
    explore_stuck: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        self.mounts = MountListener(self.node)
        self.node.subscribe("/ground_truth", Odometry, self._on_truth)
        self.node.subscribe("/odom", Odometry, self._on_odom)
        self.node.subscribe("/scan", LaserScan, self._on_scan)
        self.node.subscribe("/collisions", UInt32, lambda m: setattr(self, "collisions", max(self.collisions, m.data)))
        self.node.subscribe("/tf", TFMessage, self._on_tf)
        self.node.subscribe(self.map_topic, OccupancyGrid, lambda m: setattr(self, "grid", m))
        self.node.subscribe(self.trajectory_topic, PathMsg, lambda m: setattr(self, "path", m))

    def _on_truth(self, msg: Odometry) -> None:
        t = msg.header.stamp.to_sec()
        self.truth[round(t, 3)] = from_pose_msg(msg.pose.pose)
        self.last_time = max(self.last_time, t)

    def _on_odom(self, msg: Odometry) -> None:
        if self.map_to_odom is not None:
            self.online.append((msg.header.stamp.to_sec(), compose(self.map_to_odom, from_pose_msg(msg.pose.pose))))

    def _on_tf(self, msg: TFMessage) -> None:
        for t in msg.transforms:
            if t.header.frame_id == "map" and t.child_frame_id == "odom":
                tr = t.transform
                self.map_to_odom = np.array([tr.translation.x, tr.translation.y, yaw_of(tr.rotation)])

    def _on_scan(self, msg: LaserScan) -> None:
        mount = self.mounts.mount("base_link", msg.header.frame_id)
        if mount is not None:
            self.scans.append((msg.header.stamp.to_sec(), beams_of(msg, mount)))

    def built_map(self) -> OccupancyMap | None:
        if self.grid is None:
            return None
        info = self.grid.info
        occupancy = np.asarray(self.grid.data, dtype=np.int8).reshape(info.height, info.width)
        return OccupancyMap(occupancy, info.resolution, (info.origin.position.x, info.origin.position.y), "slam")

    def keyframes(self) -> tuple[np.ndarray, np.ndarray]:
        if self.path is None:
            return np.zeros(0), np.zeros((0, 3))
        return (np.array([p.header.stamp.to_sec() for p in self.path.poses]),
                np.array([from_pose_msg(p.pose) for p in self.path.poses]).reshape(-1, 3))


@dataclass
class MappingResult:
    metrics: dict
    built: OccupancyMap
    truth_map: OccupancyMap
    slam_xy: np.ndarray
    true_xy: np.ndarray


ROS_MAP_UPDATE = 1.0  # s: the slam node's map_update_interval in ROS runs
FRONTIER_MAP_UPDATE = 2.0  # s: SLAM's map_update_interval when frontier exploration drives (local runs)


def slam_params(start: list, extra: dict | None = None) -> dict:
    params = {"initial_pose": [float(v) for v in start]} if start else {}
    params.update(extra or {})
    return params


def move_base_params(world: Path) -> dict:
    """move_base's parameters for the robot of `world` (a prepared copy): a narrow scan's memory of its hits."""
    robot = yaml.safe_load(Path(world).read_text())["robots"][0]
    laser = (robot.get("sensors") or {}).get("laser")
    narrow = isinstance(laser, dict) and float(laser.get("fov_deg", 360.0)) < 180.0
    if not narrow:
        return {}
    return {"hit_memory": NARROW_HIT_MEMORY, "seen_keep": NARROW_SEEN_KEEP, "map_cell_corners": True,
            "seen_reach": float(laser.get("min_range", 0.0)) + NARROW_SEEN_BEYOND}


MOVE_BASE_LOCAL = {"costmap_publish_frequency": 0.0}  # in-process runs publish no costmaps (nothing shows them)


def wander_driver(seed: int) -> tuple[Network, int]:
    """The wander robot's levels 0-2 (Brooks' explore level) as a driver, its modules seeded with `seed`."""
    return configured(load(ROBOTS["wander"]), RunSpec("wander", 2, Path("."), 0.0, seed)), 2


def mapping_networks(explore: str, seed: int, slam: dict, move_base: dict | None = None,
                     explore_params: dict | None = None) -> list[tuple[Network, int | None]]:
    """What a mapping run builds, in-process or on ROS: SLAM and the driver, from navigation/networks/ (and the
    wander robot's network), with the run's own parameters for each module set over the files'. Frontier
    exploration is navigation/networks/explore.yaml (SLAM, move_base, explore); wander is slam.yaml beside the
    wander robot's levels 0-2."""
    if explore == "frontier":
        return [(navigation_network("explore", {"slam": slam, "move_base": dict(move_base or {}),
                                                "explore": dict(explore_params or {})}), None)]
    return [(navigation_network("slam", {"slam": slam}), None), wander_driver(seed)]


def run_local(world: Path, start: list, duration: float, seed: int, explore: str,
              slam_extra: dict | None = None,
              explore_params: dict | None = None,
              also: Callable[[Any], None] | None = None) -> tuple[MappingRecorder, float, object]:
    """The mapping run in one process (:func:`~experiments.launch_local.launch_local`); frontier exploration ends
    it early when nothing reachable is left unknown. `also(runtime)` sets up another listener beside the recorder
    (experiments.mapping_replay's). Returns the recorder, the wall time and the Slam module."""
    if explore == "frontier":  # the explorer picks goals on the map: a fresher map saves driving to stale ones
        slam_extra = {"map_update_interval": FRONTIER_MAP_UPDATE, **(slam_extra or {})}
    networks = mapping_networks(explore, seed, slam_params(start, slam_extra),
                                {**MOVE_BASE_LOCAL, **move_base_params(world)}, explore_params)

    def setup(runtime) -> MappingRecorder:
        if also is not None:
            also(runtime)
        return MappingRecorder(runtime.node("mapping_recorder"))

    run = launch_local(world, networks, duration, seed, {"map_to_odom": False, "publish_map": False},
                       setup=setup,
                       stop=(lambda run: run.module("explore").finished or run.module("explore").gave_up)
                       if explore == "frontier" else None)
    recorder: MappingRecorder = run.prepared
    recorder.explore_finished = run.module("explore").finished if explore == "frontier" else None
    if explore == "frontier" and run.module("explore").stuck_at is not None:
        explorer = run.module("explore")
        recorder.explore_stuck = (float(explorer.stuck_at[0]), float(explorer.stuck_at[1]),
                                  explorer.now() - explorer.moved_at)
    recorder.cpu_time = run.cpu
    slam = run.module("slam")
    slam.publish_map()  # the last changes, which the periodic update has not published yet
    run.runtime.run_for(0.0)  # deliver them
    return recorder, run.wall, slam


NETWORKS = ROOT / "navigation" / "networks"  # SLAM, frontier exploration and navigation as network files


def navigation_network(name: str, params: dict[str, dict]) -> Network:
    """navigation/networks/NAME.yaml with a run's own parameters set over the file's ({module: {param: value}}):
    the network both runtimes build for `subsumption map` and `subsumption navigate`."""
    network = load(NETWORKS / f"{name}.yaml")
    for module_name, values in params.items():
        network.module(module_name).params.update(values)
    return network


def run_ros(world: Path, start: list, duration: float, seed: int, explore: str, rate: float,
            slam_extra: dict | None = None, progress: bool = True,
            explore_params: dict | None = None) -> tuple[MappingRecorder, float]:
    """The real graph (:func:`~experiments.launch_ros.ros_session`): a private master, the simulator node (no
    map -> odom, no /map), the driver's network and SLAM's (navigation/networks/) through roslaunch, and this
    process as the recorder. Frontier exploration (navigation/networks/explore.yaml) ends the run when explore
    says done (``/explore/done``); the wander driver (the wander robot's levels 0-2 beside
    navigation/networks/slam.yaml) when the duration is simulated. Everything started here is stopped here, by
    pid; the logs stay in $TMPDIR/subsumption_map_PID/."""
    slam = slam_params(start, {"map_update_interval": ROS_MAP_UPDATE, **(slam_extra or {})})
    networks = mapping_networks(explore, seed, slam, move_base_params(world), explore_params)
    # the simulation runs one map update longer, so that the map of the last moment is published
    simulator = simulator_command(world, rate, seed, duration + ROS_MAP_UPDATE + 0.5, map_to_odom=False,
                                  publish_map=False)
    log_dir = Path(os.environ.get("TMPDIR", "/tmp")) / f"subsumption_map_{os.getpid()}"
    with ros_session("mapping_recorder", log_dir, progress=progress) as session:
        recorder = MappingRecorder(session.node)
        done = {"value": False}
        stuck: list[tuple[float, float, float]] = []  # explore gave up: (x, y, s stuck)

        def on_gave_up(msg: PointStamped) -> None:
            stuck.append((msg.point.x, msg.point.y, rospy.get_time() - msg.header.stamp.to_sec()))
        if explore == "frontier":
            session.node.subscribe("/explore/done", Bool, lambda m: done.update(value=bool(m.data)))
            session.node.subscribe("/explore/gave_up", PointStamped, on_gave_up)
        for network, level in networks:
            session.launch(network, level, f"{network.name}.log")
        running = session.start(simulator, "simulator.log", "KILL")
        doing = "exploring" if explore == "frontier" else "mapping"
        wall = session.follow(running, lambda elapsed: f"{doing}: simulated {rospy.get_time():6.1f} / "
                                                       f"{duration:.0f} s, wall {elapsed:5.1f} s",
                              done=lambda: done["value"] or bool(stuck))
        if running.returncode not in (0, None):
            raise RuntimeError(f"simulator exited with status {running.returncode}; see {log_dir}/simulator.log")
        if done["value"]:
            time.sleep(ROS_MAP_UPDATE / max(rate, 0.1) + 0.5)  # the map of the last moment
        else:
            time.sleep(0.5)  # let the last messages arrive
        if explore == "frontier":
            recorder.explore_finished = done["value"]
            recorder.explore_stuck = stuck[0] if stuck else None
        return recorder, wall


def score(recorder: MappingRecorder, world: Path, wall: float, built: OccupancyMap | None = None) -> MappingResult:
    truth_map = load_map(map_of(world))
    built = built or recorder.built_map()
    if built is None:
        raise RuntimeError("SLAM published no map")
    stamps, poses = recorder.keyframes()
    ate, ate_yaw, compared = trajectory_error(stamps, poses, recorder.truth)
    online_stamps = np.array([t for t, _ in recorder.online])
    online_poses = np.array([p for _, p in recorder.online]).reshape(-1, 3)
    ate_online, _, _ = trajectory_error(online_stamps, online_poses, recorder.truth)
    scans = [(recorder.truth[round(t, 3)], b) for t, b in recorder.scans if round(t, 3) in recorder.truth]
    seen_free, seen_walls = seen_cells(truth_map, scans)
    quality = map_quality(built, truth_map, seen_free, seen_walls)
    sim_time = recorder.last_time
    true_xy = np.array([recorder.truth[k][:2] for k in sorted(recorder.truth)]).reshape(-1, 2)
    metrics = {
        "collisions": recorder.collisions,
        "sim_time_s": round(sim_time, 3),
        "wall_time_s": round(wall, 3),
        "real_time_factor": round(sim_time / wall, 2) if wall > 0 else None,
        "cpu_time_s": round(recorder.cpu_time, 3) if recorder.cpu_time is not None else None,
        "ate_m": round(ate, 4),
        "ate_yaw_deg": round(ate_yaw, 3),
        "ate_online_m": round(ate_online, 4),
        "keyframes": compared,
        **quality,
        "distance_m": round(float(np.hypot(*np.diff(true_xy, axis=0).T).sum()) if len(true_xy) > 1 else 0.0, 3),
    }
    if recorder.explore_finished is not None:
        metrics["explore_done"] = recorder.explore_finished
    if recorder.explore_stuck is not None:  # exploration ended with the robot stuck
        x, y, seconds = recorder.explore_stuck
        metrics["explore_stuck_at"] = [round(x, 2), round(y, 2)]
        metrics["explore_stuck_s"] = round(seconds, 1)
    return MappingResult(metrics, built, truth_map, poses[:, :2], true_xy)


def draw(result: MappingResult, out_path: Path, title: str) -> Path:
    fig, axes = plt.subplots(1, 3, figsize=(18, 6.4))
    built, truth = result.built, result.truth_map
    for ax, grid, xy, name, colour in ((axes[0], built, result.slam_xy, "built map, SLAM keyframes", "tab:blue"),
                                       (axes[1], truth, result.true_xy, "true map, true path", "tab:green")):
        grid.draw(ax)
        if len(xy):
            ax.plot(xy[:, 0], xy[:, 1], "-", color=colour, lw=1.0)
        ax.set_title(name)
    ax = axes[2]
    truth.draw(ax, alpha=0.5)
    rows, cols = np.nonzero(built.occupancy == 100)
    ax.plot(built.origin[0] + (cols + 0.5) * built.resolution, built.origin[1] + (rows + 0.5) * built.resolution,
            ",", color="red")
    if len(result.true_xy):
        ax.plot(result.true_xy[:, 0], result.true_xy[:, 1], "-", color="tab:green", lw=0.8, label="true path")
    if len(result.slam_xy):
        ax.plot(result.slam_xy[:, 0], result.slam_xy[:, 1], "--", color="tab:blue", lw=0.8, label="SLAM")
    ax.set_title("built walls (red) over the truth (grey)")
    ax.legend(loc="upper right", fontsize=8)
    x0, x1, y0, y1 = truth.extent()
    for ax in axes:
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out_path, dpi=90)
    plt.close(fig)
    return out_path


def write_outputs(result: MappingResult, out_dir: Path, title: str, extra: dict) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    save_map(result.built, out_dir / "map.yaml")
    draw(result, out_dir / "map_vs_truth.png", title)
    write_metrics(out_dir, {**extra, **result.metrics})


# The command -------------------------------------------------------------------------------------------------
# the options of a simulated run (None on the command line: not given) and their values when not given
SIMULATOR_DEFAULTS = {"duration": 300.0, "seed": 0, "runtime": "local", "rate": 5.0, "explore": "wander",
                      "sensor": None, "odom_noise": 0.02, "odom_turn_noise": None}
BAG_OPTIONS = ("scan", "odom")


def register_map(commands: argparse._SubParsersAction) -> None:
    cmd = commands.add_parser(
        "map", help="build a map with SLAM, in the simulator or offline from a bag; write map.yaml/pgm, a picture, "
                    "metrics.json",
        description="With --world or --map, a robot drives itself through a simulator world while SLAM "
                    "(navigation.slam:Slam) builds the map from its scan and odometry, scored against the truth. "
                    "With --bag, the same SLAM maps a recorded bag offline (as `rosbag play --clock` into `rosrun "
                    "subsumption slam` would), scored against its /ground_truth when it has one.")
    where = cmd.add_mutually_exclusive_group(required=True)
    where.add_argument("--world", type=Path, help="a simulator world file")
    where.add_argument("--map", type=Path, help="a map_server map (YAML); one robot is put on it")
    where.add_argument("--bag", type=Path, help="a recorded bag: map it offline, as fast as the CPU allows "
                                                "(docs/real_data.md)")
    cmd.add_argument("--scan", default=None, help="--bag: the LaserScan topic (default /scan)")
    cmd.add_argument("--odom", default=None, help="--bag: the nav_msgs/Odometry topic (default /odom if the bag "
                                                  "has it, else /tf odom -> base)")
    cmd.add_argument("--duration", type=arguments.number(0.0, False, "simulated seconds > 0"), default=None,
                     help=f"simulated seconds (default {SIMULATOR_DEFAULTS['duration']:g})")
    cmd.add_argument("--seed", type=arguments.seed, default=None,
                     help=f"random seed of the simulator's noise and of the driving robot (default "
                          f"{SIMULATOR_DEFAULTS['seed']})")
    cmd.add_argument("--runtime", choices=("local", "ros"), default=None,
                     help="local: one process, fast; ros: every module a ROS node on a private master "
                          f"(default {SIMULATOR_DEFAULTS['runtime']})")
    cmd.add_argument("--rate", type=arguments.number(0.0, True, "simulated s per wall s, >= 0"), default=None,
                     help=f"ros: simulated s per wall s (default {SIMULATOR_DEFAULTS['rate']:g})")
    cmd.add_argument("--explore", choices=DRIVERS, default=None,
                     help=f"who drives (default {SIMULATOR_DEFAULTS['explore']})")
    cmd.add_argument("--sensor", choices=("laser", "depth"), default=None,
                     help="laser: the 270-degree laser; depth: a 58-degree 0.45-4 m scan like a depth camera's "
                          "(default: what the world file says)")
    cmd.add_argument("--odom-noise", type=arguments.number(0.0, True, "a relative noise >= 0"), default=None,
                     help=f"relative odometry noise (default {SIMULATOR_DEFAULTS['odom_noise']:g}, the condition of "
                          f"the targets)")
    cmd.add_argument("--odom-turn-noise", type=arguments.number(0.0, True, "a relative noise >= 0"), default=None,
                     help="relative noise of odometry's turning alone (default: --odom-noise); e.g. 0.004 for a "
                          "heading five times better through turns, as a gyro would give (docs/mapping.md)")
    cmd.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                     help="a SLAM parameter (e.g. linearUpdate=0.3); repeatable")
    cmd.add_argument("--explore-param", action="append", default=[], metavar="NAME=VALUE",
                     help="a frontier exploration parameter (navigation.explore:Explore, e.g. look_around=true); "
                          "repeatable; with --explore frontier")
    cmd.add_argument("--out", type=Path, required=True,
                     help="folder for map.yaml/pgm, metrics.json and a picture (map_vs_truth.png; with --bag map.png, "
                          "trajectory.txt in TUM format, and reference.yaml/pgm when the bag has /ground_truth); "
                          "made if missing")
    cmd.set_defaults(func=cmd_map)




def _options_for_the_other_mode(args: argparse.Namespace) -> str:
    """The warning for options given that the chosen mode does not read ("" if none): a simulator run's options with
    --bag, a bag's with --world or --map. Said, not passed over in silence: a user who gives --duration to a bag
    expects it used."""
    if args.bag is not None:
        given = [name for name in SIMULATOR_DEFAULTS if getattr(args, name) is not None]
        given += ["explore_param"] if args.explore_param else []
        mode, other = "--bag", "--world or --map"
    else:
        given = [name for name in BAG_OPTIONS if getattr(args, name) is not None]
        mode, other = ("--world" if args.world is not None else "--map"), "--bag"
    if not given:
        return ""
    flags = ", ".join("--" + name.replace("_", "-") for name in given)
    return f"{flags}: for {other} only; ignored with {mode}"


def cmd_map(args: argparse.Namespace) -> int:
    unread = _options_for_the_other_mode(args)
    if unread:  # said, not an error: such command lines ran before, and other scripts may still give them
        print(f"subsumption map: {unread}", file=sys.stderr)
    if args.bag is not None:  # offline, from a recording: navigation.bag_map does it all
        try:
            bag_params = param_overrides(args.param, Slam, MappingError)
        except MappingError as error:
            print(f"subsumption map: {error}", file=sys.stderr)
            return 2
        return cli_map_bag(args.bag, args.out, args.scan or "/scan", args.odom, bag_params)
    for name, default in SIMULATOR_DEFAULTS.items():
        if getattr(args, name) is None:
            setattr(args, name, default)
    try:
        if args.duration <= 0:
            raise MappingError(f"--duration must be > 0, got {args.duration}")
        extra_params = param_overrides(args.param, Slam, MappingError)
        explore_params = param_overrides(args.explore_param, Explore, MappingError, "--explore-param")
        if explore_params and args.explore != "frontier":
            raise MappingError("--explore-param needs --explore frontier")
        base_world = args.world or world_for_map(args.map, args.out)
        world, start = prepare_world(base_world, args.out, args.sensor, args.odom_noise, args.odom_turn_noise)
        if args.runtime == "ros":
            recorder, wall = run_ros(world, start, args.duration, args.seed, args.explore, args.rate, extra_params,
                                     explore_params=explore_params)
        else:
            recorder, wall, _ = run_local(world, start, args.duration, args.seed, args.explore, extra_params,
                                          explore_params)
        result = score(recorder, world, wall)
    except (MapError, WorldError, MappingError, FileNotFoundError) as error:
        print(f"subsumption map: {error}", file=sys.stderr)
        return 2
    name = map_of(world).stem
    m = result.metrics
    noise = f"{args.odom_noise:g}" + ("" if args.odom_turn_noise is None else f", turns {args.odom_turn_noise:g}")
    title = (f"SLAM on {name} ({args.sensor or 'world sensor'}, odometry noise {noise}), {args.explore} "
             f"driving, {m['sim_time_s']:.0f} s, seed {args.seed}, {args.runtime}: ATE {m['ate_m'] * 100:.1f} cm, "
             f"free {m['free_mapped_free']:.1%}, walls {m['walls_within_cell']:.1%}, {m['collisions']} collisions")
    write_outputs(result, args.out, title, {"world": str(args.world or args.map), "seed": args.seed,
                                            "runtime": args.runtime, "explore": args.explore,
                                            "sensor": args.sensor or "world", "odom_noise": args.odom_noise,
                                            **({} if args.odom_turn_noise is None
                                               else {"odom_turn_noise": args.odom_turn_noise})})
    print(f"{args.out}/metrics.json: {m['sim_time_s']:.0f} s simulated in {m['wall_time_s']:.1f} s, ATE "
          f"{m['ate_m']:.3f} m, free {m['free_mapped_free']:.1%}, walls {m['walls_within_cell']:.1%}, "
          f"{m['collisions']} collisions")
    return 0
