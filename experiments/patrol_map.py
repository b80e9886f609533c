"""The patrol's own map, complete before the patrol starts: frontier exploration until nothing reachable is unknown.

Before, the map was what the wander robot's fixed-time drive happened to see: accurate (ATE 4 mm) but, on seed 4 of
the ping-pong room, without the room's east side, and the patrol refused its goal 2 there. Now the robot explores
(navigation.explore through move_base, SLAM with the depth scan, the room empty as one maps a building) until no
reachable frontier is left, within `bound` simulated seconds; then every goal must lie in known free space on the
built map, with room for the robot. Otherwise :class:`PatrolMapIncomplete` says what stayed unknown: which goal,
whether exploration finished or ran out of time, how much reachable floor is still unknown.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.ndimage import binary_dilation

from robots.patrol.level3 import Goal, GoalsError
from subsim.mapio import GridMap, load_map
from subsim.world import WorldDocument
from subsumption.mapfile import FREE, UNKNOWN, OccupancyMap

from . import mapping

EXPLORE_BOUND = 900.0  # simulated s at most of exploring before the patrol
CLEARANCE = 0.25       # m: a goal nearer a wall than this (the TurtleBot's radius plus a margin) is refused
FOOTPRINT = 0.18       # m: the TurtleBot's radius; the floor under it along its path is floor (see stood_on)


class PatrolMapIncomplete(GoalsError):
    """The explored map leaves a goal unknown or in a wall; the message names the goal and what stayed unknown."""


def explored_map(world: Path, out_dir: Path, seed: int, goals: list, where: str, bound: float = EXPLORE_BOUND,
                 progress: bool = True) -> Path:
    """D/map/map.yaml explored for the patrol of `goals` (reused when it is already there and holds them)."""
    folder = out_dir / "map"
    path = folder / "map.yaml"
    if not path.exists():
        _say(progress, f"patrol: exploring to build the map first (frontier exploration, at most {bound:.0f} s "
                       f"simulated, SLAM with the depth scan)")
        mapping_world, start = explore_world(world, folder)
        recorder, wall, _ = mapping.run_local(mapping_world, start, bound, seed, "frontier")
        built = recorder.built_map()
        if built is not None:
            built = stood_on(built, recorder.keyframes()[1][:, :2], FOOTPRINT)
        result = mapping.score(recorder, mapping_world, wall, built)
        m = result.metrics  # explore_done: whether exploration finished before the bound
        ended = "finished" if recorder.explore_finished else "robot stuck" if recorder.explore_stuck else \
            "cut at the bound"
        mapping.write_outputs(result, folder, f"map for the patrol (frontier exploration, {ended}"
                                              f" after {m['sim_time_s']:.0f} s): ATE {m['ate_m'] * 100:.1f} cm",
                              {"world": str(world), "seed": seed, "sensor": "depth", "odom_noise": 0.02,
                               "explore": "frontier"})
    else:
        _say(progress, f"patrol: using the map built before, {path}")
    metrics = json.loads((folder / "metrics.json").read_text()) if (folder / "metrics.json").exists() else {}
    try:
        check_goals(goals, load_map(path), where, f"the navigation map {path}")
    except GoalsError as error:
        finished = metrics.get("explore_done")
        stuck = metrics.get("explore_stuck_at")
        how = (f"exploration stopped with the robot stuck at ({stuck[0]:.2f}, {stuck[1]:.2f}), not moved for "
               f"{metrics.get('explore_stuck_s', '?')} s" if stuck else
               "exploration finished (no reachable frontier left)" if finished else
               f"exploration ran out of its {bound:.0f} s bound" if finished is not None else "map built before")
        raise PatrolMapIncomplete(f"{error}; {how} after {metrics.get('sim_time_s', '?')} s; "
                                  f"{unknown_reachable_m2(load_map(path)):.1f} m² next to known free floor stays "
                                  f"unknown (see {folder / 'map_vs_truth.png'})") from None
    return path


def explore_world(world: Path, folder: Path) -> tuple[Path, list]:
    """`folder`/world.yaml, the world the patrol's map is explored in, and the robot's start: the building empty
    (nobody walks through it, see patrol.built_map), the camera off, SLAM reading the depth scan with 2% odometry
    noise."""
    doc = WorldDocument(world)
    doc.data["agents"] = []
    doc.sensors["camera"] = False
    return mapping.prepare_world(doc, folder, "depth", 0.02)


def stood_on(grid: OccupancyMap, path: np.ndarray, radius: float) -> OccupancyMap:
    """`grid` with the unknown cells the robot's footprint (`radius`) covered along `path` ((n, 2) map-frame SLAM
    keyframes, the segments between them included) marked free: the robot stood there, so it is floor. Cells
    marked occupied stay so.

    Why: the depth camera sees nothing nearer than 0.45 m, so the floor under the robot where it started is never
    seen; the ping-pong room's default goal 0 is that start corner, and on seeds 3 and 4 the explored map held the
    corner's surroundings but left a blob of unknown (under 0.3 m, less than a frontier) at the goal: "0.10 m
    clear", and the patrol did not start."""
    if not len(path):
        return grid
    step = grid.resolution / 2
    points = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / step)))
        points.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    points = np.concatenate(points)
    cols = np.floor((points[:, 0] - grid.origin[0]) / grid.resolution).astype(int)
    rows = np.floor((points[:, 1] - grid.origin[1]) / grid.resolution).astype(int)
    inside = (rows >= 0) & (rows < grid.shape[0]) & (cols >= 0) & (cols < grid.shape[1])
    centres = np.zeros(grid.shape, dtype=bool)
    centres[rows[inside], cols[inside]] = True
    reach = int(math.floor(radius / grid.resolution))
    yy, xx = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    covered = binary_dilation(centres, structure=(yy ** 2 + xx ** 2) <= reach ** 2)
    occupancy = grid.occupancy.copy()
    occupancy[covered & (occupancy == UNKNOWN)] = FREE
    return OccupancyMap(occupancy, grid.resolution, grid.origin, grid.source)


def unknown_reachable_m2(grid) -> float:
    """Unknown floor that touches known free cells: what a frontier explorer would still go to see."""
    near_free = binary_dilation(grid.occupancy == FREE, iterations=3)
    return float(np.count_nonzero(near_free & (grid.occupancy == UNKNOWN))) * grid.resolution ** 2


def clearance(grid: GridMap, x: float, y: float) -> float:
    """Metres from (x, y) to the nearest solid cell; 0 off the map or in a wall."""
    col = int(math.floor((x - grid.origin[0]) / grid.resolution))
    row = int(math.floor((y - grid.origin[1]) / grid.resolution))
    rows, cols = grid.wall_distance.shape
    if not (0 <= row < rows and 0 <= col < cols) or grid.solid[row, col]:
        return 0.0
    return float(grid.wall_distance[row, col])


def check_goals(goals: list[Goal], grid: GridMap, where: str, what: str) -> None:
    """Every goal on the map and clear of walls by CLEARANCE; GoalsError names `where` and the goal's index."""
    x0, x1, y0, y1 = grid.extent()
    for i, (x, y, _) in enumerate(goals):
        if not (x0 <= x < x1 and y0 <= y < y1):
            raise GoalsError(f"{where}: goal {i} ({x:g}, {y:g}) is off {what} (x {x0:g}..{x1:g}, y {y0:g}..{y1:g})")
        room = clearance(grid, x, y)
        if room < CLEARANCE:
            raise GoalsError(f"{where}: goal {i} ({x:g}, {y:g}) is in a wall or too near one on {what} "
                             f"({room:.2f} m clear, the robot needs {CLEARANCE:g} m)")


def _say(enabled: bool, text: str) -> None:
    if enabled:
        print(text, file=sys.stderr, flush=True)
