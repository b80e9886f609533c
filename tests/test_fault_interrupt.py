"""Ctrl-C (and SIGKILL) of a `subsumption` command that started a ROS graph leaves no process behind.

The processes are found by the command's process tree (/proc parent links, sampled while the graph runs), never
by name, and each is identified by pid *and* start time, so a reused pid cannot pass for a survivor. Ctrl-C is
sent as a terminal sends it: SIGINT to the command's whole process group. Whatever a failing test finds alive
is killed by pid at the end, so a failure never leaks processes into the next test.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from subsumption.ros.master import free_port

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "subsumption" / "examples" / "avoid_demo.yaml"
SUBSUMPTION = str(Path(sys.executable).parent / "subsumption")
Proc = tuple[int, str]  # pid and start time (field 22 of /proc/PID/stat)
COMMAND_LINES: dict[Proc, bytes] = {}  # what each process seen was when it was seen, for the failure message


def _stat(pid: int) -> list[str] | None:
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return text[text.rindex(")") + 2:].split()  # fields after the command name (which may hold spaces)


def descendants(root: int) -> set[Proc]:
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit() and (fields := _stat(int(entry))) is not None:
            children.setdefault(int(fields[1]), []).append(int(entry))
    found, todo = set(), [root]
    while todo:
        for child in children.get(todo.pop(), []):
            fields = _stat(child)
            if fields is not None:
                found.add((child, fields[19]))
                if command_line := cmdline(child):  # the newest: a child seen before its exec is its parent's copy
                    COMMAND_LINES[(child, fields[19])] = command_line
                todo.append(child)
    return found


def alive(procs: set[Proc]) -> set[Proc]:
    return {(pid, start) for pid, start in procs
            if (fields := _stat(pid)) is not None and fields[19] == start and fields[0] != "Z"}


def run_env(tmp_path: Path) -> dict[str, str]:
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{free_port()}/", ROS_HOME=str(tmp_path / "ros_home"),
               ROS_LOG_DIR=str(tmp_path / "ros_log"), PYTHONUNBUFFERED="1")
    env["PATH"] = f"{Path(sys.executable).parent}:{env.get('PATH', '')}"
    return env


def _watch_and_stop(command: list[str], tmp_path: Path, ready, how: signal.Signals) -> tuple[set[Proc], int]:
    """Start `command`, sample its tree until `ready(tree)`, stop it `how`; return the tree seen and its status."""
    log = (tmp_path / "command.log").open("w")
    process = subprocess.Popen(command, env=run_env(tmp_path), cwd=tmp_path, stdout=log, stderr=subprocess.STDOUT,
                               start_new_session=True)
    seen: set[Proc] = set()
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:
            assert process.poll() is None, (tmp_path / "command.log").read_text()
            seen |= descendants(process.pid)
            if ready(seen):
                break
            time.sleep(0.2)
        else:
            raise AssertionError(f"the graph did not come up: {(tmp_path / 'command.log').read_text()[-2000:]}")
        time.sleep(1.0)
        seen |= descendants(process.pid)
        if how is signal.SIGINT:
            os.killpg(process.pid, signal.SIGINT)  # a terminal's Ctrl-C: the foreground process group
        else:
            process.send_signal(how)
        status = process.wait(timeout=60)
        return seen, status
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        log.close()


def assert_none_left(seen: set[Proc]) -> None:
    # processes told to stop by the kernel (pdeathsig) need a moment, and roslaunch gives a node 15 s after SIGINT
    # before it escalates to SIGTERM (then 2 s to SIGKILL), ten nodes at a time: on a busy machine a second wave of
    # slow nodes takes up to 34 s. A process that is really left behind stays, and the message names it.
    deadline = time.monotonic() + 40
    while alive(seen) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = alive(seen)
    described = [_describe(proc) for proc in left]  # before the kill below changes what they are
    for pid, _ in left:  # never leak into the next test
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    assert not left, described


def _describe(proc: Proc) -> str:
    """A survivor as it was seen running and as it is now: its command line then, its state and where it waits."""
    pid, _ = proc
    fields = _stat(pid) or ["?"]
    try:
        wchan = Path(f"/proc/{pid}/wchan").read_text()
        threads = next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines()
                       if line.startswith("Threads:"))
    except (OSError, StopIteration):
        wchan, threads = "?", "?"
    seen_as = COMMAND_LINES.get(proc, b"").replace(b"\0", b" ")[:200].decode(errors="replace")
    return f"pid {pid} seen as {seen_as!r}: now state {fields[0]}, wchan {wchan}, {threads}"


def cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


@pytest.mark.timeout(150)
def test_ctrl_c_of_subsumption_launch(tmp_path):
    def ready(seen: set[Proc]) -> bool:  # the network's 7 nodes run (roslaunch names each: __name:=)
        return sum(b"__name:=" in cmdline(pid) for pid, _ in alive(seen)) >= 7

    seen, status = _watch_and_stop([SUBSUMPTION, "launch", str(EXAMPLE), "--level", "1"], tmp_path, ready,
                                   signal.SIGINT)
    assert len(seen) >= 9  # roslaunch, its master and rosout, 7 nodes
    assert status in (0, 130, -signal.SIGINT)
    assert_none_left(seen)


@pytest.mark.timeout(200)
@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGKILL])
def test_ctrl_c_or_kill_of_subsumption_run_ros(tmp_path, how):
    command = [SUBSUMPTION, "run", "wander", "--level", "2", "--runtime", "ros", "--map",
               str(ROOT / "subsim" / "maps" / "room.yaml"), "--duration", "600", "--out", str(tmp_path / "out")]

    def ready(seen: set[Proc]) -> bool:  # the simulator runs: the whole graph is up
        return any(b"nodes/simulator" in cmdline(pid) for pid, _ in alive(seen))

    seen, status = _watch_and_stop(command, tmp_path, ready, how)
    # the whole graph was up when it was stopped: the simulator and a process per level
    lines = [COMMAND_LINES.get(proc, b"") for proc in seen]
    assert any(b"nodes/simulator" in line for line in lines), lines
    assert all(any(f"__name:=wander_level{n}".encode() in line for line in lines) for n in range(3)), lines
    if how is signal.SIGINT:
        assert status == 130 and (tmp_path / "out" / "metrics.json").exists()
    assert_none_left(seen)
