"""Navigation (move_base's job) against the targets of issue 9, printed as tables: the same runs on every
shipped map, the office world and generated maps none of the parameters were tuned on, in the in-process
runtime, localizing with AMCL (never the truth), 2% odometry noise.

    .venv/bin/python -m bench.navigation [--goals 50] [--seed 1] [--jobs 2] [--only room,office] [--skip-plan]
                                      [--plan-repeats 20] [--skip-goals] [--skip-explore] [--out DIR]

    just the planning time:  .venv/bin/python -m bench.navigation --skip-goals --skip-explore --plan-repeats 50

1. Goals: per world, N random reachable goals one after another (``subsumption navigate``'s run): goals
   reached (SUCCEEDED), reached truly (the true pose within the tolerance + 0.1 m), collisions, mean and max
   path_ratio (travelled over the shortest collision-free length), AMCL's RMS error, and speed.
   Targets: >= 98% reached, 0 collisions, mean path_ratio <= 1.2; with people walking, 0 collisions still.
2. Global planning time on 1000 x 1000 maps (50 x 50 m at 5 cm; generated hallways and clutter): A* plus
   shortening from random reachable starts to random reachable goals (``--plan-repeats N``), wall-clock and CPU
   ms of the same plans side by side (median, worst, 90th percentile), each pair planned twice in turn: with
   the octile heuristic alone and with the map's landmarks (whose one-off build is timed apart), and the
   costmap update with a scan's obstacles. Target: <= 50 ms. Measured before any goal or exploration run
   starts (so none of this bench's own jobs compete with it), with ``uptime``'s load averages before and
   after and the wall / CPU ratio: a ratio near 1 means the plans had a core to themselves, and the wall
   figures are a quiet machine's.
3. Frontier exploration (``subsumption map --explore frontier``): time until nothing reachable is left
   unknown, the share of the reachable free space mapped free, collisions, ATE.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml


from subsim import world_path
from subsim.maps.generate import clutter, hallways, write_layout

from .tables import markdown_table

SHIPPED = ("room", "corridors", "sparse")
GENERATED = (("clutter", 31), ("hallways", 47))  # seeds the shipped maps and the tests do not use


def office_world(folder: Path, people: bool) -> Path:
    """The office world with a laser robot in place of the camera-only TurtleBot (navigation needs a scan),
    with or without its two people walking."""
    data = yaml.safe_load(world_path("office").read_text())
    data["map"] = str((world_path("office").parent / data["map"]).resolve())
    data.pop("scene", None)
    robot = data["robots"][0]
    robot.pop("kind", None)
    if not people:
        data.pop("agents", None)
    for agent in data.get("agents", []):
        agent.pop("picture", None)  # a camera's business (its path is relative to the shipped world's folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"office_{'people' if people else 'empty'}_world.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def generated_world(kind: str, seed: int, folder: Path) -> Path:
    layout = clutter(seed=seed, size=12.0, density=0.08) if kind == "clutter" else \
        hallways(seed=seed, width=20.0, height=14.0)
    write_layout(layout, folder, f"{kind}_{seed}")
    return folder / f"{kind}_{seed}_world.yaml"


def generated_people_world(kind: str, seed: int, folder: Path) -> Path:
    """A generated world with people in it, which no parameter was tuned on: a person pacing the longest straight
    stretch of free floor each way (one along x, one along y; 0.8 m/s, the room's), and a robot wandering."""
    from scipy.ndimage import distance_transform_edt

    world = generated_world(kind, seed, folder)
    data = yaml.safe_load(world.read_text())
    from subsim.mapio import load_map

    grid = load_map(folder / data["map"])
    clearance = distance_transform_edt(grid.occupancy == 0) * grid.resolution
    start = data["robots"][0]["start"]
    agents = []
    free = clearance >= 0.6  # room for a person (0.25 m) with a robot passing beside
    for axis, name in ((1, "walker_x"), (0, "walker_y")):
        best = (0, 0, 0)  # length, line, first cell
        lines = free if axis == 1 else free.T
        for i, line in enumerate(lines):
            padded = np.concatenate(([0], line.astype(int), [0]))
            edges = np.flatnonzero(np.diff(padded))
            for a, b in zip(edges[::2], edges[1::2]):
                if b - a > best[0]:
                    best = (b - a, i, a)
        length, i, a = best
        ends = [a + 6, a + min(length, 200) - 7]  # 0.3 m in from its ends, at most 10 m long
        cells = [(i, c) for c in ends] if axis == 1 else [(c, i) for c in ends]
        waypoints = [[round(float(v), 3) for v in grid.centre_of(r, c)] for r, c in cells]
        agents.append({"name": name, "kind": "person", "motion": "waypoints", "waypoints": waypoints, "speed": 0.8})
        # the next one's beat 1 m clear of this one's: two walkers waiting for each other would wait for ever
        band = int(round(1.0 / grid.resolution))
        if axis == 1:
            free[max(i - band, 0): i + band + 1, ends[0] - band: ends[1] + band + 1] = False
        else:
            free[ends[0] - band: ends[1] + band + 1, max(i - band, 0): i + band + 1] = False
    rows, cols = np.nonzero(clearance >= 0.6)
    far = np.argmax(np.hypot(*(np.column_stack(grid.centre_of(rows, cols)) - np.array(start[:2])).T))
    rover = [round(float(v), 3) for v in grid.centre_of(int(rows[far]), int(cols[far]))] + [0.0]
    agents.append({"name": "rover", "kind": "robot", "motion": "wander", "start": rover, "speed": 0.4})
    data["agents"] = agents
    path = folder / f"{kind}_{seed}_people_world.yaml"
    path.write_text(f"# {kind} {seed} with two people pacing its longest stretches and a robot wandering\n"
                    + yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
    return path


def worlds(out: Path) -> list[tuple[str, Path, bool]]:
    """(name, world file, people walking)."""
    folder = out / "worlds"
    found = [(name, world_path(name), False) for name in SHIPPED]
    found.append(("office", office_world(folder, people=False), False))
    found += [(f"{kind} {seed}", generated_world(kind, seed, folder), False) for kind, seed in GENERATED]
    found.append(("room_people", world_path("room_people"), True))  # a person walking, a robot wandering
    found.append(("office_people", office_world(folder, people=True), True))  # two people walking
    found.append(("hallways_people 47", generated_people_world("hallways", 47, folder), True))
    return found


def goal_job(job: tuple) -> dict:
    from experiments.navigation import navigate

    name, world, people, goals, seed, out = job
    folder = Path(out) / f"nav_{name.replace(' ', '_')}"
    return navigate(Path(world), None, goals, seed, "local", folder, extra={"name": name, "people": people})


def explore_job(job: tuple) -> dict:
    from experiments.mapping import prepare_world, run_local, score, write_outputs

    name, world, duration, seed, out = job
    folder = Path(out) / f"explore_{name.replace(' ', '_')}"
    prepared, start = prepare_world(Path(world), folder, "laser", 0.02)
    recorder, wall, _ = run_local(prepared, start, duration, seed, "frontier")
    result = score(recorder, prepared, wall)
    extra = {"name": name, "reachable_mapped": round(reachable_mapped(result, start), 4)}
    write_outputs(result, folder, f"frontier exploration, {name}", extra)
    return {**extra, **result.metrics}


def reachable_mapped(result, start: list) -> float:
    """Of the true free cells the robot's centre can reach from the start (0.2 m from walls), the share the
    built map has free: what "nothing reachable left unknown" means, measured on the truth."""
    return reachable_share(result.truth_map, result.built, start)


def reachable_share(truth, built, start: list) -> float:
    from experiments.navigation import reachable_free

    rows, cols = np.nonzero(reachable_free(truth, (start[0], start[1]), 0.2))
    xy = np.column_stack((truth.origin[0] + (cols + 0.5) * truth.resolution,
                          truth.origin[1] + (rows + 0.5) * truth.resolution))
    br = np.floor((xy[:, 1] - built.origin[1]) / built.resolution).astype(int)
    bc = np.floor((xy[:, 0] - built.origin[0]) / built.resolution).astype(int)
    inside = (br >= 0) & (br < built.shape[0]) & (bc >= 0) & (bc < built.shape[1])
    free = np.zeros(len(xy), dtype=bool)
    free[inside] = built.occupancy[br[inside], bc[inside]] == 0
    return float(free.mean()) if len(free) else float("nan")


def planning_times(repeats: int, seed: int) -> list[list]:
    """Per map two rows on the same random pairs, timed alternately: A* with the octile heuristic alone
    ("octile", as before landmarks) and with the map's landmarks built ("landmarks", what the planner uses once
    it has planned on a map enough; their build is timed on its own)."""
    from navigation.costmap import INSCRIBED, Costmap, InflationParams
    from navigation.planner import LANDMARKS, PlannerParams, plan, warm_up
    from subsumption.mapfile import OccupancyMap

    from experiments.navigation import reachable_free

    rows = []
    variants = (("octile", PlannerParams(landmarks=0)), ("landmarks", PlannerParams()))
    for kind, layout in (("hallways", hallways(seed=seed, width=50.0, height=50.0)),
                         ("clutter", clutter(seed=seed, size=50.0, density=0.08))):
        grid = OccupancyMap(layout.grid, 0.05, (0.0, 0.0), kind)
        costmaps = {name: Costmap(grid, InflationParams()) for name, _ in variants}
        free_r, free_c = np.nonzero(reachable_free(grid, layout.start[:2], 0.35))
        rng = np.random.default_rng(seed)
        params = dict(variants)["landmarks"]
        static = costmaps["landmarks"].static_costs
        warm_up(params)  # every kernel compiled first
        c0 = time.process_time()
        seed_cell = int(free_r[0]) * grid.shape[1] + int(free_c[0])  # as plan() would: a start cell
        LANDMARKS.prepare(costmaps["landmarks"], static, params.cost_factor, INSCRIBED, params.landmarks, seed_cell)
        build_ms = 1000 * (time.process_time() - c0)
        for name, p in variants:
            plan(costmaps[name], grid.centre_of(int(free_r[0]), int(free_c[0])),
                 grid.centre_of(int(free_r[-1]), int(free_c[-1])), p)
        times = {name: ([], [], []) for name, _ in variants}  # wall, cpu, lengths
        for _ in range(repeats):
            i, j = rng.integers(len(free_r), size=2)
            a, b = grid.centre_of(int(free_r[i]), int(free_c[i])), grid.centre_of(int(free_r[j]), int(free_c[j]))
            for name, p in variants:
                t0, c0 = time.perf_counter(), time.process_time()
                result = plan(costmaps[name], a, b, p)
                times[name][0].append(1000 * (time.perf_counter() - t0))
                times[name][1].append(1000 * (time.process_time() - c0))
                times[name][2].append(result.length())
        # a scan's obstacles: 300 points within 3 m of a free cell, inflated into the costmap
        costmap = costmaps["landmarks"]
        centre = np.array(grid.centre_of(int(free_r[len(free_r) // 2]), int(free_c[len(free_c) // 2])))
        update = []
        for _ in range(repeats):
            angles = rng.uniform(-np.pi, np.pi, 300)
            points = centre + rng.uniform(0.5, 3.0, (300, 1)) * np.column_stack((np.cos(angles), np.sin(angles)))
            t0 = time.process_time()
            costmap.set_scan_points(points)
            _ = costmap.costs
            update.append(1000 * (time.process_time() - t0))
        for name, _ in variants:
            wall, cpu, lengths = (np.array(v) for v in times[name])
            rows.append([f"{kind} 50 x 50 m, seed {seed}", name, f"{grid.shape[1]} x {grid.shape[0]}", repeats,
                         f"{np.mean(lengths):.1f}", f"{np.median(wall):.1f}", f"{np.median(cpu):.1f}",
                         f"{wall.max():.1f}", f"{cpu.max():.1f}", f"{np.percentile(wall, 90):.1f}",
                         f"{np.percentile(cpu, 90):.1f}", f"{wall.sum() / max(cpu.sum(), 1e-9):.2f}",
                         f"{build_ms:.0f}" if name == "landmarks" else "-",
                         f"{np.median(update):.1f}", "yes" if np.median(wall) <= 50 else "NO",
                         "yes" if wall.max() <= 50 else "NO"])
    return rows


PLAN_HEADER = ["map", "heuristic", "cells", "plans", "mean length m", "wall ms median", "CPU ms median",
               "wall ms worst", "CPU ms worst", "wall ms p90", "CPU ms p90", "wall / CPU", "landmark build CPU ms",
               "costmap update ms",
               "<= 50 ms (wall median)", "<= 50 ms (wall worst)"]


def uptime() -> str:
    """``uptime``'s line (load averages over 1, 5 and 15 min), or os.getloadavg's figures without the command."""
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, timeout=5, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def measure_plans(repeats: int, seed: int) -> dict:
    """Table 2's rows with the machine's load around them (uptime before and after)."""
    before = uptime()
    rows = planning_times(repeats, seed)
    return {"rows": rows, "uptime_before": before, "uptime_after": uptime(), "cores": os.cpu_count()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--goals", type=int, default=50, help="goals per world (default 50)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2, help="runs in parallel (default 2)")
    parser.add_argument("--only", default="", help="comma-separated world names (default: all): room, corridors, "
                                                   "sparse, office, 'clutter 31', 'hallways 47', room_people, "
                                                   "office_people, 'hallways_people 47'")
    parser.add_argument("--skip-plan", action="store_true", help="leave out table 2")
    parser.add_argument("--plan-repeats", type=int, default=20, metavar="N",
                        help="plans timed per map in table 2 (default 20)")
    parser.add_argument("--skip-explore", action="store_true", help="leave out table 3")
    parser.add_argument("--skip-goals", action="store_true", help="leave out table 1")
    parser.add_argument("--explore-duration", type=float, default=600.0, help="simulated s at most per exploration")
    parser.add_argument("--out", type=Path, default=Path("out/bench_navigation"), help="pictures and metrics here")
    parser.add_argument("--report", type=Path, nargs="+", metavar="DIR",
                        help="run nothing: print tables 1 and 3 from the metrics.json files earlier runs left in "
                             "these --out folders")
    args = parser.parse_args()
    if args.report:
        results = [_named(p, "nav_") for d in args.report for p in sorted(d.glob("nav_*/metrics.json"))]
        explores = [_named(p, "explore_") for d in args.report for p in sorted(d.glob("explore_*/metrics.json"))]
        print_tables(results, None, explores, results[0]["goals"] if results else 0, args.seed,
                     args.explore_duration)
        return 0
    out = args.out.resolve()
    every = worlds(out)
    chosen = every if not args.only else [w for name in args.only.split(",") for w in every if w[0] == name]
    goal_jobs = [] if args.skip_goals else [(n, str(w), p, args.goals, args.seed, str(out)) for n, w, p in chosen]
    explore_jobs = [] if args.skip_explore else [
        (n, str(w), args.explore_duration, args.seed, str(out)) for n, w, p in chosen if not p]
    if args.plan_repeats < 1:
        parser.error(f"--plan-repeats must be >= 1, got {args.plan_repeats}")
    # the plans are timed first, alone: this bench's own runs would otherwise share the cores with them
    plans = None if args.skip_plan else measure_plans(args.plan_repeats, args.seed)
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        goal_futures = [pool.submit(goal_job, j) for j in goal_jobs]
        explore_futures = [pool.submit(explore_job, j) for j in explore_jobs]
        results = [f.result() for f in goal_futures]
        explores = [f.result() for f in explore_futures]
    print_tables(results, plans, explores, args.goals, args.seed, args.explore_duration)
    return 0


def _named(path: Path, prefix: str) -> dict:
    """A run's metrics.json, with its world's name (from the folder when the file has none)."""
    metrics = json.loads(path.read_text())
    metrics.setdefault("name", path.parent.name[len(prefix):].replace("_", " ") if "people" not in path.parent.name
                       else path.parent.name[len(prefix):])
    metrics.setdefault("people", "people" in metrics["name"])
    folder = path.parent
    if prefix == "explore_" and "reachable_mapped" not in metrics and (folder / "map.yaml").exists():
        from subsim.mapio import load_map
        from subsumption.mapfile import read_map_file

        world = yaml.safe_load((folder / "world.yaml").read_text())
        metrics["reachable_mapped"] = reachable_share(load_map(world["map"]), read_map_file(folder / "map.yaml"),
                                                      world["robots"][0]["start"])
    return metrics


def print_tables(results: list[dict], plans: dict | None, explores: list[dict], goals: int, seed: int,
                 explore_duration: float) -> None:
    if results:
        print(f"\n1. Goals: {goals} random reachable goals per world, one after another, seed {seed}, AMCL "
              "localization, 2% odometry noise, in-process\n")
        rows = []
        for m in results:
            share = m["reached"] / m["goals"]
            met = share >= 0.98 and m["collisions"] == 0 and (m["path_ratio"] or 9) <= 1.2
            if m["people"]:
                met = m["collisions"] == 0
            rows.append([m["name"], f"{m['reached']}/{m['goals']}", m["reached_truly"], m["aborted"], m["collisions"],
                         m["path_ratio"], m["path_ratio_max"], f"{m['loc_rmse_m']:.3f}",
                         f"{m['sim_time_s']:.0f}", f"{m['sim_time_s'] / m['wall_time_s']:.1f}",
                         f"{m['sim_time_s'] / m['cpu_time_s']:.1f}", "yes" if met else "NO"])
        print(markdown_table(["world", "reached", "truly", "aborted", "collisions", "path ratio", "max ratio",
                              "AMCL RMS m", "sim s", "x real time (wall)", "x real time (CPU)", "targets met"], rows))
        print("\n(with people walking the target is zero collisions; reaching every goal is not asked)")
    if plans:
        print("\n2. Global plan on a 1000 x 1000 map (A* on the inflated costmap + line-of-sight shortening), "
              "random reachable pairs, timed alone before any other run of this bench (target: 50 ms). Wall time "
              "is what this process got of the machine; CPU time what a plan costs a core of its own: with wall / "
              "CPU near 1 the wall figures are a quiet machine's.\n")
        print(f"uptime before: {plans['uptime_before']}")
        print(f"uptime after:  {plans['uptime_after']}   ({plans['cores']} cores)\n")
        print(markdown_table(PLAN_HEADER, plans["rows"]))
    if explores:
        print(f"\n3. Frontier exploration (SLAM + move_base + explore), laser, at most {explore_duration:.0f} s "
              "simulated\n")
        rows = [[m["name"], "yes" if m.get("explore_done") else "NO", f"{m['sim_time_s']:.0f}",
                 f"{m['distance_m']:.0f}",
                 m["collisions"], f"{m['ate_m']:.3f}", f"{m['free_mapped_free']:.1%}",
                 f"{m['walls_within_cell']:.1%}", f"{m.get('reachable_mapped', float('nan')):.1%}"]
                for m in explores]
        print(markdown_table(["world", "done", "sim s", "driven m", "collisions", "ATE m", "free seen -> free",
                              "walls within 1 cell", "reachable free mapped"], rows))


if __name__ == "__main__":
    sys.exit(main())
