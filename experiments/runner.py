"""One experiment: a robot's network, levels 0..N, in the simulator for a stretch of simulated time.

Two runtimes, one recipe. ``local`` builds the network and the simulator in one
:class:`~subsumption.LocalRuntime` (deterministic, as fast as the computation). ``ros`` runs the real graph:
a master, the simulator node publishing /clock at `rate` x real time, every module and arbiter as its own
node through roslaunch, and this process as a recorder node. Both record with the same
:class:`~experiments.recorder.RunRecorder` and write the same outputs: ``trajectory.png`` and ``metrics.json``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from subsim.mapio import load_map
from subsim.plot import plot_run
from subsumption import LocalRuntime
from subsumption.network import load
from subsumption.network.local import build_local
from subsumption.network.spec import Network
from subsumption.network.wiring import wire

from .metrics import coverage_m2, free_area_m2, path_length
from .recorder import RunRecorder

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = {"wander": ROOT / "robots" / "wander" / "wander.yaml"}


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
    label: str = ""
    params: dict[str, Any] = field(default_factory=dict)  # "module.param" -> value, over the network file's

    @property
    def network_path(self) -> Path:
        return ROBOTS.get(self.robot, Path(self.robot))


@dataclass
class RunResult:
    spec: RunSpec
    metrics: dict
    trajectory: list[tuple[float, float]] = field(repr=False, default_factory=list)
    collision_points: list[tuple[float, float]] = field(repr=False, default_factory=list)
    agents: list[list[tuple[float, float]]] = field(repr=False, default_factory=list)


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
    from subsumption.loading import load_module_class

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


def run_local(spec: RunSpec) -> RunResult:
    import subsim.local

    network = configured(load(spec.network_path), spec)
    runtime = LocalRuntime()
    subsim.local.attach(runtime, spec.world, seed=spec.seed, record=False)
    built = build_local(network, runtime, spec.level)
    recorder = RunRecorder(runtime.node("experiment_recorder"), built.wiring)
    started = time.monotonic()
    runtime.run_until(spec.duration)
    return _result(spec, recorder, time.monotonic() - started)


def run_ros(spec: RunSpec, progress: bool = True) -> RunResult:
    """The network on a real ROS graph with its own master; everything started here is stopped here, by pid."""
    import rospy

    from subsumption.ros.launch import launch, launch_env
    from subsumption.ros.master import start_master
    from subsumption.ros.runtime import init_node

    network = configured(load(spec.network_path), spec)
    wiring = wire(network, spec.level)
    master = start_master()
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri))
    os.environ["ROS_MASTER_URI"] = master.uri
    children: list[subprocess.Popen] = []
    launched = None
    log_dir = Path(os.environ.get("TMPDIR", "/tmp")) / f"subsumption_run_{os.getpid()}"
    log_dir.mkdir(parents=True, exist_ok=True)
    try:
        _say(progress, f"ROS master {master.uri} (export ROS_MASTER_URI={master.uri} to watch with rostopic/rviz)")
        subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True)
        launched = launch(network, spec.level, env=env, stdout=open(log_dir / "roslaunch.log", "w"),
                          stderr=subprocess.STDOUT)
        node = init_node("experiment_recorder", argv=["experiment_recorder"])
        recorder = RunRecorder(node, wiring)
        if spec.bag is not None:
            children.append(subprocess.Popen(["rosbag", "record", "-a", "-O", str(spec.bag), "__name:=bag_recorder"],
                                             env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                             start_new_session=True))
        _wait_for_nodes(env, [m.name for m in wiring.modules] + [a.name for a in wiring.arbiters], launched)
        simulator = subprocess.Popen(
            [sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={spec.world}", f"_rate:={spec.rate}",
             f"_seed:={spec.seed}", f"_duration:={spec.duration}"],
            env=env, stdout=open(log_dir / "simulator.log", "w"), stderr=subprocess.STDOUT, start_new_session=True)
        children.append(simulator)
        started = time.monotonic()
        live = sys.stderr.isatty()
        last_line = -10.0
        while simulator.poll() is None and not rospy.is_shutdown():
            elapsed = time.monotonic() - started
            if live or elapsed - last_line >= 10.0:
                last_line = elapsed
                _say(progress, f"{chr(13) if live else ''}  {spec.label or 'run'}: simulated {rospy.get_time():6.1f} / "
                               f"{spec.duration:.0f} s, wall {elapsed:5.1f} s", end="" if live else "\n")
            time.sleep(0.5)
        if live:
            _say(progress, "")
        wall = time.monotonic() - started
        if simulator.returncode not in (0, None):
            raise RuntimeError(f"simulator exited with status {simulator.returncode}; see {log_dir}/simulator.log")
        time.sleep(0.3)  # let the last messages arrive
        return _result(spec, recorder, wall)
    finally:
        for child in reversed(children):
            if child.poll() is None:
                child.send_signal(2)  # SIGINT: rosbag closes its bag, nodes shut down cleanly
                try:
                    child.wait(10)
                except subprocess.TimeoutExpired:
                    child.kill()
                    child.wait()
        if launched is not None:
            launched.stop()
        master.stop()


def _wait_for_nodes(env: dict[str, str], names: list[str], launched, timeout: float = 60.0) -> None:
    """Wait until every node of the network has registered, so the run starts with the whole graph."""
    import rosnode

    deadline = time.monotonic() + timeout
    wanted = {"/" + name for name in names}
    while time.monotonic() < deadline:
        if not launched.running():
            raise RuntimeError(f"roslaunch exited with status {launched.process.returncode}")
        if wanted <= set(rosnode.get_node_names()):
            time.sleep(1.0)  # subscriptions connect just after registration
            return
        time.sleep(0.25)
    missing = wanted - set(rosnode.get_node_names())
    raise RuntimeError(f"nodes did not start within {timeout:.0f} s: {sorted(missing)}")


def _say(enabled: bool, text: str, end: str = "\n") -> None:
    if enabled:
        print(text, end=end, file=sys.stderr, flush=True)


def _result(spec: RunSpec, recorder: RunRecorder, wall: float) -> RunResult:
    grid = load_map(_map_of(spec.world))
    xy = recorder.trajectory()
    sim_time = recorder.path[-1][0] if recorder.path else 0.0  # the simulation starts at time 0
    metrics = {
        "robot": spec.robot, "level": spec.level, "map": str(_map_of(spec.world)), "seed": spec.seed,
        "runtime": spec.runtime, "rate": spec.rate if spec.runtime == "ros" else None,
        "collisions": recorder.collisions,
        "distance_m": round(path_length(xy), 3),
        "coverage_m2": round(coverage_m2(grid, xy), 3),
        "free_area_m2": round(free_area_m2(grid), 3),
        "sim_time_s": round(sim_time, 3),
        "wall_time_s": round(wall, 3),
        "upper_in_control": {name: round(share.fraction, 4) for name, share in recorder.shares.items()},
    }
    return RunResult(spec, metrics, [tuple(p) for p in xy.tolist()], list(recorder.collision_points),
                     [list(path) for path in recorder.agents])


def _map_of(world: Path) -> Path:
    data = yaml.safe_load(Path(world).read_text())
    map_path = Path(data["map"])
    return (map_path if map_path.is_absolute() else Path(world).parent / map_path).resolve()


def write_outputs(result: RunResult, out_dir: Path, title: str | None = None) -> None:
    """DIR/trajectory.png and DIR/metrics.json."""
    import numpy as np

    out_dir.mkdir(parents=True, exist_ok=True)
    spec = result.spec
    name = Path(result.metrics["map"]).stem
    title = title or (f"{spec.robot} level {spec.level} on {name}, {spec.duration / 60:.0f} min, seed {spec.seed}, "
                      f"{spec.runtime}: {result.metrics['collisions']} collisions, "
                      f"{result.metrics['coverage_m2']:.0f} m² covered")
    paths = {"robot0": np.array(result.trajectory).reshape(-1, 2)}
    paths.update({f"agent{i}": np.array(path).reshape(-1, 2) for i, path in enumerate(result.agents)})
    plot_run(load_map(_map_of(spec.world)), paths, {"robot0": result.collision_points}, out_dir / "trajectory.png",
             title=title)
    (out_dir / "metrics.json").write_text(json.dumps(result.metrics, indent=2) + "\n")


__all__ = ["RunSpec", "RunResult", "run_local", "run_ros", "world_for_map", "write_outputs", "ROBOTS"]
