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
from pathlib import Path

import numpy as np
import yaml

from robots.patrol.level3 import GoalsError
from subsim.mapio import load_map

EXPLORE_BOUND = 900.0  # simulated s at most of exploring before the patrol


class PatrolMapIncomplete(GoalsError):
    """The explored map leaves a goal unknown or in a wall; the message names the goal and what stayed unknown."""


def explored_map(world: Path, out_dir: Path, seed: int, goals: list, where: str, bound: float = EXPLORE_BOUND,
                 progress: bool = True) -> Path:
    """D/map/map.yaml explored for the patrol of `goals` (reused when it is already there and holds them)."""
    from subsim.world import absolute_paths

    from . import mapping
    from .patrol import _say, check_goals

    folder = out_dir / "map"
    path = folder / "map.yaml"
    if not path.exists():
        _say(progress, f"patrol: exploring to build the map first (frontier exploration, at most {bound:.0f} s "
                       f"simulated, SLAM with the depth scan)")
        data = yaml.safe_load(Path(world).read_text())
        absolute_paths(data, world)
        data["agents"] = []  # the building mapped while nobody walks through it (see patrol.built_map)
        robot = data["robots"][0]
        robot["sensors"] = {**(robot.get("sensors") or {}), "camera": False}
        folder.mkdir(parents=True, exist_ok=True)
        source = folder / "source_world.yaml"
        source.write_text(yaml.safe_dump(data, sort_keys=False))
        mapping_world, start = mapping.prepare_world(source, folder, "depth", 0.02)
        recorder, wall, _ = mapping.run_local(mapping_world, start, bound, seed, "frontier")
        result = mapping.score(recorder, mapping_world, wall)
        m = result.metrics  # explore_done: whether exploration finished before the bound
        mapping.write_outputs(result, folder, f"map for the patrol (frontier exploration, "
                                              f"{'finished' if recorder.explore_finished else 'cut at the bound'}"
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
        how = ("exploration finished (no reachable frontier left)" if finished else
               f"exploration ran out of its {bound:.0f} s bound" if finished is not None else "map built before")
        raise PatrolMapIncomplete(f"{error}; {how} after {metrics.get('sim_time_s', '?')} s; "
                                  f"{unknown_reachable_m2(load_map(path)):.1f} m² next to known free floor stays "
                                  f"unknown (see {folder / 'map_vs_truth.png'})") from None
    return path


def unknown_reachable_m2(grid) -> float:
    """Unknown floor that touches known free cells: what a frontier explorer would still go to see."""
    from scipy.ndimage import binary_dilation

    from subsumption.mapfile import FREE, UNKNOWN

    near_free = binary_dilation(grid.occupancy == FREE, iterations=3)
    return float(np.count_nonzero(near_free & (grid.occupancy == UNKNOWN))) * grid.resolution ** 2
