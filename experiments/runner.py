"""One experiment: a robot's network, levels 0..N, in the simulator for a stretch of simulated time.

Two runtimes, one recipe. ``local`` builds the network and the simulator in one
:class:`~subsumption.LocalRuntime` (deterministic, as fast as the computation). ``ros`` runs the real graph:
a master, the simulator node publishing /clock at `rate` x real time, every module and arbiter as its own
node through roslaunch, and this process as a recorder node. Both record with the same
:class:`~experiments.recorder.RunRecorder` and write the same outputs: ``trajectory.png`` and ``metrics.json``.
"""
from __future__ import annotations

import math
import resource
import signal
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rospy
import yaml

from subsim.mapio import load_map
from subsim.plot import plot_run
from subsim.world import WorldError, load_world
from subsumption.arguments import parameter_value
from subsumption.loading import load_module_class
from subsumption.metricsfile import write_metrics
from subsumption.module import ParamError
from subsumption.network import load
from subsumption.network.spec import Network
from subsumption.network.wiring import Wiring, wire
from subsumption.ros.nodes import node_command
from subsumption.yamlfile import load as load_yaml

from .launch_local import launch_local
from .launch_ros import RunCutShort, StopRequest, ros_session, simulator_command
from .metrics import coverage_m2, free_area_m2, path_length
from .recorder import CameraView, RunRecorder

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = {"wander": ROOT / "robots" / "wander" / "wander.yaml",
          "patrol": ROOT / "robots" / "patrol" / "patrol.yaml"}


@dataclass
class RunSpec:
    robot: str                      # a name in ROBOTS or the path of a network file
    level: int
    world: Path                     # a world file (written by world_for_map for a bare map)
    duration: float                 # simulated seconds
    seed: int = 0
    runtime: str = "local"          # "local" or "ros"
    rate: float = 3.0               # ros only: simulated seconds per wall second (0: as fast as possible)
    bag: Path | None = None         # ros only: record every topic to this bag
    mcap: Path | None = None        # ros only: record every topic to this MCAP file (subsumption.ros.mcap_record)
    label: str = ""
    params: dict[str, Any] = field(default_factory=dict)  # "module.param" -> value, over the network file's
    simulator: dict[str, Any] = field(default_factory=dict)  # simulator options (map_to_odom, publish_map)
    observe: Any = None  # called with the recorder's NodeHandle before the run; what it returns is `observed`
    groups: str = "file"  # ros only: module groups (file, level or none; see subsumption.network.groups)

    @property
    def network_path(self) -> Path:
        return network_file(self.robot)


@dataclass
class RunResult:
    spec: RunSpec
    metrics: dict
    trajectory: list[tuple[float, float]] = field(repr=False, default_factory=list)
    collision_points: list[tuple[float, float]] = field(repr=False, default_factory=list)
    agents: list[list[tuple[float, float]]] = field(repr=False, default_factory=list)
    observed: Any = field(repr=False, default=None)  # what spec.observe returned, after the run


def param_overrides(items: list[str], module: type, error: type[Exception], option: str = "--param") -> dict:
    """`option NAME=VALUE` options (repeatable) as a module's parameters, each value read as YAML. A name the
    module does not have, or an item without `=`, raises `error` naming the option, the item and the names."""
    params = {}
    known = module.interface.params
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or name not in known:
            raise error(f"{option} {item!r}: expected NAME=VALUE with NAME a parameter of "
                        f"{module.__module__}:{module.__qualname__} ({', '.join(sorted(known))})")
        params[name] = _checked(module, name, value, f"{option} {item!r}", error)
    return params


def _checked(module: type, name: str, text: str, where: str, error: type[Exception]) -> Any:
    """The value `text` of `module`'s parameter `name` as the module itself would check it (type, range, NaN),
    read as YAML by the command line's one reader (subsumption.arguments); `error` names `where` when it fails."""
    try:
        return module.interface.params[name].coerce(parameter_value(text, where), where)
    except (ValueError, ParamError) as problem:
        raise error(str(problem)) from None


def network_file(robot: str) -> Path:
    """The network file of `robot`: a name in ROBOTS or a path."""
    return ROBOTS.get(robot, Path(robot))


def module_overrides(items: list[str], network_path: Path) -> dict:
    """`--param MODULE.NAME=VALUE` options (repeatable) as a run's "module.param" overrides, each value read as
    YAML. A malformed item, a module the network file does not have, or a parameter its class does not have raises
    ValueError naming the option, the item and what there is (before anything starts)."""
    network = load(network_path)
    params = {}
    for item in items:
        key, sep, value = item.partition("=")
        module_name, dot, name = key.partition(".")
        if not sep or not dot or not name:
            raise ValueError(f"--param {item!r}: expected MODULE.NAME=VALUE (e.g. move_base.max_vel_x=0.3)")
        module = network.module(module_name)
        if module is None:
            raise ValueError(f"--param {item!r}: no module {module_name!r} in {network_path}")
        known = load_module_class(module.class_path).interface.params if module.class_path else {}
        if name not in known:
            raise ValueError(f"--param {item!r}: {module_name} ({module.class_path}) has no parameter {name!r}; it "
                             f"has {', '.join(sorted(known)) or 'none'}")
        params[key] = _checked(load_module_class(module.class_path), name, value, f"--param {item!r}", ValueError)
    return params


def world_for_map(map_yaml: Path, out_dir: Path, start: tuple[float, float, float] | None = None) -> Path:
    """A world file with one robot (topics at the root) on any map_server map; without a start pose the
    simulator picks a free one deterministically."""
    out_dir.mkdir(parents=True, exist_ok=True)
    robot: dict = {"name": "robot0", "namespace": ""}
    if start is not None:
        robot["start"] = list(start)
    path = out_dir / "world.yaml"
    path.write_text(yaml.safe_dump({"map": str(Path(map_yaml).resolve()), "robots": [robot]}, sort_keys=False))
    return path


def configured(network: Network, spec: RunSpec) -> Network:
    """The network with this run's seed given to every module that has a `seed` parameter, and the run's
    "module.param" overrides set (an unknown module is an error naming it)."""
    for module in network.modules():
        if module.class_path and "seed" in load_module_class(module.class_path).interface.params:
            module.params["seed"] = spec.seed
    for key, value in spec.params.items():
        module_name, _, param = key.partition(".")
        module = network.module(module_name)
        if module is None or not param:
            raise ValueError(f"parameter override {key!r}: no module {module_name!r} in {spec.network_path}")
        module.params[param] = value
    return network


def _recorder(node, wiring: Wiring, spec: RunSpec) -> RunRecorder:
    """The run's recorder, told the world's agents (names, radii) and the robot's radius to trace contacts."""
    world = load_world(spec.world)
    robot = world.robots[0] if world.robots else None
    cam = robot.camera if robot is not None else None
    camera = CameraView(cam.x, cam.yaw, math.radians(cam.hfov_deg), cam.min_range) if cam is not None else None
    return RunRecorder(node, wiring, agent_names=[a.name for a in world.agents],
                       agent_radii=[a.radius for a in world.agents],
                       robot_radius=robot.radius if robot is not None else 0.18, camera=camera)


def run_local(spec: RunSpec) -> RunResult:
    """The run in one process (:func:`~experiments.launch_local.launch_local`), recorded and scored."""

    def observe(runtime, built) -> tuple[RunRecorder, Any]:
        recorder = _recorder(runtime.node("experiment_recorder"), built[0].wiring, spec)
        return recorder, (spec.observe(recorder.node) if spec.observe else None)

    run = launch_local(spec.world, [(configured(load(spec.network_path), spec), spec.level)], spec.duration,
                       spec.seed, spec.simulator, observe=observe)
    recorder, observed = run.observed
    result = _result(spec, recorder, run.wall)
    result.observed = observed
    return result


@dataclass
class Stage:
    """Wall time and CPU time of one stage of an experiment (this process and the child processes it has
    waited for), for the progress lines: what a stage costs, apart from how loaded the machine was."""

    wall: float
    cpu: float

    @staticmethod
    def _cpu() -> float:
        own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    @classmethod
    def start(cls) -> "Stage":
        return cls(time.monotonic(), cls._cpu())

    def end(self) -> str:
        """'W s wall, C CPU-s' since start()."""
        return f"{time.monotonic() - self.wall:.0f} s wall, {self._cpu() - self.cpu:.0f} CPU-s"


def run_ros(spec: RunSpec, progress: bool = True, log_dir: Path | None = None,
            ros_ip: str | None = None, join: str | None = None) -> RunResult:
    """The network on a real ROS graph with its own master; everything started here is stopped here, by pid,
    and dies with this process even if it is killed (see :mod:`experiments.launch_ros`).

    Logs of every process (roslaunch, nodes, simulator) and the launch file go to `log_dir` (kept), or to a
    temporary folder removed at the end. A run whose simulator dies, or that is interrupted (SIGINT,
    SIGTERM), still returns what was recorded, with ``metrics["complete"]`` false and ``metrics["ended"]``
    saying why. Every process listens on loopback only unless `ros_ip` names this host's address.
    `join` (a master's URI) runs the network and the simulator on that running master instead of one of its own.
    """
    with StopRequest() as stop:
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)
            return _run_ros(spec, progress, log_dir, ros_ip, stop, join)
        with tempfile.TemporaryDirectory(prefix="subsumption_run_") as temporary:
            return _run_ros(spec, progress, Path(temporary), ros_ip, stop, join)


def _run_ros(spec: RunSpec, progress: bool, log_dir: Path, ros_ip: str | None, stop: StopRequest,
             join: str | None = None) -> RunResult:
    network = configured(load(spec.network_path), spec)
    wiring = wire(network, spec.level)
    mcap_command = node_command("mcap_record", "-O", str(spec.mcap), "__name:=mcap_recorder") if spec.mcap else None
    # found before anything starts: a missing program is one line, status 2
    sim_command = simulator_command(spec.world, spec.rate, spec.seed, spec.duration, **spec.simulator)
    with ros_session("experiment_recorder", log_dir, stop, ros_ip, join, progress) as session:
        started = time.monotonic()
        recorder = _recorder(session.node, wiring, spec)
        observed = spec.observe(recorder.node) if spec.observe else None
        launched = session.launch(network, spec.level, "roslaunch.log", xml=log_dir / "network.launch",
                                  groups=spec.groups, wait=False)
        if spec.bag is not None:
            session.start(["rosbag", "record", "-a", "-O", str(spec.bag), "__name:=bag_recorder"], None)
        if mcap_command is not None:
            session.start(mcap_command, "mcap_record.log")
        session.wait_ready(wiring, launched, groups=spec.groups)
        simulator = None
        wall = 0.0
        if not stop.signal:
            simulator = session.start(sim_command, "simulator.log", "KILL")
            label = spec.label or "run"
            wall = session.follow(simulator, lambda elapsed: f"{label}: simulated {rospy.get_time():6.1f} / "
                                                             f"{spec.duration:.0f} s, wall {elapsed:5.1f} s")
        else:
            wall = time.monotonic() - started
        time.sleep(0.3)  # let the last messages arrive
        ended = stop.reason or _simulator_end(spec, simulator, recorder, log_dir)
        result = _result(spec, recorder, wall, ended)
        result.observed = observed
        return result


def _simulator_end(spec: RunSpec, simulator: subprocess.Popen | None, recorder: RunRecorder, log_dir: Path) -> str:
    """'' when the simulator ran the whole duration, else why the run was cut short (with its last log lines)."""
    if simulator is None:
        return "the simulator never started"
    simulated = recorder.path[-1][0] if recorder.path else 0.0
    status = simulator.returncode
    if status == 0:  # the simulator exits 0 only after its whole duration (its last odometry may not have arrived)
        return ""
    how = f"killed by {signal.Signals(-status).name}" if status < 0 else f"exited with status {status}"
    tail = " | ".join((log_dir / "simulator.log").read_text(errors="replace").strip().splitlines()[-3:])
    return f"simulator {how} at simulated {simulated:.1f} s of {spec.duration:g}" + (f": {tail}" if tail else "")


def _result(spec: RunSpec, recorder: RunRecorder, wall: float, ended: str = "") -> RunResult:
    """The run's metrics; `ended` is '' for a run that went its whole duration, else why it was cut short."""
    grid = load_map(map_of(spec.world))
    xy = recorder.trajectory()
    sim_time = recorder.path[-1][0] if recorder.path else 0.0  # the simulation starts at time 0
    metrics = {
        "robot": spec.robot, "level": spec.level, "map": str(map_of(spec.world)), "seed": spec.seed,
        "runtime": spec.runtime, "rate": spec.rate if spec.runtime == "ros" else None,
        "collisions": recorder.collisions,
        "contacts": recorder.contacts,
        "distance_m": round(path_length(xy), 3),
        "coverage_m2": round(coverage_m2(grid, xy), 3),
        "free_area_m2": round(free_area_m2(grid), 3),
        "sim_time_s": round(sim_time, 3),
        "wall_time_s": round(wall, 3),
        "upper_in_control": {name: round(share.fraction, 4) for name, share in recorder.shares.items()},
        "arbiter_silent": {name: round(share.silent_fraction, 4) for name, share in recorder.shares.items()},
        "deaths": list(recorder.deaths), "respawns": list(recorder.respawns),
        "complete": not ended,
        "ended": ended or "finished",
    }
    return RunResult(spec, metrics, [tuple(p) for p in xy.tolist()], list(recorder.collision_points),
                     [list(path) for path in recorder.agents])


def map_of(world: Path) -> Path:
    """The absolute path of the map file a world file names (relative to the world file's folder): what a run's
    pictures draw on and its scores compare with, found without loading the world."""
    data = load_yaml(world, "world file")
    if not isinstance(data, dict) or not isinstance(data.get("map"), str):
        raise WorldError.at(world, "map", "expected the path of a map_server YAML file")
    map_path = Path(data["map"])
    return (map_path if map_path.is_absolute() else Path(world).parent / map_path).resolve()


def write_outputs(result: RunResult, out_dir: Path, title: str | None = None) -> None:
    """DIR/trajectory.png and DIR/metrics.json."""
    out_dir.mkdir(parents=True, exist_ok=True)
    spec = result.spec
    name = Path(result.metrics["map"]).stem
    title = title or (f"{spec.robot} level {spec.level} on {name}, {spec.duration / 60:.0f} min, seed {spec.seed}, "
                      f"{spec.runtime}: {result.metrics['collisions']} collisions, "
                      f"{result.metrics['coverage_m2']:.0f} m² covered")
    paths = {"robot0": np.array(result.trajectory).reshape(-1, 2)}
    paths.update({f"agent{i}": np.array(path).reshape(-1, 2) for i, path in enumerate(result.agents)})
    plot_run(load_map(map_of(spec.world)), paths, {"robot0": result.collision_points}, out_dir / "trajectory.png",
             title=title)
    write_metrics(out_dir, result.metrics)


__all__ = ["RunSpec", "RunResult", "RunCutShort", "Stage", "module_overrides", "network_file", "run_local", "run_ros",
           "world_for_map", "write_outputs", "ROBOTS"]
