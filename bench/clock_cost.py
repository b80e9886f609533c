"""What handling ``/clock`` costs an idle node, at the rates a simulator may publish it.

A private rosmaster (a free port, stopped by pid), ``/use_sim_time`` set, one rospy process publishing
``/clock`` at real time at R Hz, and N real arbiter nodes (``nodes/suppressor``: a 10 Hz expiry timer and a 1 Hz
status timer, ROS diagnostics, like the ~25 arbiters of the patrol network) whose inputs stay silent: all they do
is keep ROS time. Each rate runs for the same wall time; the table gives the CPU (user + system, from /proc) of
an idle node and of the clock's publisher, as a share of one core. Rate 0: no simulated time at all (wall clock,
no /clock): the floor an idle node costs anyway.

Usage: .venv/bin/python -m bench.clock_cost [--nodes N] [--seconds S] [--rates 50,20,10,0]
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from subsumption.ros.master import host_env, start_master, stop_processes, tied_to_parent

TICKS = os.sysconf("SC_CLK_TCK")

CLOCK = """
import sys, time, rospy
from rosgraph_msgs.msg import Clock
rospy.init_node("clock_source")
rate = float(sys.argv[1])
pub = rospy.Publisher("/clock", Clock, queue_size=100)
start = time.monotonic()
n = 0
while not rospy.is_shutdown():
    n += 1
    pub.publish(Clock(clock=rospy.Time.from_sec(n / rate)))
    delay = start + n / rate - time.monotonic()
    if delay > 0:
        time.sleep(delay)
"""


def _cpu(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def measure(rate: float, nodes: int, seconds: float) -> tuple[float, float]:
    """(mean CPU share of an idle arbiter node, CPU share of the /clock publisher) over `seconds` of wall time,
    after the nodes have started."""
    master = start_master()
    env = host_env(dict(os.environ, ROS_MASTER_URI=master.uri), None)
    processes: list[subprocess.Popen] = []
    try:
        subprocess.run(["rosparam", "set", "/use_sim_time", "true" if rate > 0 else "false"], env=env, check=True)
        if rate > 0:
            processes.append(subprocess.Popen(tied_to_parent([sys.executable, "-c", CLOCK, str(rate)]), env=env))
        for i in range(nodes):
            processes.append(subprocess.Popen(tied_to_parent(
                [sys.executable, str(ROOT / "nodes" / "suppressor"), f"upper:=/idle{i}/upper",
                 f"lower:=/idle{i}/lower", f"output:=/idle{i}/output", f"__name:=idle{i}", "_time_constant:=0.5"]),
                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        time.sleep(8.0)  # start-up (imports, registration) is not what is measured
        before = [_cpu(p.pid) for p in processes]
        time.sleep(seconds)
        after = [_cpu(p.pid) for p in processes]
        used = [(a - b) / seconds for a, b in zip(after, before)]
        source = used[0] if rate > 0 else 0.0
        idle = used[1:] if rate > 0 else used
        return sum(idle) / len(idle), source
    finally:
        stop_processes(processes, signal.SIGTERM, timeout=10)
        master.stop()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nodes", type=int, default=10)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--rates", default="50,20,10,0")
    args = parser.parse_args()
    print(f"{args.nodes} idle arbiter nodes, {args.seconds:.0f} s wall each; load average now "
          f"{os.getloadavg()[0]:.1f}")
    print("| /clock Hz | idle node, % of a core | x 36 nodes, cores | /clock publisher, % of a core |")
    print("|---|---|---|---|")
    for rate in (float(r) for r in args.rates.split(",")):
        node, source = measure(rate, args.nodes, args.seconds)
        label = f"{rate:g}" if rate > 0 else "none (wall clock)"
        print(f"| {label} | {100 * node:.2f} | {36 * node:.2f} | {100 * source:.1f} |", flush=True)
    print(f"load average at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
