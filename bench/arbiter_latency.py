"""Latency and throughput of our suppressor node against a direct connection and topic_tools' C++ relay.

Run with the project's interpreter (it needs rospy): ``.venv/bin/python -m bench.arbiter_latency`` (``make bench``).
It starts its own rosmaster on a free port and stops it, and every process it started, by process id.

For each path (direct publisher -> subscriber; our suppressor, messages on its lower line; the same on its
upper line; topic_tools relay) a sender and a receiver process (bench.latency_probe) exchange
geometry_msgs/TwistStamped: 500 msg/s for a few seconds for latency (receive time - header.stamp, both on
this machine's wall clock, tcp_nodelay everywhere), then one second at each of several rates, and a
second of sending as fast as the sender can. "Sustained" is the highest achieved send rate at which >= 99 %
arrived; "blast" is what arrived per second of receiving while the sender went flat out (the sender, a
Python process, is usually the limit there). The figures go to stdout as a table; nothing is asserted.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from subsumption.ros.master import start_master, stop_process

PROBE = ["-m", "bench.latency_probe"]  # run from ROOT (the processes' cwd)
RELAY = "/usr/lib/topic_tools/relay"
RATES = (2000, 5000, 8000, 12000, 16000)


class Processes:
    """Everything this bench starts, stopped by pid (never by name)."""

    def __init__(self, env: dict[str, str]) -> None:
        self.env = env
        self.started: list[subprocess.Popen] = []

    def start(self, args: list[str], **kwargs) -> subprocess.Popen:
        kwargs.setdefault("stdout", subprocess.DEVNULL)
        kwargs.setdefault("stderr", subprocess.DEVNULL)
        process = subprocess.Popen(args, env=self.env, cwd=ROOT, start_new_session=True, text=True, **kwargs)
        self.started.append(process)
        return process

    def stop(self, process: subprocess.Popen) -> None:
        stop_process(process, signal.SIGTERM, timeout=5)

    def stop_all(self) -> None:
        for process in reversed(self.started):
            self.stop(process)


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def measure(procs: Processes, name: str, send_topic: str, recv_topic: str, node: list[str] | None,
            latency_seconds: float) -> dict[str, object]:
    relay = procs.start(node) if node else None
    phases = [["lat", 500, latency_seconds]] + [[f"r{r}", r, 1.0] for r in RATES] + [["blast", 0, 1.0]]
    receiver = procs.start([sys.executable, *PROBE, "recv", recv_topic], stdout=subprocess.PIPE)
    sender = procs.start([sys.executable, *PROBE, "send", send_topic, json.dumps({"phases": phases})],
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert receiver.stdout is not None and sender.stdin is not None and sender.stdout is not None
    line = receiver.stdout.readline().strip()
    if line != "first":
        raise RuntimeError(f"{name}: no message came through (receiver said {line!r})")
    time.sleep(0.5)
    sender.stdin.write("go\n")
    sender.stdin.flush()
    sent = json.loads(sender.stdout.readline())["sent"]
    got = json.loads(receiver.stdout.readline())
    for process in (sender, receiver) + ((relay,) if relay else ()):
        procs.stop(process)
    lat_us = [1e6 * x for x in got["latencies"].get("lat", [])]
    sustained = 0.0
    for rate in RATES:
        phase = f"r{rate}"
        achieved = sent[phase] / 1.0
        if sent[phase] and got["counts"].get(phase, 0) >= 0.99 * sent[phase]:
            sustained = max(sustained, achieved)
    blast_rx = got["counts"].get("blast", 0)
    blast_span = got["span"].get("blast", 0.0) or 1.0
    return {"name": name, "p50": percentile(lat_us, 50) if lat_us else float("nan"),
            "p99": percentile(lat_us, 99) if lat_us else float("nan"),
            "mean": statistics.fmean(lat_us) if lat_us else float("nan"),
            "n": len(lat_us), "lat_sent": sent["lat"], "sustained": sustained,
            "blast_sent": sent["blast"], "blast_rx": blast_rx, "blast_rate": blast_rx / blast_span,
            "per_rate": {r: (sent[f"r{r}"], got["counts"].get(f"r{r}", 0)) for r in RATES}}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0, help="length of the 500 msg/s latency run")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--rounds", type=int, default=1,
                        help="measure every path this many times, interleaved, and keep each path's median "
                             "p50/p99 (the machine is shared: interleaving spreads load changes fairly)")
    parser.add_argument("--queue-size", type=int, default=None,
                        help="pass ~queue_size to our suppressor (default: the node's own default)")
    args = parser.parse_args()

    master = start_master()
    env = dict(os.environ, ROS_MASTER_URI=master.uri, ROS_HOSTNAME="127.0.0.1", PYTHONUNBUFFERED="1",
               ROS_PACKAGE_PATH=f"{ROOT}:/usr/share", ROS_HOME=f"/tmp/ros_home_bench_{os.getpid()}")
    env.pop("ROS_IP", None)
    procs = Processes(env)
    suppressor = [sys.executable, str(ROOT / "nodes" / "suppressor"), "_time_constant:=0.5",
                  "_type:=geometry_msgs/TwistStamped"]
    if args.queue_size is not None:
        suppressor.append(f"_queue_size:={args.queue_size}")
    runs = [
        ("direct", "/b/direct", "/b/direct", None),
        ("suppressor (lower)", "/b/s1/lower", "/b/s1/out",
         suppressor + ["upper:=/b/s1/upper", "lower:=/b/s1/lower", "output:=/b/s1/out", "__name:=supp1"]),
        ("suppressor (upper)", "/b/s2/upper", "/b/s2/out",
         suppressor + ["upper:=/b/s2/upper", "lower:=/b/s2/lower", "output:=/b/s2/out", "__name:=supp2"]),
        ("topic_tools relay", "/b/r/in", "/b/r/out", [RELAY, "/b/r/in", "/b/r/out", "__name:=relay"]),
    ]
    results = []
    try:
        rounds: dict[str, list[dict]] = {}
        for round_ in range(args.rounds):
            # each round starts one path later, so no path always follows the same neighbour
            for name, send_topic, recv_topic, node in runs[round_ % len(runs):] + runs[:round_ % len(runs)]:
                print(f"round {round_ + 1}: measuring {name} ...", file=sys.stderr, flush=True)
                rounds.setdefault(name, []).append(measure(procs, name, send_topic, recv_topic, node, args.seconds))
        for name in (run[0] for run in runs):
            measured = rounds[name]
            best = sorted(measured, key=lambda r: r["p50"])[len(measured) // 2]
            best = dict(best, p99=statistics.median(r["p99"] for r in measured),
                        sustained=statistics.median(r["sustained"] for r in measured),
                        blast_rate=statistics.median(r["blast_rate"] for r in measured))
            results.append(best)
    finally:
        procs.stop_all()
        master.stop()

    by = {r["name"]: r for r in results}
    print(f"arbiter_latency  {datetime.datetime.now():%Y-%m-%d %H:%M}  geometry_msgs/TwistStamped, "
          f"latency at 500 msg/s for {args.seconds:g} s, tcp_nodelay, median of {args.rounds} round(s)")
    print(f"{'path':<22}{'p50 µs':>9}{'p99 µs':>9}{'mean µs':>9}{'n':>7}{'sustained/s':>13}{'blast rx/s':>12}")
    for r in results:
        print(f"{r['name']:<22}{r['p50']:>9.0f}{r['p99']:>9.0f}{r['mean']:>9.0f}{r['n']:>7}"
              f"{r['sustained']:>13.0f}{r['blast_rate']:>12.0f}")
    relay = by["topic_tools relay"]
    ok = True
    for name in ("suppressor (lower)", "suppressor (upper)"):
        ours = by[name]
        r50, r99 = ours["p50"] / relay["p50"], ours["p99"] / relay["p99"]
        print(f"{name}: ours/relay p50 {r50:.2f}, p99 {r99:.2f}")
        lat_ok = ours["p50"] <= relay["p50"] and ours["p99"] <= relay["p99"]
        rate_ok = ours["sustained"] >= 5000
        ok &= lat_ok and rate_ok
        print(f"  goal: latency <= relay at p50 and p99: {'yes' if lat_ok else 'NO'}; "
              f">= 5000 msg/s sustained: {'yes' if rate_ok else 'NO'} ({ours['sustained']:.0f})")
    print("per-rate (sent, received):")
    for r in results:
        print(f"  {r['name']:<22}" + "  ".join(f"{k}: {s}/{g}" for k, (s, g) in r["per_rate"].items()))
    print(f"goals hold: {'yes' if ok else 'NO'}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
