"""What a ROS-graph run costs, process by process: CPU and resident memory.

Runs a command (e.g. ``subsumption run patrol ... --runtime ros``) and samples every process it starts (the
whole tree of its children) from /proc once a second. Prints, at the end:

- the CPU seconds (user + system) each process spent while the simulator ran (start-up, map building and
  scoring left out), named by its ROS node name (``__name:=``) or its program, largest first, and as a share
  of one core;
- each process's resident memory at its peak: RSS (what ``top`` shows; shared library pages counted in every
  process that maps them) and PSS (shared pages split between the processes sharing them, so that the total is
  what the run really holds in RAM), and both totals at the moment the run held the most;
- the machine's load average (min, mean, max of the 1-minute figure) over that time;
- the same figures for **the robot's own processes** alone: every node of the network, rosmaster and roslaunch,
  leaving out the simulator (on a robot: its drivers, which are not ours) and the command itself (the run's
  scoring and recording): what the robot's computer carries beside its drivers; and of their CPU, what the
  modules' and arbiters' own callbacks took (the ``cpu_s`` of their statuses on ``/diagnostics``): the rest is
  ROS's transport, the timers and the interpreter;
- when the command wrote a ``metrics.json`` in its ``--out`` folder, what the run reports (collisions, when it
  stopped before the face, ...), and the simulator's own last line from ``--out``'s ``logs/simulator.log`` (its
  rate, and how often it fell behind it);
- this machine's speed before and after the run (:mod:`bench.machine_speed`): the same code's figures move with it
  from hour to hour on a shared machine, so runs at different times compare only as far as these agree;
- the wake-ups of all its processes over the whole run (voluntary context switches, from ``getrusage`` of the
  processes once they have exited, so nothing is sampled): each message handed from one thread to another costs
  one, and a wake-up on a processor that had gone idle costs tens of microseconds of CPU on a virtual machine.

A process's CPU is its last sample: what it spends in the second before it exits is not counted (the figures
are a second short at most). Why a bench and not a test: these are timings, and they depend on the load.

On a loaded machine the simulation falls behind its --rate and the CPU per wall second says little; so the
bench also follows the simulation's ``/clock`` (on the master the command prints, ``ROS master URI``) and
reports the CPU per simulated second while the clock ran: the cores the graph needs at 1x, start-up left out,
and the simulated seconds per wall second over the same window (the samples up to the last one at which the
clock had moved on: the run's scoring and shutdown after the simulation are not in it).

``--compare`` runs the command twice, with ``--groups none`` (one process per module and arbiter) and with
``--groups level`` (one process per level: docs/ros.md, "Module groups"), each with its own ``--out``, and prints
the two side by side. ``--versus=ARGS`` does the same for the command as given and with ARGS added (a parameter's
old value, say). With ``--repeat N`` each is run N times, interleaved (A B A B ...: a shared machine's speed drifts
within the hour, so only runs side by side compare), and the means are printed with their ratio.

Usage (from the project root)::

    .venv/bin/python -m bench.ros_load [--every S] [--json FILE] [--compare | --versus=ARGS] [--repeat N] -- \\
        subsumption run patrol --level 4 ... --runtime ros --out D
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shlex
import statistics
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from bench.machine_speed import describe as describe_speed, machine_speed

TICKS = os.sysconf("SC_CLK_TCK")
PAGE_KB = os.sysconf("SC_PAGE_SIZE") / 1024
METRIC_KEYS = ("sim_time_s", "wall_time_s", "goals_sent", "goals_reached", "collisions", "detected_at_s",
               "stopped_at_s", "stop_chain", "false_alarms", "followed_s", "resumed_patrol_at_s", "complete", "ended")


def _stat(pid: int) -> tuple[int, float, float] | None:
    """(parent pid, CPU seconds user + system, RSS in MB) of a live process, None if it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()  # after the command name, which may hold spaces
    return int(fields[1]), (int(fields[11]) + int(fields[12])) / TICKS, int(fields[21]) * PAGE_KB / 1024


def _pss(pid: int) -> float:
    """Proportional set size in MB (shared pages divided among their sharers); 0 if unreadable."""
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            if line.startswith("Pss:"):
                return int(line.split()[1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0.0


def process_name(pid: int) -> str:
    """The ROS node name of a process (``__name:=x``), else its program (the script a Python runs)."""
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace").split("\0")
    except OSError:
        return "?"
    argv = [a for a in argv if a]
    for arg in argv:
        if arg.startswith("__name:="):
            return arg.split(":=", 1)[1]
    programs = [a for a in argv if not a.startswith("-")]
    if len(programs) >= 2 and os.path.basename(programs[0]).startswith("python"):
        return os.path.basename(programs[1])
    return os.path.basename(programs[0]) if programs else "?"


def _tree(root: int) -> dict[int, tuple[float, float]]:
    """(CPU seconds, RSS MB) of `root` and all its descendants now."""
    parents: dict[int, int] = {}
    now: dict[int, tuple[float, float]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            stat = _stat(int(entry))
            if stat is not None:
                parents[int(entry)] = stat[0]
                now[int(entry)] = stat[1:]
    inside = {root}
    changed = True
    while changed:
        changed = False
        for pid, parent in parents.items():
            if parent in inside and pid not in inside:
                inside.add(pid)
                changed = True
    return {pid: now[pid] for pid in inside if pid in now}


@dataclass
class Sampled:
    """What one run cost."""

    wall: float = 0.0
    window: float = 0.0
    cpu: dict[str, list[float]] = field(default_factory=dict)      # name -> CPU s of each process of that name
    rss: dict[str, list[float]] = field(default_factory=dict)      # name -> peak RSS MB of each process
    pss: dict[str, list[float]] = field(default_factory=dict)      # name -> peak PSS MB of each process
    peak_rss: float = 0.0   # MB, all processes at the sample where they held the most
    peak_pss: float = 0.0
    processes: int = 0      # processes alive at the PSS peak
    loads: list[float] = field(default_factory=list)
    metrics: dict = field(default_factory=dict)
    returncode: int = 0
    clocked_cpu: float = 0.0  # CPU s of every process while the simulation's clock ran ...
    clocked_sim: float = 0.0  # ... and the simulated seconds it ran meanwhile
    clocked_wall: float = 0.0
    clocked_robot_cpu: float = 0.0  # ... of which the robot's own processes (ROBOT_SIDE_NOTE)
    clocked_callbacks_cpu: float = 0.0  # ... of which the modules' and arbiters' callbacks (their cpu_s statuses)
    peak_robot_pss: float = 0.0     # MB, the robot's own processes at the sample where they held the most
    simulator_pacing: str | None = None  # the simulator's own last line (its rate, and whether it fell behind)
    machine_speed: dict = field(default_factory=dict)  # {"before": ..., "after": ...}: bench.machine_speed's figures
    wakeups: int = 0  # voluntary context switches of all the run's processes, start to end (getrusage)

    @property
    def cores_at_1x(self) -> float | None:
        """CPU s per simulated s: the cores the graph needs to run at real time."""
        return self.clocked_cpu / self.clocked_sim if self.clocked_sim > 1.0 else None

    @property
    def robot_cores_at_1x(self) -> float | None:
        """CPU s of the robot's own processes per simulated s."""
        return self.clocked_robot_cpu / self.clocked_sim if self.clocked_sim > 1.0 else None

    @property
    def callbacks_cores_at_1x(self) -> float | None:
        """CPU s of the modules' and arbiters' own callbacks per simulated s (the rest of the robot's own is ROS's
        transport, timers and the interpreter)."""
        return self.clocked_callbacks_cpu / self.clocked_sim if self.clocked_sim > 1.0 else None

    @property
    def cpu_total(self) -> float:
        return sum(sum(v) for v in self.cpu.values())

    def figures(self) -> dict:
        return {"wall_s": self.wall, "window_s": self.window, "cpu_s": {k: sum(v) for k, v in self.cpu.items()},
                "cpu_total_s": self.cpu_total, "cores": self.cpu_total / self.window if self.window else None,
                "rss_mb": {k: sum(v) for k, v in self.rss.items()}, "pss_mb": {k: sum(v) for k, v in self.pss.items()},
                "peak_rss_mb": self.peak_rss, "peak_pss_mb": self.peak_pss, "processes": self.processes,
                "load": [min(self.loads), sum(self.loads) / len(self.loads), max(self.loads)] if self.loads else None,
                "clocked": {"cpu_s": self.clocked_cpu, "sim_s": self.clocked_sim, "wall_s": self.clocked_wall,
                            "cores_at_1x": self.cores_at_1x, "robot_cpu_s": self.clocked_robot_cpu,
                            "robot_cores_at_1x": self.robot_cores_at_1x, "callbacks_cpu_s": self.clocked_callbacks_cpu,
                            "callbacks_cores_at_1x": self.callbacks_cores_at_1x},
                "peak_robot_pss_mb": self.peak_robot_pss, "simulator_pacing": self.simulator_pacing,
                "machine_speed": self.machine_speed, "metrics": self.metrics, "wakeups": self.wakeups,
                "wakeups_per_s": self.wakeups / self.wall if self.wall else None}


class GraphListener:
    """What this process hears on the run's graph once the command has printed its master's URI: the simulation's
    /clock, and each module's and arbiter's callbacks' CPU from /diagnostics."""

    def __init__(self) -> None:
        self.now: float | None = None
        self.callbacks_cpu: dict[str, float] = {}  # module or arbiter -> its callbacks' CPU s over the run so far
        self._last: dict[str, tuple[str, float]] = {}  # ... the pid and cpu_s its last status gave
        self._before_respawn: dict[str, float] = {}  # ... what it had given before it was respawned (from zero)
        self._started = False

    def watch_output(self, stream, sink) -> None:
        """Copy the command's stderr to `sink`, and subscribe /clock when its master is named there."""
        for line in iter(stream.readline, ""):
            sink.write(line)
            sink.flush()
            found = re.search(r"ROS master (http://\S+?)/? ", line)
            if found and not self._started:
                self._started = True
                threading.Thread(target=self._subscribe, args=(found.group(1) + "/",), daemon=True).start()

    def _subscribe(self, uri: str) -> None:
        os.environ["ROS_MASTER_URI"] = uri
        import rospy
        from rosgraph_msgs.msg import Clock

        from diagnostic_msgs.msg import DiagnosticArray

        rospy.init_node("ros_load", anonymous=True, disable_signals=True)
        rospy.Subscriber("/clock", Clock, lambda msg: setattr(self, "now", msg.clock.to_sec()), queue_size=1)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=50)

    def on_diagnostics(self, array) -> None:
        """Each module's and arbiter's callbacks' CPU so far: its status's ``cpu_s``, which a respawned process
        counts from zero again. A status from a new ``pid`` is a respawn (without a pid: a count that went down),
        and what the old process had given is kept."""
        for status in array.status:
            values = {pair.key: pair.value for pair in status.values}
            if "cpu_s" not in values:
                continue
            pid, cpu_s = values.get("pid", ""), float(values["cpu_s"])
            last_pid, last_cpu_s = self._last.get(status.name, (pid, 0.0))
            if pid != last_pid or cpu_s < last_cpu_s:
                self._before_respawn[status.name] = self._before_respawn.get(status.name, 0.0) + last_cpu_s
            self._last[status.name] = pid, cpu_s
        # replaced whole, never changed: the sampler reads it
        self.callbacks_cpu = {name: cpu_s + self._before_respawn.get(name, 0.0)
                              for name, (_, cpu_s) in self._last.items()}


ROBOT_SIDE_NOTE = "every node of the network, rosmaster, roslaunch; not the simulator nor the run's own process"


def robot_side(pid: int, name: str, root: int) -> bool:
    """Whether a process of the run is the robot's own (:data:`ROBOT_SIDE_NOTE`): the simulator stands in for
    the robot's drivers and world, and the command itself (``root``) scores and records the run."""
    return pid != root and name != "simulator"


class ClockWindow:
    """The span of a run over which the simulation's clock moved: from the first sample with a clock to the last
    sample at which the clock had moved on since the one before (the run's scoring and shutdown after the
    simulation are not in it). Sets a :class:`Sampled`'s ``clocked_*`` figures."""

    def __init__(self) -> None:
        self.start: tuple[float, float, float, float] | None = None  # (sim, wall, CPU of the tree, of the robot's)
        self.callbacks_start: dict[str, float] = {}

    def update(self, result: Sampled, sim_now: float | None, wall: float, tree_cpu: float, robot_cpu: float,
               callbacks_cpu: dict[str, float] | None = None) -> None:
        """One sample: the simulated time, the wall time, the CPU so far of all processes and of the robot's own,
        and each module's and arbiter's callbacks' CPU so far (:attr:`GraphListener.callbacks_cpu`)."""
        if sim_now is None or sim_now <= 0.0:
            return
        callbacks_cpu = callbacks_cpu or {}
        if self.start is None:
            self.start = (sim_now, wall, tree_cpu, robot_cpu)
            self.callbacks_start = dict(callbacks_cpu)
        elif sim_now > self.start[0] + result.clocked_sim:  # the clock moved on since the last sample
            # the CPU since the clock started (processes that exited meanwhile are not counted)
            result.clocked_sim = sim_now - self.start[0]
            result.clocked_wall = wall - self.start[1]
            result.clocked_cpu = max(result.clocked_cpu, tree_cpu - self.start[2])
            result.clocked_robot_cpu = max(result.clocked_robot_cpu, robot_cpu - self.start[3])
            # a module first heard after the start counts from zero (a respawn is GraphListener's: its counts only grow)
            result.clocked_callbacks_cpu = sum(cpu - self.callbacks_start.get(name, 0.0)
                                               for name, cpu in callbacks_cpu.items())


def sample(command: list[str], every: float) -> Sampled:
    """Run `command`, sampling its process tree every `every` s until it ends."""
    started = time.monotonic()
    switches_before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_nvcsw  # of the processes reaped so far
    child = subprocess.Popen(command, stderr=subprocess.PIPE, text=True, bufsize=1)
    clock = GraphListener()
    threading.Thread(target=clock.watch_output, args=(child.stderr, sys.stderr), daemon=True).start()
    clocked = ClockWindow()
    seen: dict[int, str] = {}
    peak_rss: dict[int, float] = {}
    peak_pss: dict[int, float] = {}
    result = Sampled()
    window_start: dict[int, float] | None = None
    window_end: dict[int, float] = {}
    times = [0.0, 0.0]
    while child.poll() is None:
        tree = _tree(child.pid)
        total_rss = total_pss = robot_pss = 0.0
        for pid, (_cpu, rss) in tree.items():
            seen.setdefault(pid, process_name(pid))
            pss = _pss(pid)
            peak_rss[pid] = max(peak_rss.get(pid, 0.0), rss)
            peak_pss[pid] = max(peak_pss.get(pid, 0.0), pss)
            total_rss += rss
            total_pss += pss
            robot_pss += pss if robot_side(pid, seen[pid], child.pid) else 0.0
        result.peak_robot_pss = max(result.peak_robot_pss, robot_pss)
        sim_now, tree_cpu = clock.now, sum(c for c, _r in tree.values())
        robot_cpu = sum(c for pid, (c, _r) in tree.items() if robot_side(pid, seen[pid], child.pid))
        clocked.update(result, sim_now, time.monotonic(), tree_cpu, robot_cpu, clock.callbacks_cpu)
        if total_pss > result.peak_pss:
            result.peak_pss, result.peak_rss, result.processes = total_pss, total_rss, len(tree)
        if any(seen[pid] == "simulator" for pid in tree):
            now = time.monotonic()
            cpu = {pid: c for pid, (c, _r) in tree.items()}
            if window_start is None:
                window_start, times[0] = dict(cpu), now
            else:
                result.loads.append(os.getloadavg()[0])
            window_end.update(cpu)
            times[1] = now
        time.sleep(every)
    result.returncode = child.returncode
    result.wall = time.monotonic() - started
    # every process of the tree, once reaped by its parent, is added to its parent's children's usage, and so on up
    result.wakeups = resource.getrusage(resource.RUSAGE_CHILDREN).ru_nvcsw - switches_before
    result.window = times[1] - times[0]
    if window_start is not None:
        for pid, cpu in window_end.items():
            result.cpu.setdefault(seen[pid], []).append(cpu - window_start.get(pid, 0.0))
    for pid in peak_rss:
        result.rss.setdefault(seen[pid], []).append(peak_rss[pid])
        result.pss.setdefault(seen[pid], []).append(peak_pss[pid])
    if "--out" in command:
        out = Path(command[command.index("--out") + 1])
        metrics_file = out / "metrics.json"
        if metrics_file.exists():
            metrics = json.loads(metrics_file.read_text())
            result.metrics = {k: metrics.get(k) for k in METRIC_KEYS if k in metrics}
        result.simulator_pacing = simulator_pacing(out / "logs" / "simulator.log")
    return result


def simulator_pacing(log: Path) -> str | None:
    """The simulator node's last line in a run's log (subsim.ros_node: the simulated and wall seconds, and how often
    it fell behind its rate and by how much), or None when the log is missing or has none."""
    if not log.exists():
        return None
    lines = [line.strip() for line in log.read_text(errors="replace").splitlines()
             if line.startswith("simulator: simulated")]
    return lines[-1] if lines else None


def report(result: Sampled, title: str = "") -> None:
    if title:
        print(f"\n## {title}")
    if result.window <= 0:
        print("no simulator process was seen: no CPU window to report")
    else:
        rows = sorted(((sum(v), len(v), k) for k, v in result.cpu.items()), reverse=True)
        print(f"\nCPU s per process while the simulator ran ({result.window:.0f} s wall of {result.wall:.0f}; all "
              f"processes: {result.cpu_total:.1f} CPU s, {result.cpu_total / result.window:.2f} cores on average)")
        print("| process | CPU s | % of a core | peak RSS MB | peak PSS MB |\n|---|---|---|---|---|")
        small = [r for r in rows if r[0] < 1.5]
        for cpu, count, name in rows:
            if cpu >= 1.5:
                print(f"| {name}{f' (x{count})' if count > 1 else ''} | {cpu:.1f} | {100 * cpu / result.window:.0f} | "
                      f"{sum(result.rss.get(name, [0])):.0f} | {sum(result.pss.get(name, [0])):.0f} |")
        if small:
            names = {r[2] for r in small}
            print(f"| {len(small)} others under 1.5 s each | {sum(r[0] for r in small):.1f} | "
                  f"{100 * sum(r[0] for r in small) / result.window:.0f} | "
                  f"{sum(sum(result.rss.get(n, [0])) for n in names):.0f} | "
                  f"{sum(sum(result.pss.get(n, [0])) for n in names):.0f} |")
    if result.cores_at_1x is not None:
        print(f"while the simulation's clock ran: {result.clocked_cpu:.1f} CPU s for {result.clocked_sim:.1f} simulated "
              f"s in {result.clocked_wall:.0f} wall s: {result.cores_at_1x:.2f} cores at 1x (simulated "
              f"{result.clocked_sim / result.clocked_wall:.2f}x)")
        print(f"  of which the robot's own processes ({ROBOT_SIDE_NOTE}): {result.clocked_robot_cpu:.1f} CPU s: "
              f"{result.robot_cores_at_1x:.2f} cores at 1x")
        if result.clocked_callbacks_cpu:
            print(f"  of which the modules' and arbiters' own callbacks (their statuses' cpu_s; the rest is ROS's "
                  f"transport, timers and the interpreter): {result.clocked_callbacks_cpu:.1f} CPU s: "
                  f"{result.callbacks_cores_at_1x:.2f} cores at 1x")
    print(f"resident memory at the peak: {result.peak_pss / 1024:.2f} GB PSS ({result.peak_rss / 1024:.2f} GB RSS "
          f"summed, shared pages counted in each process) in {result.processes} processes; the robot's own processes "
          f"at their peak: {result.peak_robot_pss / 1024:.2f} GB PSS")
    if result.wakeups:
        print(f"wake-ups (voluntary context switches) of all processes over the whole run: {result.wakeups} in "
              f"{result.wall:.0f} s wall, {result.wakeups / result.wall:.0f} a second")
    if result.loads:
        print(f"load average (1 min) during the run: min {min(result.loads):.1f}, mean "
              f"{sum(result.loads) / len(result.loads):.1f}, max {max(result.loads):.1f}")
    if result.simulator_pacing:
        print(f"the simulator's own account: {result.simulator_pacing}")
    if result.machine_speed:
        print(describe_speed(result.machine_speed["before"], result.machine_speed["after"]))
    if result.metrics:
        print("metrics:", json.dumps(result.metrics))


def side_by_side(results: dict[str, dict]) -> None:
    """The figures (:meth:`Sampled.figures`) of several runs in one table."""
    names = list(results)
    print(f"\n## side by side\n| | {' | '.join(names)} |\n|---|{'---|' * len(names)}")
    clocked = lambda r: r.get("clocked") or {}  # noqa: E731
    rows = [("processes (at the memory peak)", lambda r: f"{r['processes']}"),
            ("resident, PSS GB", lambda r: f"{r['peak_pss_mb'] / 1024:.2f}"),
            ("resident, RSS summed GB", lambda r: f"{r['peak_rss_mb'] / 1024:.2f}"),
            ("cores while the simulator ran", lambda r: f"{r['cores']:.2f}" if r.get("cores") else "-"),
            ("CPU s per simulated s (cores at 1x)",
             lambda r: f"{clocked(r)['cores_at_1x']:.2f}" if clocked(r).get("cores_at_1x") else "-"),
            ("the robot's own processes: CPU s per simulated s",
             lambda r: f"{clocked(r)['robot_cores_at_1x']:.2f}" if clocked(r).get("robot_cores_at_1x") else "-"),
            ("of which the modules' and arbiters' callbacks: CPU s per simulated s",
             lambda r: f"{clocked(r)['callbacks_cores_at_1x']:.2f}"
             if clocked(r).get("callbacks_cores_at_1x") else "-"),
            ("the robot's own processes: resident, PSS GB", lambda r: f"{r['peak_robot_pss_mb'] / 1024:.2f}"),
            ("simulated s per wall s",
             lambda r: f"{clocked(r)['sim_s'] / clocked(r)['wall_s']:.2f}" if clocked(r).get("wall_s") else "-"),
            ("wake-ups a second, all processes over the whole run",
             lambda r: f"{r['wakeups_per_s']:.0f}" if r.get("wakeups_per_s") else "-"),
            ("load average (mean)", lambda r: f"{r['load'][1]:.1f}" if r.get("load") else "-"),
            ("this machine's speed before the run: Python ms / face scan ms / wake-up us",
             lambda r: " / ".join(f"{r['machine_speed']['before'][k]:.0f}"
                                  for k in ("python_ms", "opencv_ms", "wakeup_us")))]
    rows += [(key, lambda r, k=key: str((r.get("metrics") or {}).get(k, "-"))) for key in METRIC_KEYS]
    def shown(cell, figures: dict) -> str:
        try:
            return cell(figures)
        except (KeyError, TypeError, ZeroDivisionError):  # a run that wrote no figures (it failed to start)
            return "-"

    for label, cell in rows:
        print(f"| {label} | {' | '.join(shown(cell, results[n]) for n in names)} |")


def _with(command: list[str], option: str, value: str) -> list[str]:
    """`command` with `option value` set (replaced when given)."""
    command = list(command)
    if option in command:
        command[command.index(option) + 1] = value
        return command
    return command + [option, value]


def variants(command: list[str], compare: bool, versus: str | None) -> dict[str, tuple[str, list[str]]]:
    """The runs to set side by side: label -> (folder name below --out, the command). --compare: --groups none and
    --groups level; --versus ARGS: the command as given, and with ARGS added."""
    if compare:
        return {f"--groups {groups}": (f"groups_{groups}", _with(command, "--groups", groups))
                for groups in ("none", "level")}
    return {"as given": ("as_given", list(command)), f"with {versus}": ("versus", command + shlex.split(versus))}


def _mean(values: list[float | None]) -> float | None:
    """The mean of the runs that gave a figure (a run that failed to start gives None)."""
    given = [v for v in values if v is not None]
    return statistics.fmean(given) if given else None


def repeated(results: dict[str, list[dict]]) -> None:
    """Several interleaved runs of each variant: each run's cores at 1x, and the means with their ratio to the
    first variant's."""
    names = list(results)
    clocked = lambda r, key: (r.get("clocked") or {}).get(key)  # noqa: E731
    print(f"\n## runs side by side, interleaved\n| run | {' | '.join(names)} |\n|---|{'---|' * len(names)}")
    for i in range(max(len(runs) for runs in results.values())):
        cells = []
        for name in names:
            run = results[name][i] if i < len(results[name]) else {}
            cores, robot = clocked(run, "cores_at_1x"), clocked(run, "robot_cores_at_1x")
            cells.append(f"{cores:.2f} ({robot:.2f} the robot's own)" if cores and robot else "-")
        print(f"| {i + 1} | {' | '.join(cells)} |")
    first = names[0]
    rows = [("CPU s per simulated s (cores at 1x), mean", lambda r: clocked(r, "cores_at_1x")),
            ("the robot's own processes, mean", lambda r: clocked(r, "robot_cores_at_1x")),
            ("resident, PSS GB, mean", lambda r: r.get("peak_pss_mb", 0) / 1024 or None),
            ("wake-ups a second (all processes, the whole run), mean", lambda r: r.get("wakeups_per_s"))]
    print(f"\n| mean of the runs | {' | '.join(names)} |\n|---|{'---|' * len(names)}")
    for label, value in rows:
        means = {n: _mean([value(r) for r in results[n]]) for n in names}
        cells = [("-" if means[n] is None else f"{means[n]:.2f}"
                  + (f" ({means[n] / means[first]:.2f}x)" if n != first and means[n] and means[first] else ""))
                 for n in names]
        print(f"| {label} | {' | '.join(cells)} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--every", type=float, default=1.0, help="seconds between samples")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--compare", action="store_true",
                        help="run the command with --groups none and with --groups level, and compare")
    parser.add_argument("--versus", metavar="ARGS",
                        help="run the command as given and with ARGS added, and compare (give it with '=': "
                             "--versus='--param detect.rate=10')")
    parser.add_argument("--repeat", type=int, default=1,
                        help="with --compare or --versus: runs of each, interleaved (A B A B ...), then the means")
    parser.add_argument("command", nargs=argparse.REMAINDER, help="-- the command to run")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the command to run after --")
    if args.compare and args.versus:
        parser.error("--compare and --versus are two ways to compare: give one")
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    if not (args.compare or args.versus):
        before = machine_speed()
        result = sample(command, args.every)
        result.machine_speed = {"before": before, "after": machine_speed()}
        report(result)
        if args.json:
            args.json.write_text(json.dumps(result.figures(), indent=1))
        return result.returncode
    if "--out" not in command:
        parser.error("--compare and --versus need the command's --out (each run writes into a folder of its own "
                     "below it)")
    out = Path(command[command.index("--out") + 1])
    runs = variants(command, args.compare, args.versus)
    results: dict[str, list[dict]] = {label: [] for label in runs}
    status = 0
    for i in range(args.repeat):
        for label, (folder, variant) in runs.items():
            # each run sampled by a process of its own: it follows that run's /clock as a ROS node, and rospy
            # lets a process be one node, on one master, once
            name = folder if args.repeat == 1 else f"{folder}_{i + 1}"
            run = _with(variant, "--out", str(out / name))
            figures = out / f"{name}.ros_load.json"
            out.mkdir(parents=True, exist_ok=True)
            print(f"\n## {label}{f' (run {i + 1} of {args.repeat})' if args.repeat > 1 else ''}\n$ {' '.join(run)}",
                  flush=True)
            status = max(status, subprocess.run([sys.executable, "-m", "bench.ros_load", "--every", str(args.every),
                                                 "--json", str(figures), "--", *run]).returncode)
            results[label].append(json.loads(figures.read_text()) if figures.exists() else {})
    side_by_side({label: figures[-1] for label, figures in results.items()})
    if args.repeat > 1:
        repeated(results)
    if args.json:
        args.json.write_text(json.dumps({label: figures[-1] if args.repeat == 1 else figures
                                         for label, figures in results.items()}, indent=1))
    return status


if __name__ == "__main__":
    sys.exit(main())
