"""Soak: the patrol robot at level 4 on ROS at 1x for a long run: memory and latency must stay flat.

The run is the ordinary command (``subsumption run patrol --level 4 --runtime ros --rate 1``, the ping-pong room
with its intruder coming in, followed, and gone, again and again: its round loops); this process joins its master
and every --sample simulated seconds reads the resident memory (VmRSS) of every node's process (its pid asked of the
node itself, as ``rosnode`` does) and the latency of the sensor pipeline: how old, in ROS time, each message of
/scan (depth_scan's, from the camera's depth image), /amcl_pose and /track/box_info is when it arrives here. Printed
at the end: every node's memory at --baseline s (the issue: 5 minutes) and at the end, the largest growth; the mean
latency of each topic in the first and the last tenth of the run; the run's collisions and deaths. The issue's
figure is --duration 3600: 0 collisions, every node within +10 % of its 5-minute memory, no growth in latency.

    .venv/bin/python -m bench.soak [--duration 3600] [--baseline 300] [--sample 30] [--out out/soak]
    .venv/bin/python -m bench.soak --duration 240 --baseline 60 --sample 15    # a short version

(bench.arbiter_soak is the arbiters' own soak under 5,000 messages a second.)
Writes OUT/soak.json.
"""
from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

from bench.chaos import MAP, WORLD, RunWatch, pid_of
from subsim.world import WorldDocument
from subsumption.network import load
from subsumption.network.wiring import wire
from subsumption.ros.launch import watched_nodes

PATROL = Path(__file__).resolve().parent.parent / "robots" / "patrol" / "patrol.yaml"
LATENCY_TOPICS = {"/scan": "sensor_msgs/LaserScan", "/amcl_pose": "geometry_msgs/PoseWithCovarianceStamped",
                  "/track/box_info": "sensor_msgs/CameraInfo"}
GROWTH_LIMIT = 0.10


def rss_kb(pid: int) -> int | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


class Latency:
    """Ages (ROS time now minus the header's stamp) of each topic's messages, with the ROS time of arrival."""

    def __init__(self) -> None:
        import rospy
        import roslib.message

        self.ages: dict[str, list[tuple[float, float]]] = {topic: [] for topic in LATENCY_TOPICS}
        for topic, kind in LATENCY_TOPICS.items():
            rospy.Subscriber(topic, roslib.message.get_message_class(kind),
                             lambda msg, t=topic: self._heard(t, msg), queue_size=50)

    def _heard(self, topic: str, msg) -> None:
        import rospy

        now = rospy.get_time()
        stamp = msg.header.stamp.to_sec()
        if stamp > 0:
            self.ages[topic].append((now, now - stamp))

    def mean(self, topic: str, start: float, end: float) -> float | None:
        ages = [age for at, age in self.ages[topic] if start <= at < end]
        return round(sum(ages) / len(ages), 4) if ages else None


def coming_and_going(out: Path) -> Path:
    """The chaos scene's world with its target walking its round again and again (``loop: true``): in through the
    room's east door, across the robot's patrol, out of the west door and back along the north corridor, so that
    an hour's run meets it many times. Written to OUT/soak_world.yaml."""
    document = WorldDocument(WORLD)
    for agent in document.data["agents"]:
        agent["loop"] = True
    return document.write(out / "soak_world.yaml")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.soak", description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=3600.0, help="simulated s of the run")
    parser.add_argument("--baseline", type=float, default=300.0, help="simulated s of the memory baseline")
    parser.add_argument("--sample", type=float, default=30.0, help="simulated s between memory samples")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("out/soak"))
    args = parser.parse_args(argv)
    if not (0 < args.baseline < args.duration and 0 < args.sample <= args.baseline):
        parser.error("expected 0 < --sample <= --baseline < --duration")
    nodes = [n["name"] for n in watched_nodes(wire(load(PATROL), 4))]
    command = [str(Path(sys.executable).parent / "subsumption"), "run", "patrol", "--level", "4", "--world",
               str(coming_and_going(args.out)), "--map", str(MAP), "--runtime", "ros", "--rate", "1", "--duration", str(args.duration),
               "--seed", str(args.seed), "--out", str(args.out)]
    print(f"soak: {' '.join(command)}", flush=True)
    run = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                           start_new_session=True)
    watch = RunWatch(run)
    memory: dict[str, list[tuple[float, int]]] = {node: [] for node in nodes}
    latency = None
    try:
        master_uri = watch.join_graph("soak")
        if master_uri is None:
            return 1
        import rospy

        latency = Latency()
        next_sample = args.sample
        while run.poll() is None:
            now = rospy.get_time()
            if now >= next_sample:
                for node in nodes:
                    pid = pid_of(master_uri, node)
                    kb = rss_kb(pid) if pid else None
                    if kb:
                        memory[node].append((now, kb))
                next_sample += args.sample
            time.sleep(0.2)
    finally:
        if run.poll() is None:
            run.send_signal(signal.SIGINT)
            run.wait(60)
    return report(args, memory, latency, watch)


def report(args: argparse.Namespace, memory: dict, latency: Latency | None, watch: RunWatch) -> int:
    metrics_path = args.out / "metrics.json"
    if not metrics_path.exists():
        print("soak: the run wrote no metrics:\n" + "\n".join(watch.lines), file=sys.stderr)
        return 1
    metrics = json.loads(metrics_path.read_text())
    end = metrics.get("sim_time_s") or args.duration
    growth = {}
    for node, samples in memory.items():
        base = next((kb for t, kb in samples if t >= args.baseline), None)
        half = next((kb for t, kb in samples if t >= end / 2), None)
        if base and samples:
            # the second half's growth tells a leak (still growing) from a high-water mark reached early
            growth[node] = {"baseline_mb": round(base / 1024, 1), "end_mb": round(samples[-1][1] / 1024, 1),
                            "growth": round(samples[-1][1] / base - 1.0, 4),
                            "second_half_growth": round(samples[-1][1] / half - 1.0, 4) if half else None,
                            "samples_mb": [[round(t, 1), round(kb / 1024, 1)] for t, kb in samples]}
    worst = max(growth.items(), key=lambda item: item[1]["growth"], default=(None, None))
    tenth = end / 10
    lat = {topic: {"first_tenth_s": latency.mean(topic, 0, tenth), "last_tenth_s": latency.mean(topic, end - tenth,
                                                                                                end + 1)}
           for topic in LATENCY_TOPICS} if latency else {}
    over = [node for node, g in growth.items() if g["growth"] > GROWTH_LIMIT]
    summary = {"sim_time_s": end, "collisions": metrics.get("collisions"), "deaths": metrics.get("deaths"),
               "nodes_sampled": len(growth), f"nodes_over_{GROWTH_LIMIT:.0%}": over, "worst_growth": worst,
               "latency": lat, "memory": growth, "complete": metrics.get("complete")}
    (args.out / "soak.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"soak: {end:.0f} s simulated, {metrics.get('collisions')} collisions, {len(metrics.get('deaths') or [])} "
          f"deaths; memory of {len(growth)} nodes from {args.baseline:g} s to the end: largest growth "
          f"{worst[0]} {worst[1]['growth']:+.1%}" if worst[0] else "soak: no memory samples")
    for node, g in sorted(growth.items(), key=lambda item: -item[1]["growth"])[:8]:
        second = f", second half {g['second_half_growth']:+.1%}" if g["second_half_growth"] is not None else ""
        print(f"  {node:>24}: {g['baseline_mb']:7.1f} MB -> {g['end_mb']:7.1f} MB ({g['growth']:+.1%}{second})")
    for topic, values in lat.items():
        print(f"  latency {topic}: first tenth {values['first_tenth_s']} s, last tenth {values['last_tenth_s']} s")
    if lat:
        print("  (ages in ROS time, which this process learns from /clock: an age below zero is a message that came "
              "before the next /clock did)")
    return 0 if growth and not over and not metrics.get("collisions") else 1


if __name__ == "__main__":
    sys.exit(main())
