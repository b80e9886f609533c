"""The generated map families: seeded (same seed, same map; another seed, another map), doorways as wide as
asked and really open in the grid, every start pose free, and the CLI writes a world the simulator loads."""
from __future__ import annotations

import numpy as np
import pytest

from subsim.mapio import FREE, OCCUPIED
from subsim.maps.generate import RES, clutter, hallways, main, office, write_layout
from subsim.world import load_world

KINDS = (office, hallways, clutter)


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
def test_the_same_seed_gives_the_same_map_and_another_seed_another(kind):
    a, b, c = kind(seed=3), kind(seed=3), kind(seed=4)
    assert np.array_equal(a.grid, b.grid) and a.start == b.start and a.doors == b.doors
    assert not np.array_equal(a.grid, c.grid)


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
def test_the_start_pose_is_free_with_room_for_the_robot(kind):
    layout = kind(seed=7)
    x, y, _ = layout.start
    r = int(np.ceil(0.4 / RES))
    row, col = int(y / RES), int(x / RES)
    assert (layout.grid[row - r:row + r + 1, col - r:col + r + 1] == FREE).all()


def _open_width(grid: np.ndarray, door: tuple[float, float, float, float]) -> float:
    """The free run (m) along the wall through the middle of a doorway, measured in the grid itself."""
    x0, y0, x1, y1 = door
    row = int(round((y0 + y1) / 2 / RES - 0.5))
    line = grid[row]
    col = int((x0 + x1) / 2 / RES)
    left = right = col
    while line[left - 1] == FREE:
        left -= 1
    while line[right + 1] == FREE:
        right += 1
    return (right - left + 1) * RES


@pytest.mark.parametrize("width", [0.9, 1.05, 1.2])
def test_office_doorways_are_as_wide_as_asked_and_open(width):
    layout = office(seed=11, door_min=width, door_max=width)
    assert len(layout.doors) == 4
    for door in layout.doors:
        assert _open_width(layout.grid, door) == pytest.approx(width, abs=1e-6)
    assert layout.door_widths == pytest.approx([width] * 4)


def test_office_doorways_fall_in_the_default_range_and_lead_to_four_rooms():
    import cv2

    for seed in range(5):
        layout = office(seed=seed)
        assert all(0.9 - 1e-9 <= w <= 1.2 + 1e-9 for w in layout.door_widths)
        free = (layout.grid == FREE).astype(np.uint8)
        assert cv2.connectedComponents(free, connectivity=4)[0] - 1 == 1  # doorways join everything
        closed = layout.grid.copy()
        for x0, y0, x1, y1 in layout.doors:
            closed[int(round(y0 / RES)):int(round(y1 / RES)), int(round(x0 / RES)):int(round(x1 / RES))] = OCCUPIED
        assert cv2.connectedComponents((closed == FREE).astype(np.uint8), connectivity=4)[0] - 1 == 5  # corridor + 4


def test_clutter_density_adds_boxes():
    walls = (clutter(seed=2, density=0.0).grid == OCCUPIED).sum()
    floor = (clutter(seed=2).grid == FREE).sum() + (clutter(seed=2).grid == OCCUPIED).sum() - walls
    for density in (0.03, 0.06, 0.12):
        boxes = (clutter(seed=2, density=density).grid == OCCUPIED).sum() - walls
        assert boxes / floor == pytest.approx(density, rel=0.35)


def test_the_cli_writes_a_world_the_simulator_loads(tmp_path, capsys):
    assert main(["office", "--seed", "5", "--out", str(tmp_path), "--door-min", "1.0", "--door-max", "1.0"]) == 0
    world_file = tmp_path / "office_seed5_world.yaml"
    assert capsys.readouterr().out.strip() == str(world_file)
    world = load_world(world_file)
    assert world.map.occupancy.shape == office(seed=5).grid.shape
    assert np.array_equal(world.map.occupancy, office(seed=5, door_min=1.0, door_max=1.0).grid)
    assert world.robots[0].start == pytest.approx(office(seed=5).start)


def test_write_layout_names_its_files(tmp_path):
    world = write_layout(hallways(seed=1), tmp_path / "sub", "h")
    assert world == tmp_path / "sub" / "h_world.yaml"
    assert (tmp_path / "sub" / "h.yaml").exists() and (tmp_path / "sub" / "h.pgm").exists()


def test_impossible_arguments_are_one_clear_error(capsys):
    with pytest.raises(SystemExit):
        main(["office", "--door-min", "1.5", "--door-max", "1.0"])
    assert "door_min <= door_max" in capsys.readouterr().err


@pytest.mark.parametrize("seed", [7, 11])
def test_office_people_walk_through_every_door_on_free_ground_and_the_world_loads(tmp_path, seed):
    """--people 2 --robot turtlebot: two walkers, each through every doorway on one side, their whole route (each
    leg, sampled) at least 0.3 m from every wall; the world loads with them and a TurtleBot."""
    assert main(["office", "--seed", str(seed), "--out", str(tmp_path), "--people", "2", "--robot", "turtlebot"]) == 0
    world = load_world(tmp_path / f"office_seed{seed}_world.yaml")
    assert world.robots[0].kind == "turtlebot" and len(world.agents) == 2
    layout = office(seed=seed)
    occupied = np.argwhere(layout.grid == OCCUPIED) * RES + RES / 2  # (row, col) -> (y, x) centres
    through = set()
    for agent in world.agents:
        route = np.array(agent.waypoints + agent.waypoints[:1])
        for a, b in zip(route[:-1], route[1:]):
            for t in np.linspace(0.0, 1.0, 20):
                x, y = a + t * (b - a)
                assert np.hypot(occupied[:, 1] - x, occupied[:, 0] - y).min() >= 0.3
        middle = layout.start[1]  # the corridor's
        for i, (x0, y0, x1, y1) in enumerate(layout.doors):
            wall = max(abs(y0 - middle), abs(y1 - middle))
            if any(x0 < p[0] < x1 and abs(p[1] - middle) > wall + 0.5 for p in route):  # into that room
                through.add(i)
    assert through == set(range(len(layout.doors)))
    assert [a.speed for a in world.agents] == [0.9, 0.8]
