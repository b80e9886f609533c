"""How much faster than real time the simulator runs: one robot, 12 sonars and a 541-beam laser at 10 Hz,
physics at 50 Hz, on a 50 m x 50 m map at 5 cm with random boxes (fixed seed).

  (1) in-process, headless: the pure Simulation, and the Simulation with its bridge on a LocalRuntime
      (every message built and published; the goal, >= 200x, is judged on this one);
  (2) under ROS: a private rosmaster (started here on a free port, stopped by pid), the simulator node at
      ~rate 0 (as fast as it can) and one rospy process subscribed to every topic; goal >= 5x.

Usage: .venv/bin/python -m bench.sim_speed [--seconds SIM_SECONDS] [--ros-seconds SIM_SECONDS] [--no-ros]
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from geometry_msgs.msg import Twist

from subsim.mapio import FREE, OCCUPIED, save_map
from subsim.sim import Simulation

from .simulator_graph import run_simulator

GOAL_LOCAL, GOAL_ROS = 200.0, 5.0

# Subscribes to every topic the simulator publishes, counts messages, leaves after 3 s of silence.
LISTENER = r"""
import json, sys, time, rospy
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan, Range
from std_msgs.msg import UInt8, UInt32
from tf2_msgs.msg import TFMessage
topics = {"/clock": Clock, "/scan": LaserScan, "/sonar": Range, "/odom": Odometry, "/ground_truth": Odometry,
          "/tf": TFMessage, "/tf_static": TFMessage, "/map": OccupancyGrid, "/bumper": UInt8,
          "/collisions": UInt32, "/agents": PoseArray}
counts = {t: 0 for t in topics}
last = [time.monotonic()]
def seen(topic):
    def cb(msg):
        counts[topic] += 1
        last[0] = time.monotonic()
    return cb
rospy.init_node("listener", disable_signals=True)
for topic, kind in topics.items():
    rospy.Subscriber(topic, kind, seen(topic), queue_size=1000)
print("ready", flush=True)
while time.monotonic() - last[0] < 3.0 or counts["/clock"] == 0:
    time.sleep(0.1)
print(json.dumps(counts), flush=True)
"""


def bench_map(folder: Path, seed: int = 7) -> Path:
    """50 m x 50 m, walled, 300 random boxes of 0.2-1.5 m, written as a map_server map and a world file."""
    res, size = 0.05, 1000
    grid = np.full((size, size), FREE, dtype=np.int8)
    grid[:4, :] = grid[-4:, :] = grid[:, :4] = grid[:, -4:] = OCCUPIED
    rng = np.random.default_rng(seed)
    for _ in range(300):
        w, h = rng.integers(4, 30, 2)
        r, c = rng.integers(10, size - 40, 2)
        if math.hypot(r - 500, c - 500) > 40:  # keep the start clear
            grid[r:r + h, c:c + w] = OCCUPIED
    save_map(grid, folder / "bench.yaml", res)
    world = folder / "bench_world.yaml"
    world.write_text("map: bench.yaml\nrobots:\n  - {name: robot0, namespace: '', start: [25.0, 25.0, 0.0]}\n")
    return world


def drive(sim_time: float) -> tuple[float, float]:
    """A wandering command: enough to make the robot move, turn and meet things."""
    return 0.5, 0.8 * math.sin(sim_time / 3.0)


def bench_pure(world: Path, seconds: float) -> tuple[float, float]:
    sim = Simulation(world, seed=1, record=False)
    start = time.perf_counter()
    steps = int(round(seconds * 50))
    for i in range(steps):
        if i % 5 == 0:
            sim.set_command("robot0", *drive(sim.time))
            sim.sense("robot0")
        sim.step(0.02)
    return sim.time, time.perf_counter() - start


def bench_local(world: Path, seconds: float) -> tuple[float, float]:
    from subsumption.local import LocalRuntime

    import subsim.local

    runtime = LocalRuntime()
    subsim.local.attach(runtime, world, seed=1, record=False)
    node = runtime.node("driver")
    pub = node.publisher("/cmd_vel", Twist)

    def command() -> None:
        msg = Twist()
        msg.linear.x, msg.angular.z = drive(runtime.now())
        pub.publish(msg)

    node.call_every(0.1, command)
    start = time.perf_counter()
    runtime.run_for(seconds)
    return runtime.now(), time.perf_counter() - start


def bench_ros(world: Path, seconds: float) -> tuple[float, float, dict[str, int]]:
    """(simulated s, wall s, messages per topic) of the simulator node as fast as it can go."""
    return run_simulator(world, seconds, 0.0, LISTENER, listener_timeout=30.0)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=600.0, help="simulated seconds in-process")
    parser.add_argument("--ros-seconds", type=float, default=120.0, help="simulated seconds under ROS")
    parser.add_argument("--no-ros", action="store_true")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        world = bench_map(Path(tmp))
        Simulation(world)  # compile (or load) the kernels before timing
        simulated, wall = bench_pure(world, args.seconds)
        rows.append(("in-process, Simulation only", simulated, wall, None))
        simulated, wall = bench_local(world, args.seconds)
        rows.append(("in-process, bridge on LocalRuntime", simulated, wall, GOAL_LOCAL))
        counts = None
        if not args.no_ros:
            simulated, wall, counts = bench_ros(world, args.ros_seconds)
            rows.append(("ROS, rate 0, rospy listener on all topics", simulated, wall, GOAL_ROS))
    print("one robot, 12 sonars + 541-beam laser at 10 Hz, physics 50 Hz, 50 m x 50 m map at 5 cm (1000x1000)")
    print(f"| {'setup':<42} | {'sim s':>7} | {'wall s':>7} | {'x real time':>11} | {'goal':>6} | met |")
    print(f"|{'-' * 44}|{'-' * 9}|{'-' * 9}|{'-' * 13}|{'-' * 8}|-----|")
    for name, simulated, wall, goal in rows:
        factor = simulated / wall
        met = "-" if goal is None else ("yes" if factor >= goal else "NO")
        goal_text = "-" if goal is None else f">={goal:g}"
        print(f"| {name:<42} | {simulated:7.1f} | {wall:7.2f} | {factor:11.1f} | {goal_text:>6} | {met:>3} |")
    if counts is not None:
        print("messages the listener received:", ", ".join(f"{k} {v}" for k, v in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
