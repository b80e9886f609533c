"""The one way a run starts on ROS: a master, simulated time, this process as the run's recorder node, networks
through roslaunch (:mod:`subsumption.ros.launch`), the simulator node, and everything stopped again by pid.

``subsumption run --runtime ros``, ``subsumption map --runtime ros`` and ``subsumption navigate --runtime ros`` do
the same around what is their own (which networks, which observers, when the run is over, what is scored):

    with ros_session("mapping_recorder", log_dir) as session:
        recorder = MappingRecorder(session.node)
        session.launch(network, level, "slam.log")          # waits until every node of it is built
        simulator = session.start(simulator_command(world, rate, seed, duration), "simulator.log", "KILL")
        wall = session.follow(simulator, lambda elapsed: f"mapping: simulated ... wall {elapsed:5.1f} s")

Every process started through the session is tied to this one (it dies with it, even by SIGKILL: see
:func:`subsumption.ros.master.tied_to_parent`) and is stopped when the ``with`` block ends, however it ends: the
processes newest first, then each roslaunch (which stops its nodes), then the master, then this node.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import rosgraph
import rospy

from subsumption.network.spec import Network
from subsumption.network.wiring import Wiring, wire
from subsumption.ros.launch import Launched, NetworkNotReady, launch, launch_env, network_nodes, wait_for_nodes
from subsumption.ros.master import OwnedMaster, host_env, start_master, stop_processes, tied_to_parent
from subsumption.ros.nodes import node_command
from subsumption.ros.runtime import RosNodeHandle


class RunCutShort(RuntimeError):
    """The run could not start (nothing was recorded); the message says why and where the logs are."""


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


@dataclass
class JoinedMaster:
    """A master someone else runs: used, never stopped."""

    uri: str

    def stop(self) -> None:
        pass


def simulator_command(world: Path, rate: float, seed: int, duration: float, **options: Any) -> list[str]:
    """The simulator node's command line (found now: a missing program is one line before anything starts);
    `options` are its boolean private parameters (map_to_odom, publish_map)."""
    return node_command("simulator", f"_world:={world}", f"_rate:={rate}", f"_seed:={seed}",
                        f"_duration:={duration}", *(f"_{key}:={str(value).lower()}" for key, value in options.items()))


def wait_for_run_nodes(wiring: Wiring, launched: Launched, stop: StopRequest, log_dir: Path,
                       extra: tuple[str, ...] = (), timeout: float = 60.0, groups: str = "file",
                       log_name: str = "roslaunch.log") -> None:
    """Wait until every node of the network (and the `extra` nodes) has registered and every module is built,
    so the run starts with the whole graph ready (the core's wait, which replay uses too); a failure
    (RunCutShort) names the log to read, `log_dir`/`log_name` when roslaunch said why."""
    names, built = network_nodes(wiring, groups)
    if len(names) < len(wiring.modules) + len(wiring.arbiters):
        # a group builds its members one after another: its start-up is the sum of theirs (level 3's amcl and
        # move_base warming their kernels: 35-70 s measured on a loaded machine)
        timeout *= 2
    try:
        wait_for_nodes(names + list(extra), launched, timeout, stop=lambda: bool(stop.signal), built=built)
    except NetworkNotReady as error:
        where = f"; see {log_dir / log_name}" if "roslaunch" in str(error) else f"; see {log_dir}"
        raise RunCutShort(f"{error}{where}") from None


@dataclass
class RosSession:
    """A run's ROS graph while it is on: its master, the environment of the processes it starts, its log folder,
    this process's node, and what it started (stopped by :func:`ros_session` at the end)."""

    master: OwnedMaster | JoinedMaster
    env: dict[str, str]
    log_dir: Path
    stop: StopRequest
    progress: bool = True
    ros_ip: str | None = None
    node: RosNodeHandle | None = None
    children: list[subprocess.Popen] = field(default_factory=list)
    launched: list[Launched] = field(default_factory=list)

    def say(self, text: str, end: str = "\n") -> None:
        """A progress line on stderr (unless the run is quiet)."""
        if self.progress:
            print(text, end=end, file=sys.stderr, flush=True)

    def launch(self, network: Network, level: int | None, log_name: str, xml: Path | None = None,
               groups: str = "file", wait: bool = True) -> Launched:
        """roslaunch levels 0..`level` of `network` (:func:`subsumption.ros.launch.launch`), its output in
        `log_dir`/`log_name`, kept to be stopped at the end; with `wait`, waited for until every node of it is
        registered and built (RunCutShort names the network and its log when one is not in time). Networks
        launched one after another, each waited for: roslaunches started together on one master race for its
        run_id."""
        with open(self.log_dir / log_name, "w") as log:
            self.launched.append(launch(network, level, env=self.env, ros_ip=self.ros_ip, xml=xml, groups=groups,
                                        stdout=log, stderr=subprocess.STDOUT))
        if wait:
            try:
                self.wait_ready(wire(network, level), self.launched[-1], groups=groups, log_name=log_name)
            except RunCutShort as error:
                raise RunCutShort(f"network {network.name}: {error}") from None
        return self.launched[-1]

    def wait_ready(self, wiring: Wiring, launched: Launched, groups: str = "file", log_name: str = "roslaunch.log",
                   extra: tuple[str, ...] = ()) -> None:
        """:func:`wait_for_run_nodes` for one launched network, interrupted by the session's stop request."""
        wait_for_run_nodes(wiring, launched, self.stop, self.log_dir, extra, groups=groups, log_name=log_name)

    def start(self, command: list[str], log_name: str | None, on_parent_death: str = "INT") -> subprocess.Popen:
        """Start `command` tied to this process, in a session of its own (only its pid stops it), its output in
        `log_dir`/`log_name` (None: discarded); kept to be stopped at the end. Should this process die without
        stopping it (SIGKILL), it gets SIG`on_parent_death`: INT lets a recorder close its file; KILL suits a
        process with nothing to save whose ROS shutdown could hang (the simulator: once seen waiting on a lock for
        good after SIGINT)."""
        tied = tied_to_parent(command, on_parent_death)
        if log_name is None:
            process = subprocess.Popen(tied, env=self.env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                       start_new_session=True)
        else:
            with open(self.log_dir / log_name, "w") as log:
                process = subprocess.Popen(tied, env=self.env, stdout=log, stderr=subprocess.STDOUT,
                                           start_new_session=True)
        self.children.append(process)
        return process

    def follow(self, simulator: subprocess.Popen, status: Callable[[float], str],
               done: Callable[[], bool] = lambda: False) -> float:
        """Wait until the simulator ends, `done()` says the run is over, a stop request comes or rospy shuts down;
        show `status(wall seconds so far)` every 10 s (live on a terminal). Returns the wall seconds waited."""
        live = sys.stderr.isatty()
        started = time.monotonic()  # wall clock on purpose: how long the run takes, for the progress line
        last_line = -10.0
        while simulator.poll() is None and not self.stop.signal and not rospy.is_shutdown() and not done():
            elapsed = time.monotonic() - started
            if live or elapsed - last_line >= 10.0:
                last_line = elapsed
                self.say(f"{chr(13) if live else ''}  {status(elapsed)}", end="" if live else "\n")
            time.sleep(0.2)
        if live:
            self.say("")
        return time.monotonic() - started


@contextmanager
def ros_session(node_name: str, log_dir: Path, stop: StopRequest | None = None, ros_ip: str | None = None,
                join: str | None = None, progress: bool = True) -> Iterator[RosSession]:
    """A master of its own (or the running one at `join`, used and never stopped), /use_sim_time set, and this
    process as the ROS node `node_name`; everything started through the session is stopped when the block ends.

    Processes listen on loopback only unless `ros_ip` names this host's address; ROS's own logs go to
    `log_dir`/ros. With a `stop` (the caller's :class:`StopRequest`, already entered) SIGINT and SIGTERM are the
    caller's to handle; without one rospy's handlers stay (Ctrl-C ends the run with KeyboardInterrupt)."""
    log_dir.mkdir(parents=True, exist_ok=True)
    ros_logs = str(log_dir / "ros")
    master = JoinedMaster(join) if join else start_master(ros_ip=ros_ip, env=dict(os.environ, ROS_LOG_DIR=ros_logs))
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri, ROS_LOG_DIR=ros_logs), ros_ip)
    os.environ.update(host_env(dict(ROS_MASTER_URI=master.uri, ROS_LOG_DIR=ros_logs), ros_ip))
    session = RosSession(master, env, log_dir, stop or StopRequest(), progress, ros_ip)
    try:
        session.say(f"ROS master {master.uri} (export ROS_MASTER_URI={master.uri} to watch with rostopic/rviz)")
        rosgraph.Master(f"/{node_name}", master_uri=master.uri).setParam("/use_sim_time", True)
        rospy.init_node(node_name, argv=[node_name], disable_signals=stop is not None)
        session.node = RosNodeHandle()
        yield session
    finally:
        stop_processes(session.children)
        for running in reversed(session.launched):
            running.stop()
        master.stop()
        rospy.signal_shutdown("run over")


__all__ = ["JoinedMaster", "RosSession", "RunCutShort", "StopRequest", "ros_session", "simulator_command",
           "wait_for_run_nodes"]
