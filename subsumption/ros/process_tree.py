"""The processes a program's children started (roslaunch's nodes), found in /proc, to stop them too (the tests'
process groups, the benches that start roslaunch).

Why: roslaunch stops its nodes one after another (SIGINT, then a wait for each); with the patrol robot's 30 nodes
on a loaded machine that took longer than a test waited, the test then killed roslaunch, and the nodes it had not
reached yet lived on without it (found: 23 of one run's nodes still running minutes later). Each process is known
by its pid and its start time (a pid the kernel has given to another process since is not touched)."""
from __future__ import annotations

import os
import signal
import time
from pathlib import Path

Process = tuple[int, int]  # pid, start time (clock ticks after boot: /proc/PID/stat field 22)


def _stat(pid: int) -> tuple[int, int] | None:
    """(parent pid, start time) of `pid`, None if it is gone (or a zombie: nothing left to stop)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return None if fields[0] == "Z" else (int(fields[1]), int(fields[19]))


def descendants(pids: list[int]) -> set[Process]:
    """Every living process below `pids` (children, their children, ...), with its start time."""
    children: dict[int, list[Process]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (stat := _stat(int(entry.name))) is not None:
            children.setdefault(stat[0], []).append((int(entry.name), stat[1]))
    found: set[Process] = set()
    todo = list(pids)
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child[0])
    return found


def alive(process: Process) -> bool:
    """Whether `process` still runs as the same process (its pid not reused since: the start time matches)."""
    stat = _stat(process[0])
    return stat is not None and stat[1] == process[1]


def signal_all(processes: set[Process], sig: int) -> None:
    """Send `sig` to each of `processes` that is still that process."""
    for process in processes:
        if alive(process):
            try:
                os.kill(process[0], sig)
            except ProcessLookupError:
                pass


def stop(processes: set[Process], timeout: float = 3.0) -> None:
    """SIGTERM each of `processes`, SIGKILL those still there after `timeout` s (wall clock: processes ending)."""
    signal_all(processes, signal.SIGTERM)
    deadline = time.monotonic() + timeout  # wall clock on purpose: processes ending, not ROS time
    while time.monotonic() < deadline and any(alive(p) for p in processes):  # wall clock on purpose
        time.sleep(0.05)
    signal_all(processes, signal.SIGKILL)
