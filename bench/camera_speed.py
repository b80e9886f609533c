"""How fast the RGB-D camera renders, beside the cost of the simulator's other sensors.

  (1) in-process, one core: ``Simulation.render`` of the TurtleBot's 640x480 Kinect in the pingpong room, from
      poses along a lap of the room (colour + depth, and the cheap ``depth_band`` mode), beside one sweep of a
      541-beam laser + 12 sonars and one physics step; goal >= 200 frames/s for RGB-D;
  (2) in-process, the bridge on a LocalRuntime: the pingpong world with the camera at 30 Hz (images, JPEG,
      camera_info published) and the DepthToScan module making the scan, in simulated seconds per wall second;
  (3) under ROS: a private rosmaster (started here on a free port, stopped by pid), the simulator node at
      ~rate 1 (real time) with the camera on, and one rospy process subscribed to the camera topics: the
      real-time factor the node reports, and the camera rate the subscriber receives; goals 1x and 30 Hz.

Usage: .venv/bin/python -m bench.camera_speed [--frames N] [--seconds SIM_S] [--ros-seconds SIM_S] [--no-ros]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

import subsim
from subsim.sim import Simulation

from .simulator_graph import run_simulator

GOAL_FPS, GOAL_ROS_FACTOR, GOAL_ROS_HZ = 200.0, 1.0, 30.0

LISTENER = r"""
import json, time, rospy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
topics = {"/camera/rgb/image_raw": Image, "/camera/depth/image_raw": Image, "/camera/rgb/camera_info": CameraInfo,
          "/camera/rgb/image_raw/compressed": CompressedImage, "/clock": Clock}
stamps = {t: [] for t in topics}
last = [time.monotonic()]
def seen(topic):
    def cb(msg):
        stamps[topic].append(time.monotonic())
        last[0] = time.monotonic()
    return cb
rospy.init_node("listener", disable_signals=True)
for topic, kind in topics.items():
    rospy.Subscriber(topic, kind, seen(topic), queue_size=10, buff_size=2 ** 24)
print("ready", flush=True)
while time.monotonic() - last[0] < 3.0 or not stamps["/clock"]:
    time.sleep(0.1)
def rate(times):
    return (len(times) - 1) / (times[-1] - times[0]) if len(times) > 2 else 0.0
print(json.dumps({t: [len(v), rate(v)] for t, v in stamps.items()}), flush=True)
"""


def lap_poses(n: int) -> list[tuple[float, float, float]]:
    """Poses round the pingpong room's table, facing along the lap and a little inwards (seeing the table)."""
    corners = np.array([[1.0, 1.0], [9.4, 1.0], [9.4, 5.4], [1.0, 5.4], [1.0, 1.0]])
    lengths = np.hypot(*np.diff(corners, axis=0).T)
    where = np.linspace(0, lengths.sum(), n, endpoint=False)
    poses = []
    for s in where:
        k = int(np.searchsorted(np.cumsum(lengths), s, side="right"))
        a, b = corners[k], corners[k + 1]
        f = (s - np.cumsum(lengths)[k - 1] if k else s) / lengths[k]
        x, y = a + f * (b - a)
        poses.append((float(x), float(y), math.atan2(*(b - a)[::-1]) + 0.4))
    return poses


def world_copy(folder: Path, mode: str = "rgbd", laser: bool = False) -> Path:
    """The pingpong world with absolute paths, the camera in `mode`, and a laser + sonars if asked."""
    world = yaml.safe_load(subsim.world_path("pingpong").read_text())
    world["map"] = str(subsim.MAPS / world["map"])
    for picture in world["scene"]["pictures"] + [world["agents"][0]["picture"]]:
        picture["file"] = str(subsim.MAPS / picture["file"])
    world["agents"][0]["wait"] = 0.0
    sensors = {"camera": {"mode": mode}}
    if laser:
        sensors.update(laser=True, sonar=True)
    world["robots"][0]["sensors"] = sensors
    path = folder / f"pingpong_{mode}{'_laser' if laser else ''}.yaml"
    path.write_text(yaml.safe_dump(world))
    return path


def per_call(fn, n: int) -> tuple[float, float]:
    """(wall ms, CPU ms) per call of fn, over n calls."""
    wall, cpu = time.perf_counter(), time.process_time()
    for i in range(n):
        fn(i)
    return (time.perf_counter() - wall) / n * 1e3, (time.process_time() - cpu) / n * 1e3


def bench_in_process(folder: Path, frames: int) -> list[tuple[str, float, float]]:
    rows = []
    poses = lap_poses(frames)
    for mode in ("rgbd", "depth_band"):
        sim = Simulation(world_copy(folder, mode, laser=True), record=False)
        robot = sim.robots["robot0"]
        for _ in range(200):
            sim.step(0.02)  # the target well into the room

        def frame(i: int) -> None:
            robot.x, robot.y, robot.theta = poses[i % len(poses)]
            sim.render("robot0")

        frame(0)
        wall, cpu = per_call(frame, frames)
        rows.append((f"camera {mode} 640x480" if mode == "rgbd" else "camera depth_band (10 rows)", wall, cpu))
        if mode == "rgbd":
            wall, cpu = per_call(lambda i: sim.sense("robot0"), frames)
            rows.append(("laser 541 beams + 12 sonars, one sweep", wall, cpu))
            wall, cpu = per_call(lambda i: sim.step(0.02), frames)
            rows.append(("physics step (robot + target)", wall, cpu))
    return rows


def bench_local(folder: Path, seconds: float) -> tuple[float, float]:
    from subsumption.local import LocalRuntime
    from vision.depth_scan import DepthToScan

    import subsim.local

    runtime = LocalRuntime()
    subsim.local.attach(runtime, world_copy(folder), seed=1, record=False)
    runtime.add_module(DepthToScan, "depth_scan", remap={"depth": "/camera/depth/image_raw",
                                                         "camera_info": "/camera/depth/camera_info",
                                                         "~scan": "/scan"})
    start = time.perf_counter()
    runtime.run_for(seconds)
    return runtime.now(), time.perf_counter() - start


def bench_ros(folder: Path, seconds: float) -> tuple[float, float, dict]:
    """(simulated s, wall s, per topic [messages, Hz]) of the simulator node at real time with the camera on."""
    return run_simulator(world_copy(folder), seconds, 1.0, LISTENER)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=500, help="frames rendered per in-process measurement")
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds of the LocalRuntime run")
    parser.add_argument("--ros-seconds", type=float, default=30.0, help="simulated seconds under ROS (at real time)")
    parser.add_argument("--no-ros", action="store_true", help="skip the ROS measurement")
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core, as the goal says
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = bench_in_process(folder, args.frames)
        print("in-process, one core, pingpong room, 640x480 Kinect (57 deg), poses round the table")
        print("(per CPU s: calls per second of CPU time this process got; the same as per wall s on an idle core,")
        print(" and the honest figure on a shared machine, where the wall clock also counts other jobs' turns)")
        print(f"| {'what':<40} | {'wall ms':>8} | {'CPU ms':>7} | {'per wall s':>10} | {'per CPU s':>9} | "
              f"{'goal':>6} | met (CPU) |")
        print(f"|{'-' * 42}|{'-' * 10}|{'-' * 9}|{'-' * 12}|{'-' * 11}|{'-' * 8}|-----------|")
        for name, wall, cpu in rows:
            goal = GOAL_FPS if name.startswith("camera rgbd") else None
            met = "-" if goal is None else ("yes" if 1e3 / cpu >= goal else "NO")
            print(f"| {name:<40} | {wall:8.3f} | {cpu:7.3f} | {1e3 / wall:10.0f} | {1e3 / cpu:9.0f} | "
                  f"{'-' if goal is None else f'>={goal:g}':>6} | {met:>9} |")
        cpu_start = time.process_time()
        simulated, wall = bench_local(folder, args.seconds)
        cpu = time.process_time() - cpu_start
        print(f"\nbridge on LocalRuntime, camera 30 Hz (rgb8 + 32FC1 + JPEG + camera_info) + DepthToScan: "
              f"{simulated:.0f} sim s in {wall:.1f} wall s ({cpu:.1f} CPU s) = {simulated / wall:.1f}x real time "
              f"({simulated / cpu:.1f}x per CPU s)")
        print(f"load average now: {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
        if not args.no_ros:
            simulated, wall, counts = bench_ros(folder, args.ros_seconds)
            factor = simulated / wall
            hz = counts["/camera/rgb/image_raw"][1]
            print(f"\nROS, simulator node at ~rate 1 with the camera, {simulated:.0f} sim s in {wall:.1f} wall s: "
                  f"{factor:.2f}x real time (goal >= {GOAL_ROS_FACTOR:g}: {'yes' if factor >= 0.97 else 'NO'}); "
                  f"camera at the subscriber {hz:.1f} Hz (goal {GOAL_ROS_HZ:g}: "
                  f"{'yes' if hz >= 0.95 * GOAL_ROS_HZ else 'NO'})")
            print("listener (messages, Hz):", ", ".join(f"{k} {v[0]} {v[1]:.1f}" for k, v in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
