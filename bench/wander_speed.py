"""How fast the wander robot runs, in-process and on the ROS graph.

1. In-process: wall time of a 10-simulated-minute level-2 run on each shipped map (goal: at most 10 s).
2. ROS graph: level 2 on each shipped map for --ros-duration simulated seconds at increasing real-time factors;
   the highest factor at which the robot keeps zero collisions and the simulator keeps its pace (goal: it holds
   at 3x on 2 cores).

    .venv/bin/python -m bench.wander_speed [--ros-duration 60] [--rates 3,5,8,12]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from experiments.runner import RunSpec, run_local
from subsim import world_path

MAPS = ("corridors", "sparse")


def local_figures() -> list[tuple[str, float, int]]:
    rows = []
    for name in MAPS:
        result = run_local(RunSpec("wander", 2, world_path(name), 600.0, seed=1))
        rows.append((name, result.metrics["wall_time_s"], result.metrics["collisions"]))
    return rows


def ros_run(name: str, rate: float, duration: float) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        started = time.monotonic()
        done = subprocess.run([sys.executable, "-m", "subsumption.cli", "run", "wander", "--level", "2", "--world",
                               str(world_path(name)), "--duration", str(duration), "--runtime", "ros",
                               "--rate", str(rate), "--out", folder], capture_output=True, text=True, cwd=ROOT)
        if done.returncode != 0:
            return {"error": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed"}
        metrics = json.loads((Path(folder) / "metrics.json").read_text())
        metrics["total_wall_s"] = time.monotonic() - started
        return metrics


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ros-duration", type=float, default=60.0)
    parser.add_argument("--rates", default="3,5,8,12")
    args = parser.parse_args()
    rates = [float(r) for r in args.rates.split(",")]

    print("In-process runtime, level 2, 600 simulated s (goal: <= 10 s wall)")
    print("| map | wall s | real-time factor | collisions | goal met |")
    print("|---|---|---|---|---|")
    for name, wall, collisions in local_figures():
        print(f"| {name} | {wall:.1f} | {600 / wall:.0f}x | {collisions} | {'yes' if wall <= 10 else 'NO'} |",
              flush=True)

    print(f"\nROS graph, level 2, {args.ros_duration:.0f} simulated s per run (goal: zero collisions at 3x)")
    print("| map | asked factor | achieved factor | collisions | coverage m² | holds |")
    print("|---|---|---|---|---|---|")
    best: dict[str, float] = {}
    for name in MAPS:
        for rate in rates:
            m = ros_run(name, rate, args.ros_duration)
            if "error" in m:
                print(f"| {name} | {rate:g}x | - | - | - | NO ({m['error']}) |", flush=True)
                break
            achieved = m["sim_time_s"] / m["wall_time_s"] if m["wall_time_s"] else 0.0
            holds = m["collisions"] == 0 and achieved >= 0.8 * rate
            print(f"| {name} | {rate:g}x | {achieved:.1f}x | {m['collisions']} | {m['coverage_m2']:.1f} | "
                  f"{'yes' if holds else 'NO'} |", flush=True)
            if not holds:
                break
            best[name] = rate
    print("\nhighest factor that holds: " + ", ".join(f"{n} {best.get(n, 0):g}x" for n in MAPS))
    print(f"goal (holds at 3x on both maps): {'met' if all(best.get(n, 0) >= 3 for n in MAPS) else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
