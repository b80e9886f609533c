"""Frontier exploration's look-around (``Explore.look_around``) measured on fresh runs: table 1's worlds of
``bench.mapping`` (room, corridors, sparse, the sparse generator's seeds 31 and 47), each sensor, frontier
exploration driving (SLAM + move_base + explore, in-process, 2% odometry noise), with the look-around and
without, side by side.

    nice -n 15 .venv/bin/python -m bench.look_around [--duration 300] [--seeds 1] [--jobs 1] [--sensors depth,laser]
                                                  [--only "generated 31,sparse"] [--generated 31,47] [--out DIR]
    frontier exploration alone, the depth scan (docs/navigation.md's narrow-scan table, "after"):
        .venv/bin/python -m bench.look_around --sensors depth --looks off --seeds 1,2,3 --generated 31,47,53,61 --only \
            "sparse,generated 31,generated 47,generated 53,generated 61"
    the tables again from runs made before:  .venv/bin/python -m bench.look_around --report DIR [DIR ...]

Per run: ATE, the map scores (seen free cells mapped free, seen walls within one cell), the share of the
reachable free space mapped free (on the truth, as in ``bench.navigation``'s table 3), whether exploration said
done and when, collisions, look-arounds made, and CPU x real time (this process: simulator, SLAM, move_base,
explore). Targets (issue 9): ATE <= 0.05 m laser / 0.10 m depth, free >= 95%, walls >= 95%, >= 20x real time.
"""
from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import yaml

from bench import mapping as mapping_bench
from bench import navigation as navigation_bench
from experiments.mapping import prepare_world, run_local, score, write_outputs
from subsim import world_path


def run_job(job: tuple) -> dict:
    name, world, sensor, look, duration, seed, out, params = job
    tag = "".join(f"_{k}-{v}" for k, v in params.items())
    folder = Path(out) / f"look_{name.replace(' ', '_')}_{sensor}_seed{seed}_{'on' if look else 'off'}{tag}"
    prepared, start = prepare_world(Path(world), folder, sensor, 0.02)
    recorder, wall, _ = run_local(prepared, start, duration, seed, "frontier",
                                  explore_params={**params, "look_around": look})
    result = score(recorder, prepared, wall)
    extra = {"name": name, "sensor": sensor, "look_around": look, "seed": seed, "explore_params": params,
             "reachable_mapped": round(navigation_bench.reachable_mapped(result, start), 4)}
    write_outputs(result, folder, f"frontier exploration, look-around {'on' if look else 'off'}, {name}, {sensor}: "
                                  f"ATE {result.metrics['ate_m'] * 100:.1f} cm, walls "
                                  f"{result.metrics['walls_within_cell']:.1%}", extra)
    return {**extra, **result.metrics}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=300.0, help="simulated s at most per run (default 300)")
    parser.add_argument("--seeds", default="1", help="comma-separated seeds (default 1): frontier runs are chaotic")
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel (default 1)")
    parser.add_argument("--sensors", default="depth,laser", help="comma-separated: depth, laser (default both)")
    parser.add_argument("--only", default="", help="comma-separated world names (default all): room, corridors, "
                                                   "sparse, generated 31, generated 47")
    parser.add_argument("--generated", default=",".join(map(str, mapping_bench.GENERATED_SEEDS)),
                        help="seeds of the sparse generator's worlds to include (default: bench.mapping's)")
    parser.add_argument("--out", type=Path, default=Path("out/bench_look_around"), help="maps and pictures here")
    parser.add_argument("--looks", default="on,off", help="look-around on, off or both (default on,off)")
    parser.add_argument("--explore-param", action="append", default=[], metavar="NAME=VALUE",
                        help="another Explore parameter for every run (e.g. look_around_spacing=4)")
    parser.add_argument("--report", type=Path, nargs="+", metavar="DIR",
                        help="print the tables of runs already made (their look_*/metrics.json) and run nothing")
    args = parser.parse_args()
    out = args.out.resolve()
    mapping = mapping_bench
    if args.report:
        runs = [json.loads(p.read_text()) for d in args.report for p in sorted(d.glob("look_*/metrics.json"))]
        print_tables(runs, mapping, args.duration)
        return 0
    try:
        generated = [int(v) for v in args.generated.split(",") if v.strip()]
    except ValueError:
        parser.error(f"--generated {args.generated!r}: expected seeds (integers) separated by commas")
    names = [*mapping.SHIPPED, *(f"generated {s}" for s in generated)]
    chosen = [n.strip() for n in args.only.split(",") if n.strip()] or names
    unknown = [n for n in chosen if n not in names]
    if unknown:
        parser.error(f"--only: unknown world(s) {unknown}; known: {names}")
    sensors = [s.strip() for s in args.sensors.split(",") if s.strip()]
    if not sensors or not set(sensors) <= {"depth", "laser"}:
        parser.error(f"--sensors {args.sensors!r}: expected depth and/or laser")

    def world_of(name: str) -> Path:
        if name.startswith("generated "):
            return mapping.generated_world(int(name.split()[1]), out / "worlds")
        return world_path(name)

    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    looks = [{"on": True, "off": False}[x.strip()] for x in args.looks.split(",") if x.strip()]
    params = {k: yaml.safe_load(v) for k, _, v in (item.partition("=") for item in args.explore_param)}
    jobs = [(n, str(world_of(n)), sensor, look, args.duration, seed, str(out), params)
            for sensor in sensors for n in chosen for seed in seeds for look in looks]
    runs = []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for m in pool.map(run_job, jobs):  # in order, each as it is there (a long bench shows progress)
            runs.append(m)
            print(f"  {m['name']}, {m['sensor']}, seed {m['seed']}, look-around {'on' if m['look_around'] else 'off'}: "
                  f"ATE {m['ate_m']:.3f} m, walls {m['walls_within_cell']:.1%}, free {m['free_mapped_free']:.1%}, "
                  f"reachable mapped {m['reachable_mapped']:.1%}, {m['collisions']} collisions", flush=True)
    print_tables(runs, mapping, args.duration)
    print(f"\nMaps and pictures: {out}/look_*/map_vs_truth.png")
    return 0


def print_tables(runs: list[dict], mapping, duration: float) -> None:
    """Every run, then per world and sensor the mean over the seeds with the look-around and without."""
    runs = sorted(runs, key=lambda m: (m["sensor"], m["name"], m["seed"], not m["look_around"]))
    print(f"\nFrontier exploration with and without the look-around, at most {duration:.0f} s simulated, "
          "2% odometry noise, in-process\n")
    rows = []
    for m in runs:
        met = (m["ate_m"] <= mapping.ATE_TARGET[m["sensor"]] and m["free_mapped_free"] >= 0.95
               and m["walls_within_cell"] >= 0.95 and m["sim_time_s"] / m["cpu_time_s"] >= 20)
        look = ("on" if m["look_around"] else "off") + "".join(f", {k} {v}"
                                                              for k, v in m.get("explore_params", {}).items())
        rows.append([m["name"], m["sensor"], m["seed"], look, m["collisions"],
                     f"{m['ate_m']:.3f}", f"{m['ate_yaw_deg']:.2f}", f"{m['free_mapped_free']:.1%}",
                     f"{m['walls_within_cell']:.1%}", f"{m['reachable_mapped']:.1%}",
                     "yes" if m.get("explore_done") else "NO", f"{m['sim_time_s']:.0f}", f"{m['distance_m']:.0f}",
                     f"{m['sim_time_s'] / m['cpu_time_s']:.0f}", mapping.yes(met)])
    print(mapping.table(["world", "sensor", "seed", "look-around", "collisions", "ATE m", "yaw RMS deg",
                         "free seen -> free",
                         "walls within 1 cell", "reachable free mapped", "done", "sim s", "driven m",
                         "x real time (CPU)", "map targets met"], rows))
    print("\nMeans over the seeds (look-around on / off)\n")
    rows = []
    for sensor, name in dict.fromkeys((m["sensor"], m["name"]) for m in runs):
        pair = [[m for m in runs if m["sensor"] == sensor and m["name"] == name and m["look_around"] == look]
                for look in (True, False)]
        if not all(pair):
            continue
        mean = lambda key, group: sum(float(m.get(key) or 0) for m in group) / len(group)  # noqa: E731
        cell = lambda key, fmt: " / ".join(format(mean(key, g), fmt) for g in pair)  # noqa: E731
        speed = " / ".join(f"{sum(m['sim_time_s'] for m in g) / sum(m['cpu_time_s'] for m in g):.0f}" for g in pair)
        rows.append([name, sensor, len(pair[0]), cell("collisions", ".1f"), cell("ate_m", ".3f"),
                     cell("free_mapped_free", ".1%"), cell("walls_within_cell", ".1%"), cell("reachable_mapped", ".1%"),
                     cell("sim_time_s", ".0f"), speed])
    print(mapping.table(["world", "sensor", "seeds", "collisions", "ATE m", "free seen -> free", "walls within 1 cell",
                         "reachable free mapped", "sim s", "x real time (CPU)"], rows))


if __name__ == "__main__":
    sys.exit(main())
