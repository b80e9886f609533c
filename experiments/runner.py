"""One experiment: a robot's network, levels 0..N, in the simulator for a stretch of simulated time.

Two runtimes, one recipe. ``local`` builds the network and the simulator in one
:class:`~subsumption.LocalRuntime` (deterministic, as fast as the computation). ``ros`` runs the real graph:
a master, the simulator node publishing /clock at `rate` x real time, every module and arbiter as its own
node through roslaunch, and this process as a recorder node. Both record with the same
:class:`~experiments.recorder.RunRecorder` and write the same outputs: ``trajectory.png`` and ``metrics.json``.
"""
from __future__ import annotations

import math
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rosgraph
import rospy
import yaml

import subsim.local
from subsim.mapio import load_map
from subsim.plot import plot_run
from subsim.world import WorldError, load_world
from subsumption import LocalRuntime
from subsumption.arguments import parameter_value
from subsumption.loading import load_module_class
from subsumption.module import ParamError
from subsumption.network import load
from subsumption.network.local import build_local
from subsumption.network.spec import Network
from subsumption.network.wiring import Wiring, wire
from subsumption.ros.launch import NetworkNotReady, launch, launch_env, network_nodes, wait_for_nodes
from subsumption.ros.master import host_env, start_master, tied_to_parent
from subsumption.ros.nodes import node_command
from subsumption.ros.runtime import RosNodeHandle
from subsumption.yamlfile import load as load_yaml

from .metrics import coverage_m2, free_area_m2, path_length, write_metrics
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
    network = configured(load(spec.network_path), spec)
    runtime = LocalRuntime()
    subsim.local.attach(runtime, spec.world, seed=spec.seed, record=False, **spec.simulator)
    built = build_local(network, runtime, spec.level)
    recorder = _recorder(runtime.node("experiment_recorder"), built.wiring, spec)
    observed = spec.observe(recorder.node) if spec.observe else None
    started = time.monotonic()
    runtime.run_until(spec.duration)
    result = _result(spec, recorder, time.monotonic() - started)
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


class StopRequest:
    """Takes note of SIGINT/SIGTERM while a ROS run is on, so that the run can end in order: stop recording,
    write what was recorded (marked interrupted), then stop every process it started."""

    def __init__(self) -> None:
        self.signal: int | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> "StopRequest":
        for signum in (signal.SIGINT, signal.SIGTERM):
            self._previous[signum] = signal.signal(signum, self._note)
        return self

    def _note(self, signum: int, _frame: Any) -> None:
        self.signal = signum

    def __exit__(self, *_exc: Any) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    @property
    def reason(self) -> str:
        return f"interrupted ({signal.Signals(self.signal).name})" if self.signal else ""


class RunCutShort(RuntimeError):
    """The run could not start (nothing was recorded); the message says why and where the logs are."""


def run_ros(spec: RunSpec, progress: bool = True, log_dir: Path | None = None,
            ros_ip: str | None = None, join: str | None = None) -> RunResult:
    """The network on a real ROS graph with its own master; everything started here is stopped here, by pid,
    and dies with this process even if it is killed (see :func:`subsumption.ros.master.tied_to_parent`).

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


@dataclass
class _JoinedMaster:
    """A master someone else runs: used, never stopped."""

    uri: str

    def stop(self) -> None:
        pass


def _run_ros(spec: RunSpec, progress: bool, log_dir: Path, ros_ip: str | None, stop: StopRequest,
             join: str | None = None) -> RunResult:
    network = configured(load(spec.network_path), spec)
    wiring = wire(network, spec.level)
    mcap_command = node_command("mcap_record", "-O", str(spec.mcap), "__name:=mcap_recorder") if spec.mcap else None
    simulator_command = node_command(  # found before anything starts: a missing program is one line, status 2
        "simulator", f"_world:={spec.world}", f"_rate:={spec.rate}", f"_seed:={spec.seed}",
        f"_duration:={spec.duration}", *(f"_{key}:={str(value).lower()}" for key, value in spec.simulator.items()))
    ros_logs = log_dir / "ros"
    master = _JoinedMaster(join) if join else start_master(ros_ip=ros_ip, env=dict(os.environ,
                                                                                 ROS_LOG_DIR=str(ros_logs)))
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri, ROS_LOG_DIR=str(ros_logs)), ros_ip)
    os.environ.update(host_env(dict(ROS_MASTER_URI=master.uri, ROS_LOG_DIR=str(ros_logs)), ros_ip))
    children: list[subprocess.Popen] = []
    launched = None
    simulator = None
    started = time.monotonic()
    try:
        _say(progress, f"ROS master {master.uri} (export ROS_MASTER_URI={master.uri} to watch with rostopic/rviz)")

        rosgraph.Master("/experiment_recorder", master_uri=master.uri).setParam("/use_sim_time", True)
        rospy.init_node("experiment_recorder", argv=["experiment_recorder"], disable_signals=True)
        recorder = _recorder(RosNodeHandle(), wiring, spec)
        observed = spec.observe(recorder.node) if spec.observe else None
        with open(log_dir / "roslaunch.log", "w") as roslaunch_log:
            launched = launch(network, spec.level, env=env, ros_ip=ros_ip, xml=log_dir / "network.launch",
                              groups=spec.groups,
                              stdout=roslaunch_log, stderr=subprocess.STDOUT)
        if spec.bag is not None:
            children.append(subprocess.Popen(
                tied_to_parent(["rosbag", "record", "-a", "-O", str(spec.bag), "__name:=bag_recorder"]), env=env,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        if mcap_command is not None:
            with open(log_dir / "mcap_record.log", "w") as mcap_log:
                children.append(subprocess.Popen(tied_to_parent(mcap_command), env=env, stdout=mcap_log,
                                                 stderr=subprocess.STDOUT, start_new_session=True))
        wait_for_run_nodes(wiring, launched, stop, log_dir, groups=spec.groups)
        if not stop.signal:
            with open(log_dir / "simulator.log", "w") as simulator_log:
                simulator = subprocess.Popen(tied_to_parent(simulator_command), env=env, stdout=simulator_log,
                                             stderr=subprocess.STDOUT, start_new_session=True)
            children.append(simulator)
            started = time.monotonic()
            _follow(spec, simulator, stop, progress, started)
        wall = time.monotonic() - started
        time.sleep(0.3)  # let the last messages arrive
        ended = stop.reason or _simulator_end(spec, simulator, recorder, log_dir)
        result = _result(spec, recorder, wall, ended)
        result.observed = observed
        return result
    finally:
        stop_children(children)
        if launched is not None:
            launched.stop()
        master.stop()
        rospy.signal_shutdown("run over")


def stop_children(children: list[subprocess.Popen]) -> None:
    """Stop the processes a run started, newest first: SIGINT (rosbag closes its bag, nodes shut down cleanly),
    then SIGKILL for any that has not gone after 10 s."""
    for child in reversed(children):
        if child.poll() is None:
            child.send_signal(signal.SIGINT)
            try:
                child.wait(10)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()


def _follow(spec: RunSpec, simulator: subprocess.Popen, stop: StopRequest, progress: bool, started: float) -> None:
    """Wait for the simulator to finish (or die, or a stop request), showing progress."""
    live = sys.stderr.isatty()
    last_line = -10.0
    while simulator.poll() is None and not stop.signal:
        elapsed = time.monotonic() - started
        if live or elapsed - last_line >= 10.0:
            last_line = elapsed
            _say(progress, f"{chr(13) if live else ''}  {spec.label or 'run'}: simulated {rospy.get_time():6.1f} / "
                           f"{spec.duration:.0f} s, wall {elapsed:5.1f} s", end="" if live else "\n")
        time.sleep(0.2)
    if live:
        _say(progress, "")


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


def wait_for_run_nodes(wiring: Wiring, launched, stop: StopRequest, log_dir: Path, extra: tuple[str, ...] = (),
                       timeout: float = 60.0, groups: str = "file") -> None:
    """Wait until every node of the network (and the `extra` nodes) has registered and every module is built,
    so the run starts with the whole graph ready (the core's wait, which replay uses too); a failure names the
    log to read."""
    names, built = network_nodes(wiring, groups)
    if len(names) < len(wiring.modules) + len(wiring.arbiters):
        # a group builds its members one after another: its start-up is the sum of theirs (level 3's amcl and
        # move_base warming their kernels: 35-70 s measured on a loaded machine)
        timeout *= 2
    try:
        wait_for_nodes(names + list(extra), launched, timeout, stop=lambda: bool(stop.signal), built=built)
    except NetworkNotReady as error:
        where = f"; see {log_dir / 'roslaunch.log'}" if "roslaunch" in str(error) else f"; see {log_dir}"
        raise RunCutShort(f"{error}{where}") from None


def _say(enabled: bool, text: str, end: str = "\n") -> None:
    if enabled:
        print(text, end=end, file=sys.stderr, flush=True)


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
