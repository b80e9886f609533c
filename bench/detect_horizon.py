"""detect's whole-image scan against the scan of the rows above the camera's horizon (``~below_horizon_px``).

A level camera lower than every face (a TurtleBot's Kinect, 0.29 m up) sees no face below its horizon row (cy),
so detect's whole-image Haar scan may skip those rows. On the same frames, both scans: CPU time per frame (this
process's, which other processes' load does not inflate), faces found, and on tests/support/photoscene.py's frames (the
issue's occlusion and entering scenes, seeds 0-2, every 10th frame) the true faces of at least 24 px found and
the false detections; plus frames rendered by the simulator in the ping-pong and office intruder worlds (the
robot standing at its start, the target and the people walking by), where the boxes of both scans are compared.

Usage: .venv/bin/python -m bench.detect_horizon [--below 16]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from subsim.sim import Simulation
from tests.support import photoscene as ps
from vision.boxes import Box
from vision.faces import FaceDetector, to_gray

WORLDS = ("experiments/worlds/pingpong_intruder_world.yaml", "experiments/worlds/office_intruder_world.yaml")


def frames() -> tuple[list, list]:
    """(gray frames, true face boxes or None) of the photo scenes, then of the simulator's worlds."""
    grays, truths = [], []
    for seed in (0, 1, 2):
        for scene in (ps.occlusion_scene, ps.entering_scene):
            walkers, passers, still, timing = scene(seed)[:4]
            for i, (_, frame) in enumerate(ps.sequence(walkers, timing["duration_s"], 30.0, passers, still,
                                                       seed=seed)):
                if i % 10 == 0:
                    grays.append(to_gray(frame.rgb))
                    truths.append([Box(*face) for face in frame.faces.values()])
    for world in WORLDS:
        sim = Simulation(str(ROOT / world), seed=1, record=False)
        for _ in range(60):
            for _ in range(50):
                sim.step(0.02)
            grays.append(to_gray(sim.render("robot0").rgb))
            truths.append(None)
    return grays, truths


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--below", type=int, default=16, help="rows below the horizon scanned too")
    args = parser.parse_args()
    detector = FaceDetector("haar_alt2", 24, 1.1)
    grays, truths = frames()
    height, width = grays[0].shape
    cy = (height - 1) / 2.0  # the simulator's and photoscene's pinhole
    region = Box(0.0, 0.0, float(width), float(min(height, math.ceil(cy) + 1 + args.below)))
    cpu = {"whole": 0.0, "above": 0.0}
    found = {"whole": 0, "above": 0}
    false = {"whole": 0, "above": 0}
    faces = {"whole": 0, "above": 0}
    true_faces = same = below = 0
    for gray, truth in zip(grays, truths):
        result = {}
        for name, where in (("whole", None), ("above", region)):
            start = time.process_time()
            result[name] = detector.detect(gray, where)
            cpu[name] += time.process_time() - start
            faces[name] += len(result[name])
            if truth is not None:
                found[name] += sum(any(box.iou(t) > 0.5 for box in result[name]) for t in truth if t.h >= 24)
                false[name] += sum(all(box.iou(t) <= 0.3 for t in truth) for box in result[name])
        if truth is not None:
            true_faces += sum(t.h >= 24 for t in truth)
        below += sum(box.y + box.h > cy for box in result["whole"])
        same += len(result["whole"]) == len(result["above"]) and all(
            max((box.iou(other) for other in result["above"]), default=0.0) > 0.8 for box in result["whole"])
    n = len(grays)
    print(f"{n} frames 640x480 ({sum(t is not None for t in truths)} photo scenes, {sum(t is None for t in truths)} "
          f"simulator); scan above the horizon: rows 0-{int(region.h) - 1}")
    print("| scan | CPU ms/frame | faces found | true faces >= 24 px found (photo scenes) | false detections |")
    print("|---|---|---|---|---|")
    for name, label in (("whole", "whole image"), ("above", f"above the horizon + {args.below} rows")):
        print(f"| {label} | {1000 * cpu[name] / n:.1f} | {faces[name]} | {found[name]}/{true_faces} | {false[name]} |")
    print(f"frames with the same faces (IoU > 0.8) from both: {same}/{n}; faces the whole scan found reaching below "
          f"the horizon: {below}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
