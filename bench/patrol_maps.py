"""The patrol's own map (issue 31): does every shipped intruder world start its patrol on the map it explores?

Without --map, ``subsumption run patrol --level 4`` first builds its map by frontier exploration
(experiments.patrol_map.explored_map: navigation.explore through move_base, SLAM with the depth scan, the room
empty, at most EXPLORE_BOUND simulated s) and refuses to start unless every goal lies in known free space with
room for the robot. Each run here is that preparation exactly (experiments.patrol.prepare, the world's own goals
file, or the room's corners where the world has none), for one world and seed, in-process; the patrol itself is
not run. The issue's target: seeds 1-10 of both ping-pong intruder worlds and the office start their patrol.

    .venv/bin/python -m bench.patrol_maps [--worlds pingpong,short,office] [--seeds 1-10] [--out DIR] [--jobs N]
        [--resume] [--existing]

Prints a row per run as it ends (started, or the PatrolMapIncomplete message; how exploration ended: finished,
robot stuck, cut at the bound; simulated and wall s; ATE; unknown floor next to known free floor; frontier goals
that failed with the robot not moved, and goals explore sent back the way the robot came) and the totals; writes
OUT/patrol_maps.json. Each run's map, metrics.json and map_vs_truth.png are in OUT/WORLD_SEED/map/, the modules'
log in OUT/WORLD_SEED/explore.log.
An office run is 35-55 s of wall time on a free core (all 30 runs: 8 minutes with --jobs 2); exits 1 when a run does
not start.
"""
from __future__ import annotations

import argparse
import json
import logging
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from .tables import markdown_table

ROOT = Path(__file__).resolve().parent.parent
WORLDS = ROOT / "experiments" / "worlds"
# name: (world, goals file or None for the room's corners, as `subsumption run patrol` takes them)
SCENES = {
    "pingpong": (WORLDS / "pingpong_intruder_world.yaml", None),
    "short": (WORLDS / "pingpong_intruder_short_world.yaml", WORLDS / "pingpong_intruder_short_goals.yaml"),
    "office": (WORLDS / "office_intruder_world.yaml", WORLDS / "office_intruder_goals.yaml"),
}


def seed_list(text: str) -> list[int]:
    """'1-10' or '3' or '1,4,7-9'."""
    out: list[int] = []
    for part in text.split(","):
        first, _, last = part.strip().partition("-")
        out += list(range(int(first), int(last or first) + 1))
    return out


def run_one(job: tuple) -> dict:
    """One world and seed: the patrol's preparation as `run patrol --level 4` without --map does it."""
    from experiments.patrol import PatrolRun, prepare
    from experiments.patrol_map import PatrolMapIncomplete, unknown_reachable_m2
    from subsim.mapio import load_map

    name, seed, out, resume = job
    world, goals = SCENES[name]
    folder = Path(out) / f"{name}_{seed}"
    if not resume and (folder / "map").exists():
        shutil.rmtree(folder / "map")
    folder.mkdir(parents=True, exist_ok=True)
    # the modules' log (explore's goals and why they ended, move_base's recoveries) to OUT/WORLD_SEED/explore.log
    handler = logging.FileHandler(folder / "explore.log", mode="a" if resume else "w")
    handler.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    logger = logging.getLogger("subsumption")
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    started = time.monotonic()  # wall clock: the bench's own figure
    error = None
    try:
        prepare(PatrolRun(level=4, world=world, out=folder, duration=100.0, seed=seed, goals_file=goals,
                          progress=False))
    except PatrolMapIncomplete as problem:
        error = str(problem)
    finally:
        logger.removeHandler(handler)
        handler.close()
    wall = time.monotonic() - started
    log_text = (folder / "explore.log").read_text()
    metrics_path = folder / "map" / "metrics.json"
    m = json.loads(metrics_path.read_text()) if metrics_path.exists() else {}
    ended = ("finished" if m.get("explore_done") else "robot stuck" if m.get("explore_stuck_at") else
             "cut at the bound" if "explore_done" in m else "?")
    map_yaml = folder / "map" / "map.yaml"
    unknown = unknown_reachable_m2(load_map(map_yaml)) if map_yaml.exists() else None
    return {"world": name, "seed": seed, "started": error is None, "error": error, "ended": ended,
            "sim_s": m.get("sim_time_s"), "map_wall_s": m.get("wall_time_s"), "job_wall_s": round(wall, 1),
            "ate_m": m.get("ate_m"), "unknown_reachable_m2": unknown, "collisions": m.get("collisions"),
            "stuck_at": m.get("explore_stuck_at"), "picture": str(folder / "map" / "map_vs_truth.png"),
            "still_failures": log_text.count("(the robot did not move meanwhile)"),
            "ways_back": log_text.count("back the way it came:")}


def row(r: dict) -> list:
    fmt = lambda v, f: "-" if v is None else format(v, f)  # noqa: E731
    return [r["world"], r["seed"], "yes" if r["started"] else "NO", r["ended"], fmt(r["sim_s"], ".0f"),
            fmt(r["map_wall_s"], ".0f"), fmt(r["ate_m"] and r["ate_m"] * 100, ".1f"),
            fmt(r["unknown_reachable_m2"], ".1f"), r["collisions"] if r["collisions"] is not None else "-",
            r["still_failures"], r["ways_back"]]


HEADER = ["world", "seed", "patrol starts", "exploration ended", "simulated s", "wall s", "ATE cm",
          "unknown reachable m²", "collisions", "goals failed, robot still", "goals back the way it came"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="pingpong,short,office", help="of " + ", ".join(SCENES))
    parser.add_argument("--seeds", default="1-10", help="e.g. 1-10 or 1,4 (default %(default)s)")
    parser.add_argument("--out", type=Path, default=Path("out/bench_patrol_maps"))
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel (default 1)")
    parser.add_argument("--resume", action="store_true", help="reuse a run's map already in OUT (default: explore "
                                                              "afresh)")
    parser.add_argument("--existing", action="store_true", help="only the runs whose map is already in OUT, reused "
                                                                "(no exploring): the table of what was run")
    args = parser.parse_args()
    worlds = [w.strip() for w in args.worlds.split(",") if w.strip()]
    unknown = [w for w in worlds if w not in SCENES]
    if unknown or not worlds:
        parser.error(f"--worlds {args.worlds!r}: expected names of {', '.join(SCENES)} separated by commas")
    try:
        seeds = seed_list(args.seeds)
    except ValueError:
        parser.error(f"--seeds {args.seeds!r}: expected e.g. 1-10 or 1,4")
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs}: expected 1 or more")
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(w, s, str(out), args.resume or args.existing) for w in worlds for s in seeds  # in the order asked
            if not args.existing or (out / f"{w}_{s}" / "map" / "metrics.json").exists()]
    print(f"{len(jobs)} runs ({', '.join(worlds)} x seeds {args.seeds}), {args.jobs} at a time; maps in {out}",
          flush=True)
    results = []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for future in as_completed([pool.submit(run_one, j) for j in jobs]):
            r = future.result()
            results.append(r)
            print(f"{r['world']} seed {r['seed']}: " + ("patrol starts" if r["started"] else r["error"]) +
                  f" [{r['ended']}, {r['sim_s']} s simulated, {r['job_wall_s']} s wall]", flush=True)
    results.sort(key=lambda r: (worlds.index(r["world"]), r["seed"]))
    (out / "patrol_maps.json").write_text(json.dumps(results, indent=1))
    print("\nThe patrol's own map: frontier exploration, depth scan, odometry noise 2%, in-process\n")
    print(markdown_table(HEADER, [row(r) for r in results]))
    failed = [r for r in results if not r["started"]]
    print(f"\n{len(results) - len(failed)}/{len(results)} start their patrol (target: all)")
    for r in failed:
        print(f"  {r['world']} seed {r['seed']}: {r['error']}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
