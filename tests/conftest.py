"""Shared fixtures. Tests that need ROS get a private master on a free port (`ros_master`) and start their
nodes with `ros_processes`, which stops exactly the processes it started, by process id."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from experiments.profile_scenes import wait_until_ready
from subsumption.ros import process_tree
from subsumption.ros.master import start_master

ROOT = Path(__file__).resolve().parent.parent
VENV_BIN = Path(sys.executable).parent

# The files that take longest (30 s to 3 min each on two cores, measured with --durations), longest first. `make
# test` runs a file at a time per worker (--dist loadfile) in collection order (--no-loadscope-reorder): starting
# the long ones first lets the short ones fill in at the end, so that both workers finish together.
LONG_FILES = ["test_patrol_experiment.py", "test_experiments.py", "test_catkin.py", "test_profile_wander.py",
              "test_patrol_level5.py", "test_fault_interrupt.py", "test_nav_services.py",
              "test_replay_ros.py", "test_profile_doctor.py", "test_profile_goals.py", "test_wander_buildings.py",
              "test_patrol_level4.py", "test_readme_commands.py", "test_profile_patrol.py", "test_liveness_ros.py"]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The long files first (LONG_FILES' order), then the rest as collected; a file's tests stay in their order."""
    rank = {name: i for i, name in enumerate(LONG_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


@pytest.fixture(scope="session", autouse=True)
def private_temporary_folders(tmp_path_factory: pytest.TempPathFactory):
    """Everything the suite's processes write to a temporary folder or to ROS_HOME (the masters' and nodes' logs,
    rospack's cache, rosbag's generated message classes, a replay's launch logs) goes under pytest's own folder for
    this worker, which pytest prunes, instead of /tmp and ~/.ros. Set for this worker and inherited by every child."""
    folder = tmp_path_factory.mktemp("tmp")
    before = {name: os.environ.get(name) for name in ("TMPDIR", "ROS_HOME")}
    os.environ["TMPDIR"] = str(folder)
    os.environ["ROS_HOME"] = str(folder / "ros_home")
    tempfile.tempdir = None  # read TMPDIR again
    yield folder
    for name, value in before.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value
    tempfile.tempdir = None


def ros_env(master_uri: str) -> dict[str, str]:
    """An environment for child processes: this master, the venv first on PATH, this package on ROS_PACKAGE_PATH."""
    env = dict(os.environ)
    env["ROS_MASTER_URI"] = master_uri
    env["PATH"] = f"{VENV_BIN}:{env.get('PATH', '')}"
    env["ROS_PACKAGE_PATH"] = f"{ROOT}:/usr/share"
    env["PYTHONUNBUFFERED"] = "1"
    env.pop("ROS_IP", None)
    env["ROS_HOSTNAME"] = "127.0.0.1"
    return env


@pytest.fixture
def ros_master():
    """Yields the environment (a dict) for processes that should use a fresh private ROS master."""
    master = start_master()
    try:
        yield ros_env(master.uri)
    finally:
        master.stop()


class ProcessGroup:
    """Starts child processes and stops them all, by pid, when the test ends.

    A child's output goes to a log file (`output_of(process)` reads it), not to a pipe: a chatty node must
    never block on a full pipe that the test only reads at the end. Pass stdout=subprocess.PIPE to read a
    short-lived helper with communicate() instead."""

    def __init__(self, env: dict[str, str], log_dir: Path) -> None:
        self.env = env
        self.log_dir = log_dir
        self.processes: list[subprocess.Popen] = []

    def start(self, args: list[str], **kwargs) -> subprocess.Popen:
        log = None
        if "stdout" not in kwargs:
            log = self.log_dir / f"process_{len(self.processes)}.log"
            kwargs["stdout"] = log.open("w")
        kwargs.setdefault("stderr", subprocess.STDOUT)
        kwargs.setdefault("text", True)
        process = subprocess.Popen(args, env=self.env, cwd=ROOT, start_new_session=True, **kwargs)
        if log is not None:
            kwargs["stdout"].close()  # the child keeps its own copy
        process.log = log  # type: ignore[attr-defined]
        self.processes.append(process)
        return process

    def stop_all(self) -> None:
        """Stop every process started here and what they started (roslaunch's nodes, subsumption.ros.process_tree): the
        nodes killed all at once (a test reads nothing of theirs after it: 45 nodes shutting down one after
        another, as roslaunch does, took 5-11 s on a loaded machine), and none left behind when roslaunch has to
        be killed."""
        family = process_tree.descendants([p.pid for p in self.processes if p.poll() is None])
        for process in self.processes:
            if process.poll() is None:
                process.terminate()
        if family:
            time.sleep(0.3)  # roslaunch is shutting down (it respawns nothing now)
            process_tree.signal_all(family, signal.SIGKILL)
        for process in self.processes:
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                family |= process_tree.descendants([process.pid])
                process.kill()
                process.wait()
        process_tree.stop(family)


def output_of(process: subprocess.Popen) -> str:
    """Everything a process started by ProcessGroup (without stdout=PIPE) has printed so far."""
    return process.log.read_text(errors="replace")  # type: ignore[attr-defined]


def wait_for_nodes(env, names: set[str], launch, timeout: float = 120.0) -> None:
    """Until the launch is ready (experiments.profile_scenes.wait_until_ready: every node registered, each level's
    process built), or an AssertionError naming what is not, with roslaunch's output."""
    missing = wait_until_ready(env, names, launch, timeout)
    assert not missing, f"nodes never came up: {missing}\n{output_of(launch)[-3000:]}"


def launch_against_simulator(group: "ProcessGroup", launch_args: list[str], watcher: str, duration: float,
                             world: Path, rate: float, watcher_args: tuple[str, ...] = ()) -> tuple[dict, str]:
    """A profile's launch file run as a user would (`roslaunch subsumption ...`) with a watcher script (given the
    duration and `watcher_args`), then the simulator started once every node is up; returns the watcher's last JSON
    line and the tails of both logs."""
    names = set(subprocess.run(["roslaunch", "--nodes", *launch_args], env=group.env, capture_output=True,
                               text=True, check=True).stdout.split())
    launch = group.start(["roslaunch", *launch_args])
    watching = group.start([sys.executable, "-c", watcher, str(duration), *watcher_args], stdout=subprocess.PIPE)
    wait_for_nodes(group.env, names | {"/watcher"}, launch)
    simulator = group.start([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={world}",
                             f"_rate:={rate}", f"_duration:={duration + 30}", "_connect_wait:=10"])
    out, _ = watching.communicate(timeout=300)
    return json.loads(out.strip().splitlines()[-1]), output_of(launch)[-3000:] + output_of(simulator)[-1000:]


@pytest.fixture
def ros_processes(ros_master, tmp_path_factory):
    group = ProcessGroup(ros_master, tmp_path_factory.mktemp("process_logs"))
    try:
        yield group
    finally:
        group.stop_all()


def remaps_of(node, root) -> dict[str, str]:
    """A generated launch file's node's remaps, each ``$(arg line_NAME)`` read as roslaunch reads it when no
    argument is passed: the ``<arg>``'s default (the external line's own name)."""
    defaults = {arg.get("name"): arg.get("default") for arg in root.iter("arg")}
    resolved = {}
    for remap in node.iter("remap"):
        to = remap.get("to")
        if to.startswith("$(arg ") and to.endswith(")"):
            to = defaults[to[len("$(arg "):-1]]
        resolved[remap.get("from")] = to
    return resolved
