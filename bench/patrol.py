"""The patrol robot's level 3 against issue 10's targets, printed as a table: 10 simulated minutes of patrol
in the ping-pong room and in the office world (four goals in four rooms), in-process and on the ROS graph, each
on a map the project's own map building made beforehand.

    .venv/bin/python -m bench.patrol [--worlds pingpong,office] [--seeds 1,2,3] [--duration 600] [--jobs 1]
                                  [--ros-seeds 1] [--rate 3] [--map-limit 1800] [--out out/bench_patrol]

1. The map, once per world: ``subsumption map --sensor depth --explore frontier`` (the TurtleBot's 58-degree
   depth scan, move_base driving to frontiers until nothing reachable is left unknown, at most --map-limit
   simulated s) on the world with its people left out (one maps a building when nobody walks through it).
   Printed: how long exploring took (simulated and wall s), whether explore said done, collisions, ATE, the
   share of the seen free space mapped free. Reused from --out when it is there (delete it to rebuild).
2. The patrol: ``subsumption run patrol --level 3 --map M [--goals G]`` per world and seed, in-process, then on
   the ROS graph (one process per module) for --ros-seeds at --rate. In-process runs go --jobs at a time; ROS
   runs one at a time after them (a ROS run keeps its rate only with the CPU it needs). Ping-pong: the default goals (the room's
   four corners); office: robots/patrol/goals/office.yaml (one goal in each of four rooms).
   Printed per run: goals reached / sent, whether every goal was reached in order, laps, failed goals,
   collisions, simulated and wall s. Target: every goal reached in order, laps counted, zero collisions.

Every run's folder keeps its metrics.json, trajectory.png and log (``run.log``).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from subsim.world import WorldDocument

from .tables import markdown_table

ROOT = Path(__file__).resolve().parent.parent

WORLDS = {  # name: (world file, goals file or None for the default corners)
    "pingpong": (ROOT / "subsim/maps/pingpong_world.yaml", None),
    "office": (ROOT / "subsim/maps/office_world.yaml", ROOT / "robots/patrol/goals/office.yaml"),
}
MAP_SEED = 1


def subsumption(args: list[str], log: Path) -> tuple[int, float]:
    """Run the project's command (its exit code and wall seconds), its output into `log`."""
    log.parent.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    with log.open("w") as out:
        code = subprocess.call([sys.executable, "-m", "subsumption.cli", *args], cwd=ROOT, stdout=out,
                               stderr=subprocess.STDOUT)
    return code, time.monotonic() - started


def empty_world(world: Path, folder: Path) -> Path:
    """The world with its people and other moving agents left out, its file references made absolute."""
    doc = WorldDocument(world)
    doc.data["agents"] = []
    return doc.write(folder / "empty_world.yaml")


def build_map(name: str, out: Path, limit: float) -> tuple[Path, list]:
    folder = out / name / "map"
    if not (folder / "map.yaml").exists():
        print(f"{name}: building the map (frontier exploration, depth scan, at most {limit:.0f} s)", flush=True)
        world = empty_world(WORLDS[name][0], folder)
        code, _ = subsumption(["map", "--world", str(world), "--sensor", "depth", "--explore", "frontier",
                               "--duration", str(limit), "--seed", str(MAP_SEED), "--out", str(folder)],
                              folder / "run.log")
        if code != 0:
            raise SystemExit(f"bench.patrol: map building for {name} failed, see {folder / 'run.log'}")
    m = json.loads((folder / "metrics.json").read_text())
    return folder / "map.yaml", [name, MAP_SEED, f"{m['sim_time_s']:.0f}", f"{m['wall_time_s']:.0f}",
                                 m.get("explore_done"), m["collisions"], f"{m['ate_m'] * 100:.1f}",
                                 f"{m['free_mapped_free']:.1%}"]


def patrol(name: str, nav_map: Path, runtime: str, seed: int, args: argparse.Namespace) -> list:
    world, goals = WORLDS[name]
    folder = args.out / name / f"{runtime}_s{seed}"
    command = ["run", "patrol", "--level", "3", "--world", str(world), "--map", str(nav_map),
               "--duration", str(args.duration), "--seed", str(seed), "--runtime", runtime,
               "--rate", str(args.rate), "--out", str(folder)]
    if goals is not None:
        command += ["--goals", str(goals)]
    print(f"{name}: level 3, {runtime}, seed {seed}, {args.duration:.0f} s", flush=True)
    code, wall = subsumption(command, folder / "run.log")
    metrics = folder / "metrics.json"
    if not metrics.exists():
        return [name, runtime, seed, "-", "-", "-", "-", "-", "-", f"{wall:.0f}", f"exit {code}"]
    m = json.loads(metrics.read_text())
    return [name, runtime, seed, f"{m['goals_reached']}/{m['goals_sent']}", m["goals_in_order"], m["laps"],
            m["goals_failed"], m["collisions"], f"{m['sim_time_s']:.0f}", f"{m['wall_time_s']:.0f}",
            "" if code == 0 else f"exit {code}"]


def numbers(text: str) -> list[int]:
    return [int(v) for v in text.split(",") if v.strip()]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="pingpong,office", help="comma-separated, of " + ", ".join(WORLDS))
    parser.add_argument("--seeds", type=numbers, default=[1, 2, 3], help="in-process runs' seeds (default 1,2,3)")
    parser.add_argument("--ros-seeds", type=numbers, default=[1], help="ROS runs' seeds (default 1; '' for none)")
    parser.add_argument("--duration", type=float, default=600.0, help="simulated s of each patrol (default 600)")
    parser.add_argument("--rate", type=float, default=3.0, help="ROS runs: simulated s per wall s (default 3)")
    parser.add_argument("--map-limit", type=float, default=1800.0,
                        help="simulated s frontier exploration may take at most (default 1800)")
    parser.add_argument("--jobs", type=int, default=1, help="in-process runs at a time (default 1)")
    parser.add_argument("--out", type=Path, default=ROOT / "out/bench_patrol")
    args = parser.parse_args()
    args.out = args.out.resolve()
    names = [n.strip() for n in args.worlds.split(",") if n.strip()]
    unknown = [n for n in names if n not in WORLDS]
    if unknown:
        parser.error(f"--worlds: unknown {', '.join(unknown)} (known: {', '.join(WORLDS)})")
    maps, map_rows, rows = {}, [], []
    for name in names:
        maps[name], row = build_map(name, args.out, args.map_limit)
        map_rows.append(row)
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:  # each run is its own process
        rows += list(pool.map(lambda job: patrol(*job, args),
                              [(name, maps[name], "local", seed) for name in names for seed in args.seeds]))
    rows += [patrol(name, maps[name], "ros", seed, args) for name in names for seed in args.ros_seeds]
    print("\nMaps (frontier exploration with the depth scan, the world's people left out):\n")
    print(markdown_table(["world", "seed", "explored (sim s)", "wall s", "explore done", "collisions", "ATE cm",
                          "free mapped free"], map_rows))
    print(f"\nPatrol, level 3, {args.duration:.0f} simulated s (ROS at {args.rate:g}x):\n")
    print(markdown_table(["world", "runtime", "seed", "goals reached/sent", "in order", "laps", "failed",
                          "collisions", "sim s", "wall s", "note"], rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
