"""`subsumption experiment patrol --out D`: the paper's second experiment (its Fig. 7), level by level.

The security patrol robot (robots/patrol/patrol.yaml) in the ping-pong room, each level in the scene the paper
shows it in, on the real ROS graph (one process per module, arbiter and the simulator), then again for longer
in the in-process runtime for the numbers:

- level 0: a person walks at the robot, which backs away (Fig. 7(a));
- level 1: it wanders; the target robot crossing the room bumps into it (Fig. 7(b));
- level 2: it explores the corridors round the table (Fig. 7(c));
- level 3: it builds the map with the project's own SLAM, then patrols the room's four corners through
  move_base (Fig. 7(d)); a goal that fails raises an alarm, spoken into a WAV file;
- levels 4 and 5 (detect-track-follow, the operator terminal) run when the network file has them.

Writes, in D: ``levelN/`` per level (the ROS run's ``trajectory.png``, ``metrics.json``, ``alarms/*.wav``,
``logs/``; ``levelN/local/`` the in-process run), ``fig7_trajectories.png`` (one panel per level, from the ROS
runs) and ``summary.md`` (every run's figures). Each ROS run is its own ``subsumption run patrol`` process,
exactly what a user would type.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from subsim import world_path

from .runner import ROBOTS

SCENES = {
    0: "a person walks at the robot: it backs away",
    1: "it wanders; the target robot crossing bumps into it",
    2: "it explores the corridors round the table",
    3: "map built by its own SLAM, then the four corners patrolled through move_base",
    4: "the target with a face enters: stop, alarm, follow, patrol resumes",
    5: "an operator selects the target, drives by hand, releases",
}
LEVEL0_START = [5.0, 1.2, 0.0]   # in the ping-pong room with 4.5 m free behind: room to back away into


@dataclass(frozen=True)
class Plan:
    """How long each run is: the full experiment (make demo) or the short form (the test of every CI run)."""

    ros_duration: float      # simulated s of each ROS run (level 3: 1.5 times, to see a lap)
    rate: float              # simulated s per wall s on the ROS graph
    local_duration: float    # simulated s of each in-process run
    map_duration: float      # simulated s of map building before level 3


FULL = Plan(ros_duration=60.0, rate=3.0, local_duration=600.0, map_duration=240.0)
QUICK = Plan(ros_duration=15.0, rate=3.0, local_duration=60.0, map_duration=240.0)  # a shorter drive leaves corners unmapped


def network_levels() -> int:
    """How many levels robots/patrol/patrol.yaml has (levels 4 and 5 are added by their own issues)."""
    return len(yaml.safe_load(ROBOTS["patrol"].read_text())["levels"])


def scene_world(level: int, folder: Path) -> Path:
    """The ping-pong world for `level`: as shipped, but for level 0 the robot starts with room behind it (the
    person walks at it from the front)."""
    world = world_path("pingpong")
    if level != 0:
        return world
    data = yaml.safe_load(world.read_text())
    data["map"] = str((world.parent / data["map"]).resolve())
    _absolute_files(data, world.parent)
    data["robots"][0]["start"] = list(LEVEL0_START)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene_world.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _absolute_files(data, base: Path) -> None:
    """Every ``file`` entry (pictures) made absolute, so the copy of the world finds them."""
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else []
    for key, value in list(items):
        if key == "file" and isinstance(value, str) and not Path(value).is_absolute():
            data[key] = str((base / value).resolve())
        elif isinstance(value, (dict, list)):
            _absolute_files(value, base)


def run_level(level: int, out: Path, plan: Plan, seed: int) -> tuple[dict, dict]:
    """One level: on the ROS graph (a `subsumption run patrol` process), then in-process. Returns both metrics."""
    from .patrol import PatrolRun, built_map, execute

    folder = out / f"level{level}"
    world = scene_world(level, folder)
    nav_map = None
    if level >= 3:  # built once, in D/map, and shared by the levels that navigate
        nav_map = built_map(world, out, seed, plan.map_duration)
    duration = plan.ros_duration * (1.5 if level >= 3 else 1.0)
    command = [sys.executable, "-m", "subsumption.cli", "run", "patrol", "--level", str(level), "--world",
               str(world), "--duration", str(duration), "--seed", str(seed), "--runtime", "ros",
               "--rate", str(plan.rate), "--out", str(folder)]
    if nav_map is not None:
        command += ["--map", str(nav_map)]
    done = subprocess.run(command)
    if done.returncode != 0 or not (folder / "metrics.json").exists():
        raise RuntimeError(f"the ROS run of level {level} failed (exit {done.returncode}); see {folder / 'logs'}")
    ros = json.loads((folder / "metrics.json").read_text())
    local = execute(PatrolRun(level, world, folder / "local", plan.local_duration, seed, "local",
                              map_yaml=nav_map, progress=False)).metrics
    return ros, local


def figure_7(out: Path, levels: int) -> Path:
    """The paper's Fig. 7: one panel per level, the ROS runs' trajectories (goals and other agents drawn)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(18, 11))
    for level, ax in enumerate(axes.flat):
        ax.axis("off")
        caption = textwrap.fill(f"({'abcdef'[level]}) level {level}: {SCENES[level]}", 70)
        picture = out / f"level{level}" / "trajectory.png"
        if level < levels and picture.exists():
            ax.imshow(plt.imread(picture))
        else:
            ax.text(0.5, 0.5, f"level {level} is not in robots/patrol/patrol.yaml yet", ha="center", va="center",
                    fontsize=12, color="gray", transform=ax.transAxes)
        ax.set_title(caption, fontsize=10)
    fig.tight_layout()
    path = out / "fig7_trajectories.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def summary_table(rows: list[tuple[int, str, dict]]) -> str:
    head = ("| level | scene | runtime | simulated s | wall s | collisions | distance m | goals reached / sent | "
            "laps | alarms |")
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for level, runtime, m in rows:
        goals = f"{m.get('goals_reached', 0)} / {m.get('goals_sent', 0)}" if level >= 3 else "-"
        laps = str(m.get("laps", 0)) if level >= 3 else "-"
        lines.append(f"| {level} | {SCENES[level]} | {runtime} | {m['sim_time_s']:.0f} | {m['wall_time_s']:.1f} | "
                     f"{m['collisions']} | {m.get('distance_m', 0.0):.1f} | {goals} | {laps} | {m.get('alarms', 0)} |")
    return "\n".join(lines)


def main(out: Path, plan: Plan, seed: int = 1) -> int:
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    levels = network_levels()
    rows: list[tuple[int, str, dict]] = []
    for level in range(levels):
        print(f"[patrol {level + 1}/{levels}] level {level}: {SCENES[level]}", flush=True)
        try:
            ros, local = run_level(level, out, plan, seed)
        except RuntimeError as error:
            print(f"subsumption experiment: {error}", file=sys.stderr)
            return 1
        rows += [(level, f"ros {plan.rate:g}x", ros), (level, "local", local)]
        print(f"      ros: {ros['collisions']} collisions, {ros['wall_time_s']:.1f} s wall; local "
              f"{local['sim_time_s']:.0f} s simulated: {local['collisions']} collisions"
              + (f", {local['goals_reached']}/{local['goals_sent']} goals, {local['laps']} laps" if level >= 3 else ""),
              flush=True)
    figure = figure_7(out, levels)
    table = summary_table(rows)
    missing = [level for level in range(levels, 6)]
    note = (f"\nLevels {', '.join(map(str, missing))} are not in robots/patrol/patrol.yaml yet.\n" if missing else "")
    (out / "summary.md").write_text(table + "\n" + note)
    print(table + note)
    print(f"patrol experiment written to {out} ({figure.name}, summary.md, level0..level{levels - 1}/) in "
          f"{time.monotonic() - started:.0f} s", flush=True)
    return 0


def register_experiment(commands: argparse._SubParsersAction) -> None:
    cmd = commands.add_parser(
        "experiment", help="run one of the paper's experiments end to end (patrol: its Fig. 7, level by level)",
        description="The patrol robot's levels in the ping-pong room, each on the real ROS graph and in-process; "
                    "writes fig7_trajectories.png, summary.md and a folder per level.")
    cmd.add_argument("name", choices=("patrol",), help="which experiment: patrol (the security robot, Fig. 7)")
    cmd.add_argument("--out", type=Path, required=True, help="folder for the figure, the table and the runs")
    cmd.add_argument("--quick", action="store_true",
                     help=f"the short form (ROS runs of {QUICK.ros_duration:g} s, in-process runs of "
                          f"{QUICK.local_duration:g} s), as the test of every CI run uses it")
    cmd.add_argument("--seed", type=int, default=1, help="random seed of every run (default 1)")
    cmd.set_defaults(func=lambda args: main(args.out, QUICK if args.quick else FULL, args.seed))
