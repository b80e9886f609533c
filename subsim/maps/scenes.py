"""Draws the camera worlds, deterministically: ``python -m subsim.maps.scenes``.

* ``pingpong``: the paper's second experiment (a TurtleBot patrolling a ping-pong room). A 10 m x 6 m room with
  a 2.74 m x 1.525 m table (0.76 m high: a box the camera sees over) in the middle, so corridors run round it;
  a corridor along its north side joins two 1 m doorways. The target, another TurtleBot carrying a face photo,
  waits in the corridor, comes in by the west door, crosses the room and leaves by the east door, and goes
  round again. Posters without faces hang on the walls. The patrol robot (a TurtleBot with a Kinect, bumpers,
  no sonar and no laser) starts in the south-west corner; ``PINGPONG_CORNERS`` are the four corners to patrol.

* ``office``: the seeded office of :func:`subsim.maps.generate.office` (rooms off a 2 m corridor through
  0.9-1.2 m doorways; seed ``OFFICE_SEED``), its boxes as desks 0.75 m high, and two people carrying their face
  photos at head height (Grace Hopper and Eileen Collins) walking the corridor and in and out of the rooms. A
  TurtleBot starts at the west end of the corridor. (A level camera 0.29 m up sees a face at 1.45 m only from
  about 3 m away: it looks up at people, as the paper's TurtleBot did.)

Each world has its map (map_server PGM + YAML, 5 cm cells; the table is in the map too, so /map shows it), a
world file and a preview PNG.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from subsim.mapio import FREE, OCCUPIED, save_map

RES = 0.05
HERE = Path(__file__).resolve().parent
WALL = 0.2

# The ping-pong room: interior x in [0.2, 10.2], y in [0.2, 6.2]; corridor y in [6.4, 8.0].
PINGPONG_SIZE = (10.4, 8.2)
PINGPONG_TABLE = (5.2 - 1.37, 3.2 - 0.7625, 5.2 + 1.37, 3.2 + 0.7625)  # 2.74 m x 1.525 m, centred in the room
PINGPONG_TABLE_HEIGHT = 0.76
PINGPONG_DOORS = ((2.5, 3.5), (6.9, 7.9))  # x ranges of the two doorways in the north wall
PINGPONG_CORNERS = ((1.0, 1.0), (9.4, 1.0), (9.4, 5.4), (1.0, 5.4))  # the four corners to patrol
PINGPONG_START = (1.0, 1.0, 0.0)


def _cells(metres: float) -> int:
    return int(round(metres / RES))


def _fill(grid: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Set the cells of the world rectangle [x0, x1) x [y0, y1) (metres; row 0 = lowest y)."""
    grid[_cells(y0):_cells(y1), _cells(x0):_cells(x1)] = value


def pingpong() -> np.ndarray:
    width, height = PINGPONG_SIZE
    grid = np.full((_cells(height), _cells(width)), OCCUPIED, dtype=np.int8)
    _fill(grid, WALL, WALL, width - WALL, 6.2, FREE)  # the room
    _fill(grid, WALL, 6.4, width - WALL, height - WALL, FREE)  # the corridor
    for x0, x1 in PINGPONG_DOORS:
        _fill(grid, x0, 6.2, x1, 6.4, FREE)
    _fill(grid, *PINGPONG_TABLE, OCCUPIED)
    return grid


def pingpong_world(map_name: str) -> dict[str, Any]:
    return {
        "map": map_name,
        "scene": {
            "wall_height": 2.5, "wall_colour": [200, 196, 184], "floor_colour": [150, 120, 90],
            "boxes": [{"name": "pingpong_table", "rect": [round(v, 4) for v in PINGPONG_TABLE],
                       "height": PINGPONG_TABLE_HEIGHT, "colour": [30, 70, 130]}],
            "pictures": [
                {"file": "../pictures/poster_chelsea.png", "at": [5.2, 0.22], "yaw": 1.5708, "height": 0.6,
                 "centre": 1.2},
                {"file": "../pictures/poster_rocket.png", "at": [10.18, 3.2], "yaw": 3.1416, "height": 0.6,
                 "centre": 1.1},
                {"file": "../pictures/poster_coffee.png", "at": [0.22, 3.2], "yaw": 0.0, "height": 0.5,
                 "centre": 1.0},
            ]},
        "robots": [{"name": "robot0", "namespace": "", "kind": "turtlebot", "start": list(PINGPONG_START)}],
        "agents": [{
            "name": "target", "kind": "robot", "motion": "waypoints", "speed": 0.3, "wait": 10.0, "loop": True,
            "waypoints": [[0.8, 7.2], [3.0, 7.2], [3.0, 5.6], [1.8, 1.8], [8.6, 1.8], [7.4, 5.6], [7.4, 7.2],
                          [9.6, 7.2]],
            "picture": {"file": "../pictures/face_astronaut.png", "height": 0.45, "centre": 0.62, "yaw": 0.0}}],
    }


OFFICE_SEED = 3
DESK_HEIGHT = 0.75
FACE_CENTRE = 1.45  # m: a 0.45 m card with the face in its upper part, the face at about 1.6 m


def office() -> np.ndarray:
    from subsim.maps.generate import office as draw
    return draw(OFFICE_SEED).grid


def _desks(grid: np.ndarray) -> list[tuple[float, float, float, float]]:
    """The boxes of the office: solid pieces not joined to the building's walls, as [x0, y0, x1, y1]."""
    import cv2
    count, _, stats, _ = cv2.connectedComponentsWithStats((grid == OCCUPIED).astype(np.uint8), connectivity=4)
    walls = int(np.argmax(stats[1:, cv2.CC_STAT_AREA])) + 1
    return [tuple(round(float(v) * RES, 3) for v in (x, y, x + w, y + h))
            for i, (x, y, w, h, _) in enumerate(stats) if i not in (0, walls)]


def office_world(map_name: str) -> dict[str, Any]:
    from subsim.maps.generate import office as draw
    layout = draw(OFFICE_SEED)
    corridor_y = float(layout.start[1])
    stops = []  # for each doorway: the corridor in front of it, and 1.2 m into the room
    for x0, y0, x1, y1 in layout.doors:
        cx = round(float(x0 + x1) / 2, 2)
        inside = float(y0 - 1.2 if y0 < corridor_y else y1 + 1.2)
        stops.append(([cx, round(float(corridor_y), 2)], [cx, round(inside, 2)]))
    width = float(layout.grid.shape[1] * RES)

    def walk(doors: list[int], start_x: float) -> list[list[float]]:
        path = [[start_x, round(corridor_y, 2)]]
        for d in doors:
            front, inside = stops[d]
            path += [list(front), list(inside), list(front)]
        return path

    people = [("grace", "face_grace_hopper", 0.42, walk([0, 1], width - 1.5), 0.9, (70, 60, 50)),
              ("eileen", "face_astronaut", 0.45, walk([len(stops) - 1, len(stops) - 2], width / 2 + 2.0), 0.8, (150, 80, 30))]
    return {
        "map": map_name,
        "scene": {"wall_height": 2.5, "wall_colour": [205, 205, 195], "floor_colour": [110, 110, 125],
                  "boxes": [{"name": f"desk{i}", "rect": list(rect), "height": DESK_HEIGHT, "colour": [150, 110, 70]}
                            for i, rect in enumerate(_desks(layout.grid))],
                  "pictures": [{"file": "../pictures/poster_clock.png", "at": [round(width / 2, 2),
                                round(corridor_y + 0.98, 2)], "yaw": -1.5708, "height": 0.5, "centre": 1.3}]},
        "robots": [{"name": "robot0", "namespace": "", "kind": "turtlebot",
                    "start": [round(float(v), 3) for v in layout.start]}],
        "agents": [{"name": name, "kind": "person", "motion": "waypoints", "speed": speed, "loop": True,
                    "waypoints": path, "colour": list(colour),
                    "picture": {"file": f"../pictures/{face}.png", "height": height, "centre": FACE_CENTRE}}
                   for name, face, height, path, speed, colour in people],
    }


WORLDS = {"pingpong": (pingpong, pingpong_world), "office": (office, office_world)}


def write_all(folder: Path = HERE, preview: bool = True, names: tuple[str, ...] | None = None) -> list[Path]:
    written = []
    for name, (draw, describe) in WORLDS.items():
        if names and name not in names:
            continue
        map_yaml = save_map(draw(), folder / f"{name}.yaml", RES)
        world = describe(map_yaml.name)
        world_path = folder / f"{name}_world.yaml"
        world_path.write_text(f"# The {name} world, drawn by subsim/maps/scenes.py (see its docstring).\n"
                              + yaml.safe_dump(world, sort_keys=False, default_flow_style=None, width=110))
        written += [map_yaml, world_path]
        if preview:
            written.append(_preview(world_path, folder / f"{name}_preview.png", name))
    return written


def _preview(world_path: Path, out: Path, name: str) -> Path:
    from subsim.plot import plot_run
    from subsim.world import load_world
    world = load_world(world_path)
    paths = {r.name: np.array([r.start[:2]]) for r in world.robots if r.start is not None}
    paths.update({a.name: np.array(a.waypoints) for a in world.agents})
    return plot_run(world.map, paths, {}, out, title=f"{name} world")


if __name__ == "__main__":
    for p in write_all():
        print(p)
