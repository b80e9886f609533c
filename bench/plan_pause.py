"""The longest single plan() on a fresh 1000 x 1000 map, the landmarks' build included: what move_base's control
loop waits for at most while it plans (its plans run in its own thread, between two control steps).

    .venv/bin/python -m bench.plan_pause [--plans 60] [--seed 1] [--period 0] [--foreground]

Per map (bench.navigation's generated hallways and clutter, 50 x 50 m at 5 cm), a fresh costmap is planned on
`--plans` times between random reachable pairs with the planner's defaults, as move_base plans (landmarks built
once the searches have cost as much: in a background thread, or with ``--foreground`` inside the plan that
crosses the line, as the in-process runtime does). Printed per map: the wall and CPU ms of the longest plan
(CPU: the planning thread's own, a background build's left out), which plan started the build and which was
the first to use the landmarks, the longest and the median plan while the build was under way, and the build's
own wall time. ``--period S`` starts a plan every S seconds (0: back to back, the
most contention with the build). ``--hold-gil`` compiles the build's Dijkstra without ``nogil``, to see what
releasing the GIL gives the plans that run during the build.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np


from subsim.maps.generate import clutter, hallways


def run(kind: str, plans: int, seed: int, period: float, background: bool, hold_gil: bool,
        niceness: int | None) -> dict:
    from experiments.navigation import reachable_free
    from navigation import landmarks
    from navigation.costmap import INSCRIBED, Costmap, InflationParams
    from navigation.planner import LANDMARKS, PlannerParams, plan, warm_up
    from subsumption.mapfile import OccupancyMap

    layout = hallways(seed=seed, width=50.0, height=50.0) if kind == "hallways" else \
        clutter(seed=seed, size=50.0, density=0.08)
    grid = OccupancyMap(layout.grid, 0.05, (0.0, 0.0), kind)
    costmap = Costmap(grid, InflationParams())
    free_r, free_c = np.nonzero(reachable_free(grid, layout.start[:2], 0.35))
    rng = np.random.default_rng(seed)
    params = PlannerParams()
    warm_up(params)
    if niceness is not None:
        landmarks.BUILD_NICENESS = niceness
    if hold_gil:  # the build's Dijkstra compiled without nogil: what releasing the GIL buys the plans
        import numba

        landmarks._dijkstra = numba.njit(landmarks._dijkstra.py_func)
        warm_up(params)
    wall, cpu, phase = [], [], []  # phase per plan: "octile" before the build, "building", "landmarks"
    started = ready = None
    build_wall = float("nan")
    for k in range(plans):
        i, j = rng.integers(len(free_r), size=2)
        a, b = grid.centre_of(int(free_r[i]), int(free_c[i])), grid.centre_of(int(free_r[j]), int(free_c[j]))
        state, before = LANDMARKS.get(costmap, costmap.static_costs, params.cost_factor, INSCRIBED, params.landmarks)
        building = state.builder is not None and before is None
        t0, c0 = time.perf_counter(), time.thread_time()
        plan(costmap, a, b, params, background=background)
        wall.append(1000 * (time.perf_counter() - t0))
        cpu.append(1000 * (time.thread_time() - c0))
        phase.append("landmarks" if before is not None else "building" if building else "octile")
        state, after = LANDMARKS.get(costmap, costmap.static_costs, params.cost_factor, INSCRIBED, params.landmarks)
        if started is None and (after is not None or state.builder is not None):
            started = k
            build_t0 = time.perf_counter() if background else t0
        if ready is None and after is not None:
            ready = k + 1  # the first plan that used them
            build_wall = 1000 * (time.perf_counter() - build_t0)
        if period > 0:
            time.sleep(max(0.0, period - (time.perf_counter() - t0)))
    wall_a, cpu_a = np.array(wall), np.array(cpu)
    during = [w for w, p in zip(wall, phase) if p == "building"]
    before = [w for w, p in zip(wall, phase) if p == "octile"]
    during_cpu = [c for c, p in zip(cpu, phase) if p == "building"]
    worst = int(np.argmax(wall_a))
    return {"map": kind, "mode": "background" if background else "foreground", "plans": plans,
            "worst wall ms": f"{wall_a[worst]:.1f}", "its CPU ms": f"{cpu_a[worst]:.1f}", "worst plan #": worst,
            "build started in plan #": started, "first plan with landmarks #": ready,
            "build wall ms (about)": f"{build_wall:.0f}",
            "plans during build": len(during), "worst during build ms": f"{max(during):.1f}" if during else "-",
            "median during build ms (wall / CPU)":
                f"{np.median(during):.1f} / {np.median(during_cpu):.1f}" if during else "-",
            "median before build ms": f"{np.median(before):.1f}" if before else "-",
            "median wall ms": f"{np.median(wall_a):.1f}",
            "worst of the rest ms": f"{np.max(np.delete(wall_a, worst)):.1f}"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plans", type=int, default=60)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--period", type=float, default=0.0, help="s from one plan's start to the next's (0: none)")
    parser.add_argument("--foreground", action="store_true", help="build inside the plan (the in-process way)")
    parser.add_argument("--hold-gil", action="store_true", help="the build's Dijkstra without nogil (to compare)")
    parser.add_argument("--build-niceness", type=int, default=None,
                        help="added to the build thread's nice value (default: navigation.landmarks')")
    parser.add_argument("--only", default="hallways,clutter")
    args = parser.parse_args()
    for kind in args.only.split(","):
        result = run(kind, args.plans, args.seed, args.period, not args.foreground, args.hold_gil,
                     args.build_niceness)
        print(" | ".join(f"{k}: {v}" for k, v in result.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
