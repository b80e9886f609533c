"""`subsumption run patrol`: the security patrol robot (robots/patrol/patrol.yaml), levels 0-3, in a world.

    subsumption run patrol --level N --world W [--goals G] [--map M] --duration T --seed S
                           --runtime local|ros --out D

What this adds to a plain run (experiments.runner), level by level, as the paper's Fig. 7 shows them:

- every level: the TurtleBot's Kinect renders depth only, a band of rows round its optical centre (the
  camera's ``depth_band`` mode, 10 Hz; no level up to 3 looks at colour), and the network's own ``depth_scan``
  module (vision's DepthToScan, depthimage_to_laserscan's job) turns it into the ``scan`` every level reads. The
  simulator has no laser on this robot.
- level 0: the world's agents are replaced by one person who walks at the robot (from 3 m in front of it, to
  2 m behind where it started, and back): what the level is about.
- level 4: the camera's pixels on (the Kinect's colour and registered depth images), the staff in
  robots/patrol/staff/ enrolled into ``D/staff.npz`` for detect; the encounter scored against the ground truth
  by :mod:`experiments.patrol_vision` (its metrics keys), pictured by :mod:`experiments.patrol_vision_report`
  (``encounter.png``, ``camera_strip.png``).
- level 3: a map built beforehand by the project's own map building (``subsumption map``'s SLAM with the
  wander robot driving), or ``--map``; cached as ``D/map/map.yaml`` and reused by a later run with the same
  --out. The simulator's own ``map -> odom`` and ``/map`` are off: amcl localizes on the built map. The goals
  (``--goals``, a YAML list of [x, y, yaw] in the map frame; default: the four corners of the room) are
  checked against the world's map and the navigation map before the run: a goal in a wall or off the map is
  refused with the file and the index.

Outputs in D: ``trajectory.png`` (the map, the robot's path, the goals numbered, collisions, other agents),
``metrics.json`` (the runner's keys plus ``goals_sent``, ``goals_reached``, ``goals_in_order``, ``laps``,
``goal_log``, ``alarms``, ``alarm_log``, ``alarm_wavs``; levels 4-5 the scene's verdict, ``scene_happened`` and
``scene_missing``, from experiments.patrol_scene) and ``alarms/*.wav``. metrics.json is written once, when every
observer and step has filled the result.
"""
from __future__ import annotations

import argparse
import math
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib
import numpy as np
from actionlib_msgs.msg import GoalStatusArray
from diagnostic_msgs.msg import DiagnosticArray
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult
from scipy.ndimage import label

from robots.patrol.level3 import Goal, GoalsError, load_goals
from subsim import Simulation
from subsim.mapio import GridMap, MapError, load_map
from subsim.world import WorldDocument, WorldError
from subsumption.actions import STATUS_NAMES
from subsumption.metricsfile import write_metrics
from subsumption.runtime import NodeHandle

from . import mapping
from .figures import draw_panel
from .patrol_map import check_goals, clearance, explored_map
from .patrol_operator import DEFAULT_SCRIPT, OPERATOR_LEVEL, OperatorSetupError, operator_extension
from .patrol_scene import scene_verdict
from .patrol_vision import VISION_LEVEL, VisionObserver, staff_model
from .patrol_vision_report import finish as finish_vision
from .runner import RunCutShort, RunSpec, map_of, run_local, run_ros, world_for_map

matplotlib.use("Agg")  # headless: figures are files, on CI and over ssh alike
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

PATROL_LEVEL = 3            # the first level that navigates
MAP_DURATION = 240.0        # simulated s of map building
SERVER_WAIT = 20.0          # simulated s move_base has to answer at the start of a local run
WALKER = {"speed": 0.4, "ahead": 3.0, "behind": 2.0}
CAMERA = {"mode": "depth_band", "rate": 10.0, "compressed": False}  # depth only, a scan's rate
# from level 4 up: full frames at the rate level 4 reads them (track and follow update on each, detect scans each or
# every other within its cpu_share): a Kinect's openni driver with data_skip 2. A world's own camera settings win
VISION_CAMERA = {"rate": 10.0}


# The world ------------------------------------------------------------------------------------------------------
def patrol_world(world: Path, out_dir: Path, level: int) -> tuple[Path, tuple[float, float, float] | None]:
    """The run's copy of `world` (D/world.yaml) and the robot's start pose (None: the simulator picks one).

    The robot's Kinect renders only the band of depth rows the depth scan needs (``depth_band``, at `CAMERA`'s
    rate): levels 0-3 read no colour, which keeps runs cheap. From level 4 up it renders full frames at
    `VISION_CAMERA`'s rate, the rate the vision level reads them at: a frame nobody looks at still costs its
    rendering and every reader's copy and decode. The scan itself is made by the network's depth_scan module
    from those pixels, as on a TurtleBot; the simulator's laser and sonars are off (the patrol robot has
    neither)."""
    doc = WorldDocument(world)  # every problem of the file, named by field, before anything else
    camera = doc.sensors.get("camera")
    camera = camera if isinstance(camera, dict) else {}
    # from level 4 up detect and track look at the colour pixels: the Kinect's full frames, depth_scan takes its band
    doc.sensors.update({"laser": False, "sonar": False,
                        "camera": {**VISION_CAMERA, **camera} if level >= VISION_LEVEL else {**camera, **CAMERA}})
    start = tuple(doc.start) or None
    if level == 0:
        if start is None:
            start = Simulation(world, seed=0, record=False).robots[doc.robot["name"]].pose()
            doc.robot["start"] = [float(v) for v in start]
        doc.data["agents"] = [walker_at(load_map(doc.map_path), start)]
    return doc.write(out_dir / "world.yaml"), start


def walker_at(grid: GridMap, start: tuple[float, float, float]) -> dict:
    """A person walking straight at the robot's start from up to 3 m in front of it, on to 2 m behind, and
    back: as far as the free space allows on that line."""
    x, y, yaw = start
    c, s = math.cos(yaw), math.sin(yaw)

    def free_until(direction: float, most: float) -> float:
        reach = 0.0
        for d in np.arange(0.3, most + 1e-9, 0.05):
            if clearance(grid, x + direction * d * c, y + direction * d * s) < 0.35:
                break
            reach = float(d)
        return reach

    ahead, behind = free_until(1.0, WALKER["ahead"]), free_until(-1.0, WALKER["behind"])
    return {"name": "person", "kind": "person", "motion": "waypoints", "speed": WALKER["speed"], "loop": True,
            "waypoints": [[round(x + ahead * c, 2), round(y + ahead * s, 2)],
                          [round(x - behind * c, 2), round(y - behind * s, 2)]]}


# Goals ----------------------------------------------------------------------------------------------------------
def corner_goals(grid: GridMap, start: tuple[float, float, float] | None, margin: float = 0.8) -> list[Goal]:
    """The default patrol: the four corners of the room the robot starts in. The room is the free space at
    least `margin` from any wall that is connected to the start (doorways narrower than twice the margin close
    it off); each corner is the place of the room nearest a corner of its bounding box; counter-clockwise from
    the lower left, each facing the next."""
    clear = grid.wall_distance >= margin
    labels, count = label(clear, structure=np.ones((3, 3)))
    if count == 0:
        raise GoalsError(f"{grid.source}: no place {margin:g} m clear of the walls for a default patrol goal")
    rows, cols = np.nonzero(clear)
    xs = grid.origin[0] + (cols + 0.5) * grid.resolution
    ys = grid.origin[1] + (rows + 0.5) * grid.resolution
    if start is None:
        room = np.bincount(labels[rows, cols]).argmax()
    else:
        room = labels[rows, cols][int(np.argmin(np.hypot(xs - start[0], ys - start[1])))]
    inside = labels[rows, cols] == room
    xs, ys = xs[inside], ys[inside]
    corners = [(xs.min(), ys.min()), (xs.max(), ys.min()), (xs.max(), ys.max()), (xs.min(), ys.max())]
    points = []
    for cx, cy in corners:
        best = int(np.argmin(np.hypot(xs - cx, ys - cy)))
        points.append((round(float(xs[best]), 2), round(float(ys[best]), 2)))
    return [(x, y, round(math.atan2(points[(i + 1) % 4][1] - y, points[(i + 1) % 4][0] - x), 3))
            for i, (x, y) in enumerate(points)]


# Map building ---------------------------------------------------------------------------------------------------
def map_building_world(world: Path, folder: Path) -> tuple[Path, list]:
    """`folder`/world.yaml, the world :func:`built_map` maps, and the robot's start: the room empty (its agents
    left out, see built_map), the wander robot driving with its sonar ring, the camera off, and SLAM reading the
    depth scan with 2% odometry noise."""
    doc = WorldDocument(world)
    doc.sensors.update({"sonar": {}, "camera": False})
    doc.data["agents"] = []
    return mapping.prepare_world(doc, folder, "depth", 0.02)


def built_map(world: Path, out_dir: Path, seed: int, duration: float = MAP_DURATION, progress: bool = True) -> Path:
    """D/map/map.yaml: the map the project's SLAM builds while the wander robot drives the depth-scan robot
    through the world (reused when it is already there).

    The map is built beforehand with the room empty: the world's moving agents (people, the target robot) are
    left out, as one maps a building when nobody walks through it. A robot crossing the 58-degree view is a
    wall that moves, and the scan matcher locks onto it: with the ping-pong room's target robot in, the map of
    seed 1 was 2.2 m off (ATE; seeds 2, 3: 0.23 m, 0.62 m), without it 0.7-0.9 cm."""
    folder = out_dir / "map"
    if (folder / "map.yaml").exists():
        _say(progress, f"patrol: using the map built before, {folder / 'map.yaml'}")
        return folder / "map.yaml"
    _say(progress, f"patrol: building the map first ({duration:.0f} s simulated, SLAM with the depth scan)")
    mapping_world, start = map_building_world(world, folder)
    recorder, wall, _ = mapping.run_local(mapping_world, start, duration, seed, "wander")
    result = mapping.score(recorder, mapping_world, wall)
    m = result.metrics
    mapping.write_outputs(result, folder, f"map for the patrol: ATE {m['ate_m'] * 100:.1f} cm, free "
                                          f"{m['free_mapped_free']:.1%}, walls {m['walls_within_cell']:.1%}",
                          {"world": str(world), "seed": seed, "sensor": "depth", "odom_noise": 0.02})
    return folder / "map.yaml"


class MoveBaseUnavailable(RuntimeError):
    """The patrol's move_base never answered."""


# Watching the run -----------------------------------------------------------------------------------------------
@dataclass
class PatrolObserver:
    """Listens to the move_base action's wire and to the alarm list, as rostopic would: goals sent, results,
    alarms raised. Works on any NodeHandle, so both runtimes record the same. With `server_wait`, a run in
    which move_base has not said a word (its status) within that many simulated seconds is stopped with
    :class:`MoveBaseUnavailable` (in-process; on ROS every node of the network must have registered before the
    simulation starts, a bounded wait of its own)."""

    node: NodeHandle
    goals: list[Goal]
    server_wait: float | None = None
    server_seen: bool = False
    sent: list[tuple[float, str, int]] = field(default_factory=list)      # time, goal id, goal index
    results: list[tuple[float, str, int, str]] = field(default_factory=list)  # time, goal id, status, text
    alarms: list[dict] = field(default_factory=list)
    _raised: set = field(default_factory=set)

    def __post_init__(self) -> None:
        self.node.subscribe("/move_base/goal", MoveBaseActionGoal, self._on_goal)
        self.node.subscribe("/move_base/result", MoveBaseActionResult, self._on_result)
        self.node.subscribe("/alarms", DiagnosticArray, self._on_alarms)
        self.node.subscribe("/move_base/status", GoalStatusArray, self._on_status)
        if self.server_wait is not None:
            self.node.call_later(self.server_wait, self._check_server)

    def _on_status(self, msg: GoalStatusArray) -> None:
        self.server_seen = True

    def _check_server(self) -> None:
        if not self.server_seen:
            raise MoveBaseUnavailable(f"move_base did not answer on /move_base within {self.server_wait:g} s "
                                      f"(simulated) of the start: no navigation, no patrol")

    def _index(self, msg: MoveBaseActionGoal) -> int:
        p = msg.goal.target_pose.pose.position
        distances = [math.hypot(p.x - x, p.y - y) for x, y, _ in self.goals]
        return int(np.argmin(distances)) if distances else -1

    def _on_goal(self, msg: MoveBaseActionGoal) -> None:
        if not any(goal_id == msg.goal_id.id for _, goal_id, _ in self.sent):  # resends keep their id
            self.sent.append((self.node.now(), msg.goal_id.id, self._index(msg)))

    def _on_result(self, msg: MoveBaseActionResult) -> None:
        self.results.append((self.node.now(), msg.status.goal_id.id, msg.status.status, msg.status.text))

    def _on_alarms(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            key = (status.name, values.get("raised_at"))
            if key not in self._raised:
                self._raised.add(key)
                self.alarms.append({"name": status.name, "message": status.message,
                                    "raised_at_s": float(values.get("raised_at", self.node.now())),
                                    "x": _float(values.get("x")), "y": _float(values.get("y"))})
                if status.name.endswith(" lost") and "goal" in values:  # failed by the patrol: move_base is dead
                    self.alarms[-1]["goal_failed"] = int(values["goal"])

    def metrics(self) -> dict:
        index_of = {goal_id: index for _, goal_id, index in self.sent}
        reached = [(t, index_of.get(goal_id, -1)) for t, goal_id, status, _ in self.results if status == 3]
        order = [index for _, index in reached]
        n = len(self.goals)
        expected = [(order[0] + k) % n for k in range(len(order))] if order else []
        return {
            "goals": [list(g) for g in self.goals],
            "goals_sent": len(self.sent),
            "goals_reached": len(reached),
            "goals_failed": sum(1 for _, _, status, _ in self.results if status in (4, 5, 9))
                            + sum(1 for alarm in self.alarms if "goal_failed" in alarm),
            "goals_in_order": order == expected and bool(order) and order[0] == 0,
            "laps": len(reached) // n if n else 0,
            "goal_log": [{"goal": index_of.get(goal_id, -1), "status": STATUS_NAMES.get(status, str(status)),
                          "at_s": round(t, 2), "text": text} for t, goal_id, status, text in self.results],
            "alarms": len(self.alarms),
            "alarm_log": self.alarms,
        }


def _float(text: str | None) -> float | None:
    try:
        return float(text) if text is not None else None
    except ValueError:
        return None


# Drawing --------------------------------------------------------------------------------------------------------
def write_trajectory(result, goals: list[Goal] | None, out_path: Path, title: str) -> None:
    grid = load_map(map_of(result.spec.world))
    fig, ax = plt.subplots(figsize=(8, 8 * grid.height_m / grid.width_m + 0.8))
    draw_panel(ax, grid, np.array(result.trajectory).reshape(-1, 2),
               [np.array(a).reshape(-1, 2) for a in result.agents], result.collision_points, goals, title)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(out_path, dpi=100)
    plt.close(fig)


# The run --------------------------------------------------------------------------------------------------------
@dataclass
class PatrolRun:
    level: int
    world: Path
    out: Path
    duration: float
    seed: int = 0
    runtime: str = "local"
    goals_file: Path | None = None
    map_yaml: Path | None = None
    rate: float = 3.0
    progress: bool = True
    join: str | None = None
    ros_ip: str | None = None
    params: dict = field(default_factory=dict)  # "module.param" -> value: `run --param`, over the run's own
    groups: str = "file"  # ros: module groups (file, level or none; subsumption.network.groups)
    bag: Path | None = None   # ros: record every topic of the run to this bag
    mcap: Path | None = None  # ros: record every topic of the run to this MCAP file


def following_distance(metrics: dict) -> str:
    """The distance a pursuit kept, for the run's summary line: once closed in on follow's set distance, or, when
    the target left before the robot was there, the mean with the approach (``mean_follow_distance_m`` is then
    null)."""
    if metrics.get("mean_follow_distance_m") is not None:
        return f"{metrics['mean_follow_distance_m']} m"
    return f"{metrics.get('mean_follow_distance_with_approach_m')} m with the approach (never closed in)"


def prepare(run: PatrolRun):
    """Everything checked and built before the simulation starts: the world copy, the goals, the map, and the
    RunSpec. GoalsError / WorldError / MapError name the file and the field."""
    out = run.out.resolve()
    world, start = patrol_world(run.world, out, run.level)
    truth = load_map(map_of(world))
    goals: list[Goal] | None = None
    params: dict = {}
    simulator: dict = {}
    if run.level >= PATROL_LEVEL:
        if run.goals_file is not None:
            goals = load_goals(run.goals_file)
            where = str(run.goals_file)
        else:
            goals = corner_goals(truth, start)
            where = "the default goals (the room's corners)"
        check_goals(goals, truth, where, f"the world's map {truth.source}")
        nav_map = (run.map_yaml.resolve() if run.map_yaml else explored_map(run.world, out, run.seed, goals, where,
                                                                            progress=run.progress))
        check_goals(goals, load_map(nav_map), where, f"the navigation map {nav_map}")
        simulator = {"map_to_odom": False, "publish_map": False}
        params.update({"map_server.map_file": str(nav_map), "patrol.goal_list": [list(g) for g in goals],
                       "sound.output_dir": str(out / "alarms")})
        if start is not None:
            params.update({"amcl.initial_pose_x": start[0], "amcl.initial_pose_y": start[1],  # where it was put
                           "amcl.initial_pose_a": start[2], "amcl.initial_cov_xx": 0.1 ** 2,
                           "amcl.initial_cov_yy": 0.1 ** 2, "amcl.initial_cov_aa": 0.1 ** 2})
    if run.level >= VISION_LEVEL:
        params["detect.model"] = str(staff_model(out))
    wait = SERVER_WAIT if run.level >= PATROL_LEVEL and run.runtime == "local" else None

    def observe(node):
        patrol = PatrolObserver(node, goals or [], wait)
        return (patrol, VisionObserver(node)) if run.level >= VISION_LEVEL else (patrol, None)

    spec = RunSpec("patrol", run.level, world, run.duration, run.seed, run.runtime, run.rate,
                   label=f"patrol level {run.level}", params={**params, **run.params}, simulator=simulator,
                   observe=observe, groups=run.groups, bag=run.bag, mcap=run.mcap)
    return spec, goals


def execute(run: PatrolRun, extend=None):
    """Run it; returns the runner's RunResult with the patrol's metrics merged in, outputs written. `extend`
    (level 5's operator) may change the RunSpec before the run and returns what to call with the result after
    it, before metrics.json is written."""
    spec, goals = prepare(run)
    finish = extend(spec) if extend is not None else None
    if (run.out / "alarms").exists():
        shutil.rmtree(run.out / "alarms")
    if run.runtime == "ros":
        result = run_ros(spec, progress=run.progress, log_dir=run.out.resolve() / "logs", ros_ip=run.ros_ip,
                         join=run.join)
    else:
        result = run_local(spec)
    observer, vision = result.observed
    result.metrics.update(observer.metrics())
    result.metrics["alarm_wavs"] = sorted(str(p) for p in (run.out / "alarms").glob("*.wav"))
    if run.level >= PATROL_LEVEL and not observer.results and not observer.sent:
        result.metrics["complete"] = False
        result.metrics["ended"] = "move_base never answered the patrol's goals"
    m = result.metrics
    name = Path(m["map"]).stem
    title = (f"patrol level {run.level} on {name}, {_duration(run.duration)}, seed {run.seed}, {run.runtime}: "
             f"{m['collisions']} collisions" + (f", {m['goals_reached']}/{m['goals_sent']} goals reached, "
                                                 f"{m['laps']} laps" if run.level >= PATROL_LEVEL else
                                                 f", {m['distance_m']:.0f} m"))
    run.out.mkdir(parents=True, exist_ok=True)
    write_trajectory(result, goals, run.out / "trajectory.png", title)
    if vision is not None:
        m.update(finish_vision(vision, result, goals, observer.sent, run.out, run.duration, title))
    if finish is not None:
        finish(result)  # level 5's keys are the run's
    m.update(scene_verdict(run.level, m))  # last: judged on every other key; levels 4-5 only
    write_metrics(run.out, m)  # once: nothing after this changes the run's metrics.json
    return result


def execute_with_operator(run: PatrolRun, script: Path | None = DEFAULT_SCRIPT, host: str = "127.0.0.1"):
    """A level-5 run (`run` on the ros runtime) with the scripted operator `script` (None: nobody operates; the
    page is served and its URLs printed) and the terminal on `host`; returns the runner's RunResult with level
    5's metrics, outputs written as for the lower levels."""
    return execute(run, operator_extension(run, script, host))


def _say(enabled: bool, text: str) -> None:
    if enabled:
        print(text, file=sys.stderr, flush=True)


def cmd_run_patrol(args: argparse.Namespace, join: str | None) -> int:
    """`subsumption run patrol ...` (called by experiments.cli.cmd_run)."""
    nav_map = args.map if args.world is not None else None
    world = args.world or world_for_map(args.map, args.out.resolve() / "given", args.start)
    run = PatrolRun(args.level, world, args.out, args.duration, args.seed, args.runtime, args.goals, nav_map,
                    args.rate, join=join, ros_ip=args.ros_ip, params=args.params, groups=args.groups,
                    bag=args.bag.resolve() if args.bag else None, mcap=args.mcap.resolve() if args.mcap else None)

    if (args.operator is not None or args.host != "127.0.0.1") and args.level < OPERATOR_LEVEL:
        print(f"subsumption run: --operator and --host are for level {OPERATOR_LEVEL} (the operator terminal)",
              file=sys.stderr)
        return 2
    try:
        if args.level >= OPERATOR_LEVEL:
            result = execute_with_operator(run, args.operator, args.host)
        else:
            result = execute(run)
    except (GoalsError, MapError, WorldError, FileNotFoundError, OperatorSetupError) as error:
        print(f"subsumption run: {error}", file=sys.stderr)
        return 2
    except (RunCutShort, MoveBaseUnavailable) as error:
        print(f"subsumption run: {error}", file=sys.stderr)
        return 1
    m = result.metrics
    print(f"{args.out}/metrics.json: patrol level {m['level']}, {m['sim_time_s']:.0f} s simulated in "
          f"{m['wall_time_s']:.1f} s, {m['collisions']} collisions, {m['goals_reached']}/{m['goals_sent']} goals "
          f"reached, {m['laps']} laps, {m['alarms']} alarms")
    if args.level >= VISION_LEVEL:
        print(f"  level 4: alarm at {m['detected_at_s']} s, stopped at {m['stopped_at_s']} s "
              f"({m['stop_after_face_30px_s']} s after the face was 30 px), followed {m['followed_s']} s at "
              f"{following_distance(m)}, lost at {m['lost_at_s']} s, patrol resumed at "
              f"{m['resumed_patrol_at_s']} s, box IoU >= 0.5 in {m['track_iou_in_view']} of in-view frames, "
              f"{m['false_alarms']} false alarms")
    if args.level >= OPERATOR_LEVEL:
        print(f"  level 5: operator {m['operator_commands']} commands, manual control {m['manual_control_s']} s, "
              f"released at {m['operator']['released_at_s']} s, patrol resumed at {m['resumed_patrol_at_s']} s")
    if not m.get("complete", True):
        print(f"subsumption run: {m['ended']}", file=sys.stderr)
        return 1
    return 0


def _duration(seconds: float) -> str:
    return f"{seconds / 60:.0f} min" if seconds >= 120 else f"{seconds:.0f} s"
