"""The camera pictures of docs/simulator.md: ``python -m subsim.camera_figures [--out docs/images]``.

For each camera world (pingpong, office) a moment when the target or a person is in view: the RGB frame and
the registered depth frame (metres, colour-mapped; black where there is no reading) side by side, from the
robot's own camera in the simulation after a fixed number of steps (deterministic).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import cv2
import numpy as np

from . import world_path
from .sim import Simulation

ROOT = Path(__file__).resolve().parent.parent

# world -> (simulated seconds to run, robot pose to look from)
VIEWS = {
    "pingpong": (30.0, (1.0, 1.0, math.radians(55))),
    "office": (8.0, None),
}


def depth_colour(depth: np.ndarray, max_range: float) -> np.ndarray:
    """Depth as an RGB picture: near bright, far dark (TURBO), no reading black."""
    scaled = np.nan_to_num(255 * (1 - np.clip(depth / max_range, 0, 1)), nan=0).astype(np.uint8)
    rgb = cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO)[:, :, ::-1].copy()
    rgb[np.isnan(depth)] = 0
    return rgb


def figure(name: str, out: Path) -> list[Path]:
    seconds, pose = VIEWS[name]
    sim = Simulation(world_path(name), seed=0, record=False)
    for _ in range(int(round(seconds / 0.02))):
        sim.step(0.02)
    robot = sim.robots["robot0"]
    if pose is not None:
        robot.x, robot.y, robot.theta = pose
    frame = sim.render("robot0")
    spec = robot.spec.camera
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"camera_{name}_rgb.png", out / f"camera_{name}_depth.png"]
    cv2.imwrite(str(paths[0]), frame.rgb[:, :, ::-1])
    cv2.imwrite(str(paths[1]), depth_colour(frame.depth, spec.max_range)[:, :, ::-1])
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images", help="folder for the PNGs")
    args = parser.parse_args(argv)
    for name in VIEWS:
        for path in figure(name, args.out):
            print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
