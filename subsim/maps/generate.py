"""Draws the shipped maps and their worlds, deterministically: ``python -m subsim.maps.generate``.

The maps are the two environments of Brooks' 1986 paper (its Fig. 4) plus a small room for quick tests:

* ``corridors``: 20 m x 12 m, two parallel corridors 2.5 m wide joined at both ends, so a robot can go
  round, with a box in the lower one;
* ``sparse``: 20 m x 20 m walled area with boxes and pillars scattered over it (fixed seed);
* ``room``: 6 m x 6 m with one box.

All at 5 cm per cell, written in map_server format (PGM + YAML) with a world file each, and a PNG preview.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from subsim.mapio import FREE, OCCUPIED, save_map

RES = 0.05
HERE = Path(__file__).resolve().parent


def _cells(metres: float) -> int:
    return int(round(metres / RES))


def fill(grid: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Set the cells of the world rectangle [x0, x1) x [y0, y1) (metres; row 0 = lowest y)."""
    grid[_cells(y0):_cells(y1), _cells(x0):_cells(x1)] = value


def walled(width: float, height: float, wall: float = 0.2) -> np.ndarray:
    grid = np.full((_cells(height), _cells(width)), OCCUPIED, dtype=np.int8)
    fill(grid, wall, wall, width - wall, height - wall, FREE)
    return grid


def room() -> np.ndarray:
    grid = walled(6.0, 6.0)
    fill(grid, 3.8, 3.8, 4.4, 4.4, OCCUPIED)  # a box, off the robot's first straight line
    return grid


def corridors() -> np.ndarray:
    """A ring of corridors: lower y in [1, 3.5], upper y in [8.5, 11], joined by end corridors."""
    grid = np.full((_cells(12.0), _cells(20.0)), OCCUPIED, dtype=np.int8)
    fill(grid, 1.0, 1.0, 19.0, 3.5, FREE)  # lower corridor
    fill(grid, 1.0, 8.5, 19.0, 11.0, FREE)  # upper corridor
    fill(grid, 1.0, 1.0, 3.5, 11.0, FREE)  # west end
    fill(grid, 16.5, 1.0, 19.0, 11.0, FREE)  # east end
    fill(grid, 9.7, 1.95, 10.3, 2.55, OCCUPIED)  # the obstacle: a 0.6 m box mid-corridor
    return grid


def sparse(seed: int = 4) -> np.ndarray:
    """Boxes and pillars placed with a fixed seed, at least 1.2 m apart and away from the start area."""
    grid = walled(20.0, 20.0)
    rng = np.random.default_rng(seed)
    placed: list[tuple[float, float, float]] = []
    while len(placed) < 22:
        size = float(rng.choice([0.3, 0.5, 0.8, 1.2]))
        x, y = rng.uniform(1.0, 19.0 - size, 2)
        cx, cy = x + size / 2, y + size / 2
        if np.hypot(cx - 2.0, cy - 2.0) < 2.0:  # keep the start corner clear
            continue
        if any(np.hypot(cx - px, cy - py) < (size + ps) / 2 + 1.2 for px, py, ps in placed):
            continue
        placed.append((cx, cy, size))
        fill(grid, x, y, x + size, y + size, OCCUPIED)
    return grid


WORLDS = {
    "room": (room, [1.0, 1.5, 0.0]),
    "corridors": (corridors, [2.0, 2.25, 0.0]),
    "sparse": (sparse, [2.0, 2.0, 0.785]),
}


def write_all(folder: Path = HERE, preview: bool = True) -> list[Path]:
    written = []
    for name, (draw, start) in WORLDS.items():
        map_yaml = save_map(draw(), folder / f"{name}.yaml", RES)
        world = {"map": map_yaml.name,
                 "robots": [{"name": "robot0", "namespace": "", "start": start}]}
        world_path = folder / f"{name}_world.yaml"
        world_path.write_text(f"# The {name} world: one robot, topics at the root (/cmd_vel, /scan, ...).\n"
                              + yaml.safe_dump(world, sort_keys=False, default_flow_style=None))
        written += [map_yaml, world_path]
        if name == "room":  # the same room with company: a person pacing and a wandering robot
            world["agents"] = [
                {"name": "person", "kind": "person", "motion": "waypoints", "waypoints": [[4.8, 1.0], [4.8, 3.2]],
                 "speed": 0.8},
                {"name": "rover", "kind": "robot", "motion": "wander", "start": [2.5, 4.5, -0.5], "speed": 0.4}]
            people = folder / "room_people_world.yaml"
            people.write_text("# The room with a person walking up and down and a robot wandering about.\n"
                              + yaml.safe_dump(world, sort_keys=False, default_flow_style=None))
            written.append(people)
        if preview:
            from subsim.mapio import load_map
            from subsim.plot import plot_run
            grid = load_map(map_yaml)
            plot_run(grid, {"robot0": np.array([start[:2]])}, {}, folder / f"{name}_preview.png", title=f"{name} map")
    return written


if __name__ == "__main__":
    for path in write_all():
        print(path)
