"""False alarms from the posters when detect scans every frame: how often a poster passes for a face.

The patrol robot's detect scans the newest frame as soon as its CPU budget allows (``~cpu_share``): on the
simulator's frames that is every frame, 2.5 times as many scans as at 10 Hz, and as many more chances for a poster
(the cat, ``skimage``'s ``chelsea``, is a known near-face for Haar alt2 and alt) to pass the detector in two frames
running: it raised a false alarm once on the ROS graph (seed 3, the robot turning at 1.5 rad/s in the room's
north-east corner, the poster 6.7 m away). Here the robot stands at places along its patrol in each intruder world
(the lap's corners and every ``--step`` m between them; the worlds without their agents: no true face in view) and
turns on the spot at 1.5 rad/s, a frame every 0.04 s (the simulator's 25 Hz camera). The frames (colour and the
depth of the same instant) go through the Detect module (no face model: every face is a suspect): paced at 10 Hz
(before); every frame, without the depth check (``~depth_check_m`` 0), with ``confirm`` 3 instead, and with the
check (a box so large that a face would be within the depth's range needs a depth reading there). Printed: frames,
frames in which the scan found a "face", and the alarms each raised (each is a false alarm).

Usage: .venv/bin/python -m bench.detect_posters [--step 1.0] [--turn 1.5]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

import cv2
import genpy
import numpy as np

from subsim.sim import Simulation
from subsumption.images import from_array
from subsumption.testing import Harness
from vision.boxes import Box
from vision.faces import FaceDetector, to_gray
from vision.modules import Detect

WORLDS = {  # world: the patrol's goals in order (the ping-pong room's four corners; the office corridor's two ends)
    "experiments/worlds/pingpong_intruder_world.yaml": [(0.98, 0.98), (9.43, 0.98), (9.43, 5.43), (0.98, 5.43)],
    "experiments/worlds/office_intruder_world.yaml": [(1.5, 6.0), (18.3, 6.0)],
}
FRAME_S = 0.04


def places(goals: list[tuple[float, float]], step_m: float) -> list[tuple[float, float]]:
    """The goals and points every `step_m` on the straight ways between them, round the lap."""
    out = []
    for (x0, y0), (x1, y1) in zip(goals, goals[1:] + goals[:1] if len(goals) > 2 else goals[1:]):
        n = max(1, int(math.hypot(x1 - x0, y1 - y0) // step_m))
        out += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(n)]
    return out + ([goals[-1]] if len(goals) <= 2 else [])


def spins(world: str, goals: list[tuple[float, float]], step_m: float, turn: float):
    """(place, frames) of a full turn on the spot at each place of the patrol, the world's agents removed."""
    sim = Simulation(str(ROOT / world), seed=1, record=False)
    sim.agents.clear()
    name, robot = next(iter(sim.robots.items()))
    for x, y in places(goals, step_m):
        frames = []
        for k in range(int(math.ceil(2 * math.pi / (turn * FRAME_S)))):
            robot.x, robot.y, robot.theta = float(x), float(y), k * turn * FRAME_S
            frame = sim.render(name)
            frames.append((frame.rgb.copy(), frame.depth.copy()))
        yield (float(x), float(y)), frames


CONFIGS = {  # name: detect's parameters
    "10 Hz, confirm 2, no depth check (before)": {"rate": 10.0, "depth_check_m": 0.0},
    "every frame, no depth check": {"rate": 1.0 / FRAME_S, "depth_check_m": 0.0},
    "every frame, confirm 3, no depth check": {"rate": 1.0 / FRAME_S, "confirm": 3, "depth_check_m": 0.0},
    "every frame, depth check (the patrol robot's now)": {"rate": 1.0 / FRAME_S},
}


def alarms(frames, params: dict) -> int:
    """Alarms the Detect module raises on `frames` (colour and depth of each instant; the patrol robot's horizon)."""
    harness = Harness(Detect, params={"below_horizon_px": 16, **params})
    harness.run_for(1.0)
    for rgb, depth_m in frames:
        stamp = genpy.Time.from_sec(harness.runtime.now())
        depth = from_array(depth_m, "32FC1")
        image = from_array(rgb, "rgb8")
        depth.header.stamp = image.header.stamp = stamp
        harness.feed("depth", depth)
        harness.feed("image", image)
        harness.run_for(FRAME_S)
    return len(harness.sent("alarm"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--step", type=float, default=1.0, help="m between places along the patrol")
    parser.add_argument("--turn", type=float, default=1.5, help="rad/s on the spot")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    detector = FaceDetector("haar_alt2", 24, 1.1)
    region = Box(0.0, 0.0, 640.0, 257.0)  # the rows detect scans: the horizon (cy 239.5) and 16 below
    print("| world | places | frames | frames with a 'face' | " + " | ".join(f"false alarms: {c}" for c in CONFIGS)
          + " | places with one (every frame, no depth check) |")
    print("|---|---|---|---|" + "---|" * len(CONFIGS) + "---|")
    for world, goals in WORLDS.items():
        start = time.process_time()
        places = n = found = 0
        raised = dict.fromkeys(CONFIGS, 0)
        where = []
        for place, frames in spins(world, goals, args.step, args.turn):
            places += 1
            n += len(frames)
            found += sum(bool(detector.detect(to_gray(rgb), region)) for rgb, _ in frames)
            for config, params in CONFIGS.items():
                got = alarms(frames, params)
                raised[config] += got
                if got and config == "every frame, no depth check":
                    where.append(f"({place[0]:.1f}, {place[1]:.1f})")
        print(f"| {Path(world).stem} | {places} | {n} | {found} | " + " | ".join(str(v) for v in raised.values())
              + f" | {' '.join(where) or '-'} |", flush=True)
        print(f"  ({time.process_time() - start:.0f} CPU s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
