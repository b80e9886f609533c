"""`make demo`: Brooks' wander robot, levels 0, 1 and 2, on a real ROS graph and in-process, with figures.

1. the network diagram (the paper's Fig. 1);
2. levels 0, 1, 2 on the real ROS graph (master, simulator, the modules and arbiters as ROS nodes) at `rate` x real time,
   each level a process of its own (`--groups level`); the level-2 run is recorded with rosbag;
3. 10-simulated-minute runs in the in-process runtime (in a worker process, beside the ROS runs): level 0 with
   another robot approaching, levels 1 and 2 on both of the paper's maps (its Fig. 6), composed into one figure;
4. a summary table of every run (printed, and written as summary.md).
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from subsim import world_path  # noqa: E402
from subsumption.network import load  # noqa: E402
from subsumption.network.graph import draw  # noqa: E402
from subsumption.network.wiring import wire  # noqa: E402

from .runner import ROBOTS, ROOT, RunSpec, Stage, run_local, write_outputs  # noqa: E402
from .worker import InProcessWork  # noqa: E402

APPROACH_WORLD = ROOT / "experiments" / "worlds" / "approach_world.yaml"
ROS_RUNS = [(0, APPROACH_WORLD), (1, world_path("corridors")), (2, world_path("sparse"))]
LOCAL_RUNS = [(0, APPROACH_WORLD), (1, world_path("corridors")), (1, world_path("sparse")),
              (2, world_path("corridors")), (2, world_path("sparse"))]


def _world_name(world: Path) -> str:
    return world.stem.removesuffix("_world")


def local_run(level: int, world: Path, duration: float, folder: Path) -> dict:
    """One in-process run of the wander robot (in the worker), its outputs written to `folder`: its metrics."""
    result = run_local(RunSpec("wander", level, world, duration, seed=0, label=f"level {level}"))
    write_outputs(result, folder)
    return result.metrics


def main(out: Path, ros_duration: float, rate: float, local_duration: float, work: InProcessWork | None = None,
         queue_next: Callable[[], object] | None = None) -> int:
    """The wander robot's experiment into `out`. `work`: the worker for the in-process runs (default: one of its
    own); `queue_next`: called once this experiment's in-process runs are given to the worker, to give it more
    work to do while the ROS runs go on (make demo queues the patrol robot's map there)."""
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    own_work = work is None
    work = work or InProcessWork()
    try:
        return _main(out, ros_duration, rate, local_duration, work, started, queue_next)
    finally:
        if own_work:
            work.close()


def _main(out: Path, ros_duration: float, rate: float, local_duration: float, work: InProcessWork,
          started: float, queue_next: Callable[[], object] | None = None) -> int:
    rows: list[dict] = []
    print("[1/4] network diagram", flush=True)
    network = load(ROBOTS["wander"])
    draw(wire(network), out / "wander_network.png")
    draw(wire(network), out / "wander_network.svg")
    print(f"      {out / 'wander_network.png'}", flush=True)

    # the in-process runs go to the worker at once: they run beside the ROS runs
    local_runs = [work.submit(local_run, level, world, local_duration,
                              out / f"local_level{level}_{_world_name(world)}") for level, world in LOCAL_RUNS]
    if queue_next is not None:
        queue_next()
    print(f"[2/4] ROS graph: levels 0, 1, 2, {ros_duration:.0f} simulated s each at {rate:g}x real time", flush=True)
    stage = Stage.start()
    for level, world in ROS_RUNS:
        folder = out / f"ros_level{level}_{_world_name(world)}"
        command = [sys.executable, "-m", "subsumption.cli", "run", "wander", "--level", str(level), "--world",
                   str(world), "--duration", str(ros_duration), "--runtime", "ros", "--rate", str(rate),
                   "--groups", "level", "--out", str(folder)]
        if level == 2:
            command += ["--bag", str(folder / "run.bag")]
        if subprocess.run(command).returncode != 0:
            print(f"demo: the ROS run of level {level} failed", file=sys.stderr)
            return 1
        rows.append(json.loads((folder / "metrics.json").read_text()))

    print(f"      ROS runs: {stage.end()}", flush=True)
    print(f"[3/4] in-process runtime: {local_duration / 60:.0f} simulated minutes per run (in a worker process, "
          f"beside the ROS runs)", flush=True)
    stage = Stage.start()
    for (level, world), future in zip(LOCAL_RUNS, local_runs):
        try:
            metrics = future.result()
        except Exception as error:  # the worker's own error, whatever it is: said in one line
            print(f"demo: the in-process run of level {level} on {_world_name(world)} failed: "
                  f"{type(error).__name__}: {error}", file=sys.stderr)
            return 1
        rows.append(metrics)
        print(f"      level {level} on {_world_name(world)}: {metrics['wall_time_s']:.1f} s wall", flush=True)
    figure_6(out)
    print(f"      waiting for the in-process runs and Fig. 6: {stage.end()}", flush=True)

    print("[4/4] summary", flush=True)
    table = summary_table(rows)
    (out / "summary.md").write_text(table + "\n")
    print(table)
    print(f"\nwritten to {out} in {time.monotonic() - started:.0f} s", flush=True)
    return 0


def figure_6(out: Path) -> Path:
    """The paper's Fig. 6: levels 1 and 2 on both maps, one panel each."""
    panels = [(f"local_level{level}_{name}", f"({letter}) level {level}, {name}")
              for letter, (level, name) in zip("abcd", [(1, "corridors"), (1, "sparse"), (2, "corridors"),
                                                        (2, "sparse")])]
    fig, axes = plt.subplots(2, 2, figsize=(14, 12))
    for ax, (folder, caption) in zip(axes.flat, panels):
        ax.imshow(plt.imread(out / folder / "trajectory.png"))
        ax.set_title(caption)
        ax.axis("off")
    fig.tight_layout()
    path = out / "fig6_trajectories.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def summary_table(rows: list[dict]) -> str:
    head = ("| runtime | level | map | simulated s | wall s | collisions | distance m | coverage m² | "
            "upper line in control |")
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for row in rows:
        shares = ", ".join(f"{name} {share:.0%}" for name, share in row["upper_in_control"].items()) or "-"
        runtime = f"ros {row['rate']:g}x" if row["runtime"] == "ros" else "local"
        lines.append(f"| {runtime} | {row['level']} | {Path(row['map']).stem} | {row['sim_time_s']:.0f} | "
                     f"{row['wall_time_s']:.1f} | {row['collisions']} | {row['distance_m']:.1f} | "
                     f"{row['coverage_m2']:.1f} | {shares} |")
    return "\n".join(lines)
