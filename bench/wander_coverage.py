"""The paper's comparison as numbers: levels 1 and 2 of the wander robot on the shipped maps and on generated
buildings, 10 simulated minutes, 5 seeds each, in the in-process runtime: collisions, distance and coverage
(free area within 1 m of the path), with the level-2 / level-1 coverage ratio per map (bar: at least 1.5) and
level 2's share of the office's free area (bar: at least 60%).

    .venv/bin/python -m bench.wander_coverage [--seeds 5] [--first-seed 1] [--duration 600] [--maps office,clutter]
                                           [--param MODULE.NAME=VALUE ...] [--figures DIR]

Maps: the shipped ``corridors`` and ``sparse`` (the same map for every seed), and generated ones, a new map for
every seed (the run's seed is the map's seed, see subsim/maps/generate.py): ``office`` (20 m x 12 m, four rooms
off a 2 m corridor, doorways 0.9-1.2 m), ``hallways`` (30 m x 20 m of corridors with junctions), and 15 m squares
of clutter at three densities, ``clutter-4``, ``clutter-8`` and ``clutter-12`` (% of the floor under boxes).

--param changes a module's parameter at both levels, e.g. `--param wander.spread=1.0` (a persistent walk instead
of Brooks' aimless wander), to see what the ratio owes to it. --figures draws, per map, the first seed's
trajectories of both levels side by side (the paper's Fig. 6) into DIR/MAP.png.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import yaml


from experiments.runner import RunSpec, run_local
from subsim import world_path
from subsim.maps import generate

GENERATED = {
    "office": generate.office,
    "hallways": generate.hallways,
    "clutter-4": partial(generate.clutter, density=0.04),
    "clutter-8": partial(generate.clutter, density=0.08),
    "clutter-12": partial(generate.clutter, density=0.12),
}
MAPS = ("corridors", "sparse", *GENERATED)


def world_of(name: str, seed: int, folder: Path) -> Path:
    """The world file of a shipped map, or of the generated map `name` drawn with `seed` (written once)."""
    if name not in GENERATED:
        return world_path(name)
    world = folder / f"{name}_seed{seed}_world.yaml"
    if not world.exists():
        generate.write_layout(GENERATED[name](seed=seed), folder, f"{name}_seed{seed}")
    return world


def one(job: tuple[str, int, int, float, dict, str]) -> tuple[dict, list]:
    """One run; its metrics gain `cpu_time_s`, the CPU seconds this process spent running it (the simulator and
    the network run in it; from where `wall_time_s` starts, after the network is built, to the end), which unlike
    wall time does not grow when other work shares the machine."""
    name, level, seed, duration, params, folder = job
    world = world_of(name, seed, Path(folder))
    result = run_local(RunSpec("wander", level, world, duration, seed=seed, params=params,
                               observe=lambda _node: time.process_time()))  # called just before the run starts
    return dict(result.metrics, cpu_time_s=time.process_time() - result.observed), result.trajectory


def override(text: str) -> tuple[str, object]:
    """MODULE.NAME=VALUE, the value read as YAML (1.0 a float, 10 an int, true a bool)."""
    key, sep, value = text.partition("=")
    if not sep or "." not in key:
        raise argparse.ArgumentTypeError(f"expected MODULE.NAME=VALUE, got {text!r}")
    return key, yaml.safe_load(value)


def map_list(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in MAPS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"unknown map {unknown[0] if unknown else text!r} (known: {', '.join(MAPS)})")
    return names


def figure(name: str, seed: int, folder: Path, trajectories: dict[int, list], out: Path) -> None:
    """Both levels' paths on one map, side by side, as the paper's Fig. 6 shows them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from experiments.runner import map_of
    from subsim.mapio import load_map

    grid = load_map(map_of(world_of(name, seed, folder)))
    aspect = grid.height_m / grid.width_m
    fig, axes = plt.subplots(1, 2, figsize=(12, 6 * aspect + 0.8))
    for ax, (level, xy) in zip(axes, sorted(trajectories.items())):
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        grid.draw(ax)
        ax.plot(xy[:, 0], xy[:, 1], "-", lw=1.0, color="tab:blue" if level == 1 else "tab:orange")
        ax.plot(xy[0, 0], xy[0, 1], "o", ms=8, mfc="none", mew=2, color="k")
        ax.set_title(f"{name}, level {level}, seed {seed}")
        ax.set_aspect("equal")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=5, help="number of seeds per map and level")
    parser.add_argument("--first-seed", type=int, default=1, help="first seed (runs use first..first+seeds-1)")
    parser.add_argument("--duration", type=float, default=600.0, help="simulated seconds per run")
    parser.add_argument("--maps", type=map_list, default=list(MAPS), help=f"comma-separated, of: {', '.join(MAPS)}")
    parser.add_argument("--levels", default="1,2", help="comma-separated levels to run (default 1,2)")
    parser.add_argument("--param", type=override, action="append", default=[], metavar="MODULE.NAME=VALUE",
                        help="a module parameter for every run, e.g. wander.spread=1.0 (repeatable)")
    parser.add_argument("--figures", type=Path, default=None, help="draw Fig. 6-style trajectories into this folder")
    parser.add_argument("--jobs", type=int, default=2, help="runs in parallel")
    args = parser.parse_args()
    params = dict(args.param)
    levels = [int(v) for v in args.levels.split(",")]
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    with tempfile.TemporaryDirectory(prefix="wander_coverage_") as folder:
        for name in args.maps:  # generate every map once, before the workers share the folder
            for seed in seeds:
                world_of(name, seed, Path(folder))
        jobs = [(name, level, seed, args.duration, params, folder) for name in args.maps for level in levels
                for seed in seeds]
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            results = dict(zip([job[:3] for job in jobs], pool.map(one, jobs)))
        if args.figures:
            for name in args.maps:
                figure(name, seeds.start, Path(folder), {level: results[(name, level, seeds.start)][1]
                                                         for level in levels}, args.figures / f"{name}.png")
    print(f"Wander robot, {args.duration / 60:.0f} simulated minutes, seeds {seeds.start}..{seeds.stop - 1}, "
          f"local runtime{'; ' + ', '.join(f'{k}={v}' for k, v in params.items()) if params else ''}")
    print("| map | level | collisions (all seeds) | distance m (mean) | coverage m² (mean ± sd) | free m² (mean) "
          "| covered % (mean) | CPU s (max) | wall s (max) |")
    print("|---|---|---|---|---|---|---|---|---|")
    coverage: dict[tuple[str, int], float] = {}
    share: dict[tuple[str, int], float] = {}
    for name in args.maps:
        for level in levels:
            runs = [results[(name, level, seed)][0] for seed in seeds]
            cov = [r["coverage_m2"] for r in runs]
            coverage[(name, level)] = statistics.mean(cov)
            share[(name, level)] = statistics.mean(r["coverage_m2"] / r["free_area_m2"] for r in runs)
            print(f"| {name} | {level} | {sum(r['collisions'] for r in runs)} | "
                  f"{statistics.mean(r['distance_m'] for r in runs):.0f} | {statistics.mean(cov):.0f} ± "
                  f"{statistics.pstdev(cov):.0f} | {statistics.mean(r['free_area_m2'] for r in runs):.0f} | "
                  f"{100 * share[(name, level)]:.0f} | {max(r['cpu_time_s'] for r in runs):.1f} | "
                  f"{max(r['wall_time_s'] for r in runs):.1f} |")
    print()
    if 1 in levels and 2 in levels:
        for name in args.maps:
            ratio = coverage[(name, 2)] / max(coverage[(name, 1)], 1e-9)
            print(f"{name}: level 2 / level 1 coverage = {ratio:.2f} (bar 1.5: {'met' if ratio >= 1.5 else 'NOT met'})")
    if 2 in levels and "office" in args.maps:
        print(f"office: level 2 covers {100 * share[('office', 2)]:.0f}% of the free area "
              f"(bar 60%: {'met' if share[('office', 2)] >= 0.6 else 'NOT met'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
