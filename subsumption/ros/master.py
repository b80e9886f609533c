"""Finding, or starting, a ROS master.

`subsumption launch` behaves like roslaunch: it uses the master named by ROS_MASTER_URI when one answers,
and otherwise starts one (``rosmaster --core``) that it owns and stops again, by process id, when it ends.
Tests use the same functions on a free port so that they never touch a master they did not start.
"""
from __future__ import annotations

import os
import socket
import subprocess
import time
import xmlrpc.client
from contextlib import closing
from dataclasses import dataclass


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
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def start_master(port: int | None = None, timeout: float = 15.0) -> OwnedMaster:
    """Start `rosmaster --core` on `port` (a free one by default) and wait until it answers."""
    port = port or free_port()
    uri = f"http://127.0.0.1:{port}/"
    env = dict(os.environ, ROS_MASTER_URI=uri)
    process = subprocess.Popen(["rosmaster", "--core", "-p", str(port), "-w", "3"], env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
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
