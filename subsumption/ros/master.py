"""Finding, or starting, a ROS master; and the two rules every process we start follows.

`subsumption launch` behaves like roslaunch: it uses the master named by ROS_MASTER_URI when one answers,
and otherwise starts one (``rosmaster --core``) that it owns and stops again, by process id, when it ends.
Tests use the same functions on a free port so that they never touch a master they did not start.

- **Loopback by default.** ROS 1 has no authentication, and rospy's XML-RPC and TCPROS servers listen on
  every interface unless ROS_IP/ROS_HOSTNAME name a loopback address: then they listen on 127.0.0.1 only.
  :func:`host_env` sets both to 127.0.0.1, or to the address a user gives to spread a robot over hosts
  (``--ros-ip``, docs/faults.md).
- **Children die with their parent.** :func:`tied_to_parent` starts a command under
  ``setpriv --pdeathsig``, so that the kernel signals it when the process that started it ends, even by
  SIGKILL (roslaunch, told SIGINT, then stops its own nodes): nothing of a run outlives it.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import time
import xmlrpc.client
from contextlib import closing
from dataclasses import dataclass

LOOPBACK = "127.0.0.1"


def host_env(env: dict[str, str], ros_ip: str | None = None) -> dict[str, str]:
    """`env` with ROS_IP and ROS_HOSTNAME set to `ros_ip` (default: loopback, so nothing listens beyond this
    machine). rospy binds to 127.0.0.1 exactly when one of them names a loopback address."""
    address = ros_ip or LOOPBACK
    return dict(env, ROS_IP=address, ROS_HOSTNAME=address)


def tied_to_parent(command: list[str], signal_name: str = "INT") -> list[str]:
    """`command` prefixed so that it receives SIG`signal_name` when the process starting it dies (Linux's
    PR_SET_PDEATHSIG, set by util-linux's setpriv before it execs: the pid stays the command's own)."""
    return ["setpriv", "--pdeathsig", signal_name, "--", *command]


def free_port() -> int:
    """A TCP port that nothing listens on right now (the kernel picks it)."""
    with closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def master_reachable(uri: str, timeout: float = 0.5) -> bool:
    """Whether a ROS master answers at `uri` (getPid over XML-RPC)."""
    previous = socket.getdefaulttimeout()
    socket.setdefaulttimeout(timeout)
    try:
        code, _, _ = xmlrpc.client.ServerProxy(uri).getPid("/subsumption_probe")
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False
    finally:
        socket.setdefaulttimeout(previous)


@dataclass
class OwnedMaster:
    """A rosmaster process this program started; stop() ends exactly that process."""

    uri: str
    process: subprocess.Popen

    def stop(self) -> None:
        """Stop the master this process started (SIGTERM, then SIGKILL after 5 s)."""
        stop_process(self.process, signal.SIGTERM, 5.0)


def stop_process(process: subprocess.Popen, first: int = signal.SIGINT, timeout: float = 10.0) -> int:
    """Stop one process this program started, by its pid: signal `first` (SIGINT by default, as Ctrl-C: rosbag
    closes its bag, roslaunch and nodes shut down cleanly), wait up to `timeout` s, then SIGKILL. Returns its
    exit status; a process that has already ended is only reaped."""
    if process.poll() is None:
        process.send_signal(first)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            process.kill()
    return process.wait()


def stop_processes(processes: list[subprocess.Popen], first: int = signal.SIGINT, timeout: float = 10.0) -> None:
    """:func:`stop_process` for each of `processes`, newest first (what was started last may depend on the
    earlier ones)."""
    for process in reversed(processes):
        stop_process(process, first, timeout)


def start_master(port: int | None = None, timeout: float = 15.0, ros_ip: str | None = None,
                 env: dict[str, str] | None = None) -> OwnedMaster:
    """Start `rosmaster --core` on `port` (a free one by default), listening on `ros_ip` (default loopback
    only), tied to this process's life, and wait until it answers."""
    port = port or free_port()
    uri = f"http://{ros_ip or LOOPBACK}:{port}/"
    env = host_env(dict(os.environ if env is None else env, ROS_MASTER_URI=uri), ros_ip)
    process = subprocess.Popen(tied_to_parent(["rosmaster", "--core", "-p", str(port), "-w", "3"], "TERM"),
                               env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    # Waiting for a process to come up is a matter of wall-clock time, not of ROS time (there is no ROS yet).
    wall_deadline = time.monotonic() + timeout
    while time.monotonic() < wall_deadline:  # wall clock on purpose
        if master_reachable(uri):
            return OwnedMaster(uri, process)
        if process.poll() is not None:
            raise RuntimeError(f"rosmaster on port {port} exited with status {process.returncode}")
        time.sleep(0.05)
    OwnedMaster(uri, process).stop()
    raise RuntimeError(f"rosmaster on port {port} did not answer within {timeout} s")
