"""Draws maps, deterministically: the shipped ones, and seeded families of buildings to test robots on.

Shipped maps (``python -m subsim.maps.generate`` or ``... shipped``): the two environments of Brooks' 1986
paper (its Fig. 4) plus a small room for quick tests:

* ``corridors``: 20 m x 12 m, two parallel corridors 2.5 m wide joined at both ends, so a robot can go
  round, with a box in the lower one;
* ``sparse``: 20 m x 20 m walled area with boxes and pillars scattered over it (fixed seed);
* ``room``: 6 m x 6 m with one box.

Generated families (``python -m subsim.maps.generate KIND --seed S --out DIR``), each a function of a seed
returning a :class:`Layout` (grid, start pose, doorways) that :func:`write_layout` writes as a map_server map
(PGM + YAML) plus a world file with one robot:

* :func:`office`: rooms on both sides of a straight corridor (default: 20 m x 12 m, four rooms off a 2 m
  corridor), each room entered by one doorway 0.9-1.2 m wide in its corridor wall, boxes in the rooms;
* :func:`hallways`: long corridors meeting at T and X junctions (a seeded spanning tree over a lattice of
  junctions plus a few loops), with dead ends;
* :func:`clutter`: a walled square with boxes scattered at a given density (fraction of the floor covered),
  never closer to each other or the walls than a given gap, so every box can be gone round.

All at 5 cm per cell. The same arguments always give the same map; a different seed gives a different one.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from subsim.mapio import FREE, OCCUPIED, save_map

RES = 0.05
HERE = Path(__file__).resolve().parent
WALL = 0.2  # m: thickness of every wall drawn here


def _cells(metres: float) -> int:
    return int(round(metres / RES))


def fill(grid: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Set the cells of the world rectangle [x0, x1) x [y0, y1) (metres; row 0 = lowest y)."""
    grid[_cells(y0):_cells(y1), _cells(x0):_cells(x1)] = value


def walled(width: float, height: float, wall: float = WALL) -> np.ndarray:
    """A width x height (m) grid, free inside a solid border `wall` thick."""
    grid = np.full((_cells(height), _cells(width)), OCCUPIED, dtype=np.int8)
    fill(grid, wall, wall, width - wall, height - wall, FREE)
    return grid


# ---------------------------------------------------------------------------------------------- shipped maps

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


# ------------------------------------------------------------------------------------------ generated maps

@dataclass
class Layout:
    """A generated map: the occupancy grid (int8, row 0 = lowest y, RES m per cell, origin at (0, 0)), a free
    start pose for a robot (x, y, yaw), every doorway as (x0, y0, x1, y1), the free gap in its wall, and, for an
    office, its east-west corridor's free band (south y, north y)."""

    grid: np.ndarray
    start: tuple[float, float, float]
    doors: list[tuple[float, float, float, float]] = field(default_factory=list)
    description: str = ""
    corridor: tuple[float, float] | None = None

    @property
    def door_widths(self) -> list[float]:
        """Width (m) of every doorway: its extent along the wall it is cut in."""
        return [max(x1 - x0, y1 - y0) for x0, y0, x1, y1 in self.doors]


def _boxes(rng: np.random.Generator, grid: np.ndarray, area: tuple[float, float, float, float], count: int,
           sizes: tuple[float, float], gap: float, keep_clear: list[tuple[float, float, float]],
           tries: int = 2000) -> list[tuple[float, float, float, float]]:
    """Place up to `count` boxes (sides drawn from `sizes`) inside `area` (x0, y0, x1, y1), each at least `gap`
    from the area's edges, from every other box, and from every (x, y, radius) disc in `keep_clear`."""
    x0, y0, x1, y1 = area
    placed: list[tuple[float, float, float, float]] = []
    for _ in range(tries):
        if len(placed) >= count:
            break
        w, h = rng.uniform(*sizes, 2)
        if x1 - x0 - 2 * gap < w or y1 - y0 - 2 * gap < h:
            continue
        bx = rng.uniform(x0 + gap, x1 - gap - w)
        by = rng.uniform(y0 + gap, y1 - gap - h)
        if any(bx < px1 + gap and px0 < bx + w + gap and by < py1 + gap and py0 < by + h + gap
               for px0, py0, px1, py1 in placed):
            continue
        if any(np.hypot(np.clip(cx, bx, bx + w) - cx, np.clip(cy, by, by + h) - cy) < r for cx, cy, r in keep_clear):
            continue
        placed.append((bx, by, bx + w, by + h))
        fill(grid, bx, by, bx + w, by + h, OCCUPIED)
    return placed


def office(seed: int = 0, width: float = 20.0, height: float = 12.0, rooms: int = 4, corridor: float = 2.0,
           door_min: float = 0.9, door_max: float = 1.2, boxes: int = 2) -> Layout:
    """Rooms on both sides of a straight east-west corridor `corridor` m wide through the middle of a
    `width` x `height` m building: ceil(rooms/2) rooms south of it, the rest north, side by side. Each room has
    one doorway, as wide as a uniform draw in [door_min, door_max], at a random place in its corridor wall, and
    up to `boxes` boxes (0.4-1.0 m) kept 1.5 m from the doorway and 0.6 m from walls and each other. The robot
    starts at the west end of the corridor, facing east."""
    if rooms < 1 or corridor <= 0 or not 0 < door_min <= door_max:
        raise ValueError(f"office: need rooms >= 1, corridor > 0 and 0 < door_min <= door_max; got rooms={rooms}, "
                         f"corridor={corridor}, door_min={door_min}, door_max={door_max}")
    rng = np.random.default_rng(seed)
    grid = walled(width, height)
    south_rooms, north_rooms = (rooms + 1) // 2, rooms // 2
    c0 = (height - corridor) / 2  # the corridor's free band is [c0, c0 + corridor]
    c1 = c0 + corridor
    fill(grid, WALL, c0 - WALL, width - WALL, c0, OCCUPIED)  # south corridor wall
    if north_rooms:
        fill(grid, WALL, c1, width - WALL, c1 + WALL, OCCUPIED)  # north corridor wall
    doors: list[tuple[float, float, float, float]] = []
    for count, (ry0, ry1, wall_y0, wall_y1, door_side) in (
            (south_rooms, (WALL, c0 - WALL, c0 - WALL, c0, "north")),
            (north_rooms, (c1 + WALL, height - WALL, c1, c1 + WALL, "south"))):
        if not count:
            continue
        room_width = (width - WALL) / count
        for i in range(count):
            left = i * room_width  # the room's west wall is [left, left + WALL]
            rx0, rx1 = left + WALL, left + room_width
            if i:
                fill(grid, left, ry0, left + WALL, ry1, OCCUPIED)  # partition from the previous room
            door = float(rng.uniform(door_min, door_max))
            if rx1 - rx0 < door + 0.4:
                raise ValueError(f"office: rooms {rx1 - rx0:.2f} m wide cannot hold a {door:.2f} m doorway; "
                                 f"fewer rooms or a wider building")
            dx = float(rng.uniform(rx0 + 0.2, rx1 - 0.2 - door))
            dx = round(dx / RES) * RES  # the doorway on cell boundaries, as wide as drawn to the cell
            door_end = dx + round(door / RES) * RES
            fill(grid, dx, wall_y0, door_end, wall_y1, FREE)
            doors.append((dx, wall_y0, door_end, wall_y1))
            door_y = wall_y1 if door_side == "north" else wall_y0
            _boxes(rng, grid, (rx0, ry0, rx1, ry1), boxes, (0.4, 1.0), 0.6,
                   [((dx + door_end) / 2, door_y, 1.5)])
    return Layout(grid, (WALL + 1.0, (c0 + c1) / 2, 0.0), doors,
                  f"office {width:g} m x {height:g} m, {rooms} rooms off a {corridor:g} m corridor, seed {seed}",
                  corridor=(c0, c1))


def hallways(seed: int = 0, width: float = 30.0, height: float = 20.0, spacing: float = 6.0,
             corridor_min: float = 1.5, corridor_max: float = 2.5, loops: int = 2) -> Layout:
    """Long corridors meeting at junctions: the junctions form a lattice `spacing` m apart; a random spanning
    tree over it (plus `loops` extra links, closing loops) gives the corridors, each as wide as a uniform
    draw in [corridor_min, corridor_max]. Junctions where three or four corridors meet are T and X junctions;
    lattice corners reached by one corridor are dead ends. The robot starts at the first junction, facing
    along its first corridor."""
    if spacing <= corridor_max or not 0 < corridor_min <= corridor_max:
        raise ValueError(f"hallways: need 0 < corridor_min <= corridor_max < spacing; got {corridor_min}, "
                         f"{corridor_max}, {spacing}")
    rng = np.random.default_rng(seed)
    cols = max(1, int((width - 2 * WALL - corridor_max) // spacing) + 1)
    rows = max(1, int((height - 2 * WALL - corridor_max) // spacing) + 1)
    margin_x = (width - (cols - 1) * spacing) / 2
    margin_y = (height - (rows - 1) * spacing) / 2
    node = {(i, j): (margin_x + i * spacing, margin_y + j * spacing) for i in range(cols) for j in range(rows)}
    edges = [((i, j), (i + 1, j)) for i in range(cols - 1) for j in range(rows)] + \
            [((i, j), (i, j + 1)) for i in range(cols) for j in range(rows - 1)]
    order = rng.permutation(len(edges))
    parent = {n: n for n in node}

    def root(n):
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    chosen, spare = [], []
    for k in order:  # Kruskal with random weights: a uniformly shuffled spanning tree
        a, b = edges[k]
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[ra] = rb
            chosen.append(edges[k])
        else:
            spare.append(edges[k])
    chosen += spare[:loops]
    grid = np.full((_cells(height), _cells(width)), OCCUPIED, dtype=np.int8)
    for a, b in chosen:
        w = float(rng.uniform(corridor_min, corridor_max))
        (ax, ay), (bx, by) = node[a], node[b]
        fill(grid, min(ax, bx) - w / 2, min(ay, by) - w / 2, max(ax, bx) + w / 2, max(ay, by) + w / 2, FREE)
    first = chosen[0]
    (ax, ay), (bx, by) = node[first[0]], node[first[1]]
    return Layout(grid, (ax, ay, float(np.arctan2(by - ay, bx - ax))), [],
                  f"hallways {width:g} m x {height:g} m, junctions {spacing:g} m apart, seed {seed}")


def clutter(seed: int = 0, size: float = 15.0, density: float = 0.08, box_min: float = 0.3, box_max: float = 1.0,
            gap: float = 0.8) -> Layout:
    """A walled `size` x `size` m square with boxes (sides uniform in [box_min, box_max]) covering about
    `density` of its floor, each at least `gap` m from the walls and from every other box (so a robot narrower
    than the gap can go round every box). The start corner is kept clear; the robot faces the middle."""
    if not 0 <= density < 0.5 or gap <= 0 or not 0 < box_min <= box_max:
        raise ValueError(f"clutter: need 0 <= density < 0.5, gap > 0, 0 < box_min <= box_max; got density="
                         f"{density}, gap={gap}, box_min={box_min}, box_max={box_max}")
    rng = np.random.default_rng(seed)
    grid = walled(size, size)
    inner = size - 2 * WALL
    count = int(round(density * inner * inner / ((box_min + box_max) / 2) ** 2))
    start = (WALL + 1.0, WALL + 1.0, float(np.pi / 4))
    placed = _boxes(rng, grid, (WALL, WALL, size - WALL, size - WALL), count, (box_min, box_max), gap,
                    [(start[0], start[1], 1.5)], tries=200 * max(count, 1))
    return Layout(grid, start, [], f"clutter {size:g} m square, {len(placed)} boxes (density {density:g}), "
                                   f"seed {seed}")


KINDS = {"office": office, "hallways": hallways, "clutter": clutter}


def office_walkers(layout: Layout, count: int, seed: int = 0) -> list[dict]:
    """`count` people walking an office `layout`'s corridor and in and out of its doors, as world-file agents:
    walker i keeps to a lane 0.5 m off the corridor's middle (north of it for even i, south for odd i), walks west
    from the corridor's east end and, at each doorway on the other side (the south doors for even i: its way in
    crosses the corridor), goes 1.0-1.4 m into the room (drawn with `seed`) and back to its lane, turns 1.5 m past
    the robot's start and loops. Speeds 0.9 and 0.8 m/s, then drawn from 0.7-1.0 with `seed`: the same layout
    and seed give the same people.

    Why: a patrol that passes only people who stand still (or none) says nothing about people who walk through
    doors, which is where the robot met them in the office world (docs/patrol.md)."""
    if count <= 0:
        return []
    if layout.corridor is None:
        raise ValueError("office walkers: the layout has no corridor (made by generate.office)")
    rng = np.random.default_rng(seed)
    width = layout.grid.shape[1] * RES
    corridor_doors = [d for d in layout.doors if d[2] - d[0] >= d[3] - d[1]]  # doors cut in east-west walls
    middle = sum(layout.corridor) / 2
    west = layout.start[0] + 1.5
    east = width - WALL - 0.8
    walkers = []
    for i in range(count):
        north_lane = i % 2 == 0
        lane = round(middle + (0.5 if north_lane else -0.5), 3)
        side = [d for d in corridor_doors if (d[1] < middle) == north_lane]  # even: south doors
        order = sorted(side, key=lambda d: -d[0])  # met walking west
        points = [[round(east, 3), lane]]
        for x0, y0, x1, y1 in order:
            x = round((x0 + x1) / 2, 3)
            depth = float(rng.uniform(1.0, 1.4))
            inside = round(y0 - depth, 3) if y0 < middle else round(y1 + depth, 3)
            points += [[x, lane], [x, inside], [x, lane]]
        points.append([round(west, 3), lane])
        speed = (0.9, 0.8)[i] if i < 2 else round(float(rng.uniform(0.7, 1.0)), 2)
        walkers.append({"name": f"walker{i}", "kind": "person", "motion": "waypoints", "speed": speed,
                        "loop": True, "waypoints": points})
    return walkers


def write_layout(layout: Layout, folder: str | Path, name: str, robot_kind: str | None = None,
                 agents: list[dict] | None = None) -> Path:
    """Write FOLDER/NAME.yaml + NAME.pgm (map_server) and FOLDER/NAME_world.yaml (one robot at the layout's
    start, topics at the root, of `robot_kind` if given, e.g. ``turtlebot``; `agents` as given); return the world
    file's path, ready for ``subsumption run --world``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    map_yaml = save_map(layout.grid, folder / f"{name}.yaml", RES)
    robot = {"name": "robot0", "namespace": "", "start": [round(float(v), 4) for v in layout.start]}
    if robot_kind:
        robot["kind"] = robot_kind
    world: dict = {"map": map_yaml.name, "robots": [robot]}
    if agents:
        world["agents"] = agents
    world_path = folder / f"{name}_world.yaml"
    world_path.write_text(f"# {layout.description or name}: one robot, topics at the root (/cmd_vel, /scan, ...).\n"
                          + yaml.safe_dump(world, sort_keys=False, default_flow_style=None))
    return world_path


# --------------------------------------------------------------------------------------------- shipped maps

WORLDS = {
    "room": (room, [1.0, 1.5, 0.0]),
    "corridors": (corridors, [2.0, 2.25, 0.0]),
    "sparse": (sparse, [2.0, 2.0, 0.785]),
}


def write_all(folder: Path = HERE, preview: bool = True) -> list[Path]:
    """(Re)write the shipped maps, their worlds and previews into `folder`."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
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
            _preview(map_yaml, start, folder / f"{name}_preview.png", f"{name} map")
    return written


def _preview(map_yaml: Path, start, out: Path, title: str) -> None:
    from subsim.mapio import load_map
    from subsim.plot import plot_run
    plot_run(load_map(map_yaml), {"robot0": np.array([start[:2]])}, {}, out, title=title)


# ---------------------------------------------------------------------------------------------------- CLI

def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m subsim.maps.generate",
        description="Write a seeded generated map (map_server PGM + YAML) and a world file with one robot, or "
                    "(KIND 'shipped', the default) rewrite the shipped maps.")
    parser.add_argument("kind", nargs="?", default="shipped", choices=["shipped", *KINDS],
                        help="office: rooms off a corridor; hallways: corridors with junctions; clutter: boxes "
                             "in a square; shipped: the room, corridors and sparse maps (default)")
    parser.add_argument("--seed", type=int, default=0, help="random seed; the same seed gives the same map")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder to write into (default: the current folder; shipped: subsim/maps)")
    parser.add_argument("--name", default=None, help="file name stem (default: KIND_seedS)")
    parser.add_argument("--preview", action="store_true", help="also draw NAME_preview.png")
    g = parser.add_argument_group("office")
    g.add_argument("--width", type=float, default=None,
                   help="m, building width (office 20, hallways 30); clutter: side of the square (15)")
    g.add_argument("--height", type=float, default=None, help="m, building height (office 12, hallways 20)")
    g.add_argument("--rooms", type=int, default=4, help="office: number of rooms, half on each side")
    g.add_argument("--corridor", type=float, default=2.0, help="office: m, corridor width")
    g.add_argument("--door-min", type=float, default=0.9, help="office: m, narrowest doorway")
    g.add_argument("--door-max", type=float, default=1.2, help="office: m, widest doorway")
    g.add_argument("--boxes", type=int, default=2, help="office: boxes per room (fewer if they do not fit)")
    g.add_argument("--people", type=int, default=0, help="office: people walking the corridor and in and out of "
                                                         "the doors (seeded routes, see office_walkers)")
    parser.add_argument("--robot", default=None, choices=["turtlebot"],
                        help="the world's robot kind (default: the simulator's default robot)")
    g = parser.add_argument_group("hallways")
    g.add_argument("--spacing", type=float, default=6.0, help="hallways: m between neighbouring junctions")
    g.add_argument("--corridor-min", type=float, default=1.5, help="hallways: m, narrowest corridor")
    g.add_argument("--corridor-max", type=float, default=2.5, help="hallways: m, widest corridor")
    g.add_argument("--loops", type=int, default=2, help="hallways: corridors added to the tree, closing loops")
    g = parser.add_argument_group("clutter")
    g.add_argument("--density", type=float, default=0.08, help="clutter: fraction of the floor covered by boxes")
    g.add_argument("--box-min", type=float, default=0.3, help="clutter: m, smallest box side")
    g.add_argument("--box-max", type=float, default=1.0, help="clutter: m, largest box side")
    g.add_argument("--gap", type=float, default=0.8, help="clutter: m, least distance between boxes and walls")
    return parser


def layout_from_args(args: argparse.Namespace) -> Layout:
    """The layout the CLI's arguments ask for."""
    if args.kind == "office":
        return office(args.seed, args.width or 20.0, args.height or 12.0, args.rooms, args.corridor,
                      args.door_min, args.door_max, args.boxes)
    if args.kind == "hallways":
        return hallways(args.seed, args.width or 30.0, args.height or 20.0, args.spacing, args.corridor_min,
                        args.corridor_max, args.loops)
    return clutter(args.seed, args.width or 15.0, args.density, args.box_min, args.box_max, args.gap)


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.kind == "shipped":
        for path in write_all(args.out or HERE):
            print(path)
        return 0
    try:
        layout = layout_from_args(args)
    except ValueError as error:
        parser.error(str(error))
    name = args.name or f"{args.kind}_seed{args.seed}"
    people = getattr(args, "people", 0)
    if people and args.kind != "office":
        parser.error("--people: only for office")
    try:
        agents = office_walkers(layout, people, args.seed) if people else None
    except ValueError as error:
        parser.error(str(error))
    world = write_layout(layout, args.out or Path.cwd(), name, args.robot, agents)
    if args.preview:
        _preview(world.parent / f"{name}.yaml", layout.start, world.parent / f"{name}_preview.png", layout.description)
    print(world)
    return 0


if __name__ == "__main__":
    sys.exit(main())
