"""Shared fixtures. Tests that need ROS get a private master on a free port (`ros_master`) and start their
nodes with `ros_processes`, which stops exactly the processes it started, by process id."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from subsumption.ros.master import start_master

ROOT = Path(__file__).resolve().parent.parent
VENV_BIN = Path(sys.executable).parent


def ros_env(master_uri: str) -> dict[str, str]:
    """An environment for child processes: this master, the venv first on PATH, this package on ROS_PACKAGE_PATH."""
    env = dict(os.environ)
    env["ROS_MASTER_URI"] = master_uri
    env["PATH"] = f"{VENV_BIN}:{env.get('PATH', '')}"
    env["ROS_PACKAGE_PATH"] = f"{ROOT}:/usr/share"
    env["PYTHONUNBUFFERED"] = "1"
    env.pop("ROS_IP", None)
    env["ROS_HOSTNAME"] = "127.0.0.1"
    env["ROS_HOME"] = str(Path(os.environ.get("TMPDIR", "/tmp")) / f"ros_home_{os.getpid()}")
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
    """Starts child processes and stops them all, by pid, when the test ends."""

    def __init__(self, env: dict[str, str]) -> None:
        self.env = env
        self.processes: list[subprocess.Popen] = []

    def start(self, args: list[str], **kwargs) -> subprocess.Popen:
        kwargs.setdefault("stdout", subprocess.PIPE)
        kwargs.setdefault("stderr", subprocess.STDOUT)
        kwargs.setdefault("text", True)
        process = subprocess.Popen(args, env=self.env, cwd=ROOT, start_new_session=True, **kwargs)
        self.processes.append(process)
        return process

    def stop_all(self) -> None:
        for process in self.processes:
            if process.poll() is None:
                process.terminate()
        for process in self.processes:
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@pytest.fixture
def ros_processes(ros_master):
    group = ProcessGroup(ros_master)
    try:
        yield group
    finally:
        group.stop_all()
