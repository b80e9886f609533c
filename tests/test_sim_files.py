"""Map and world files: map_server semantics, shipped worlds, and errors that name the file and the field."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

import subsim
from subsim.mapio import FREE, OCCUPIED, UNKNOWN, MapError, load_map, save_map
from subsim.world import WorldError, load_world

MAP_YAML = """image: tiny.pgm
resolution: 0.1
origin: [-1.0, 2.0, 0.0]
negate: {negate}
occupied_thresh: 0.65
free_thresh: 0.196
"""


def tiny_map(tmp_path: Path, negate: int = 0, text: str | None = None) -> Path:
    # top image row: black, grey, white; bottom row: white, white, white
    image = np.array([[0, 205, 254], [254, 254, 254]], dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "tiny.pgm"), image)
    path = tmp_path / "tiny.yaml"
    path.write_text(MAP_YAML.format(negate=negate) if text is None else text)
    return path


def test_map_server_semantics_and_layout(tmp_path):
    grid = load_map(tiny_map(tmp_path))
    assert grid.resolution == 0.1 and grid.origin == (-1.0, 2.0)
    # row 0 is the bottom of the image (lowest y), as in nav_msgs/OccupancyGrid
    assert grid.occupancy.tolist() == [[FREE, FREE, FREE], [OCCUPIED, UNKNOWN, FREE]]
    assert grid.cell_of(-0.95, 2.15) == (1, 0)


def test_negate_inverts(tmp_path):
    grid = load_map(tiny_map(tmp_path, negate=1))
    # with negate, p = value / 255: grey 205 gives 0.80 > occupied_thresh
    assert grid.occupancy.tolist() == [[OCCUPIED, OCCUPIED, OCCUPIED], [FREE, OCCUPIED, OCCUPIED]]


def test_save_and_load_round_trip(tmp_path):
    occupancy = np.array([[0, 100, -1], [0, 0, 100]], dtype=np.int8)
    path = save_map(occupancy, tmp_path / "m.yaml", 0.05, (1.0, -2.0))
    grid = load_map(path)
    assert np.array_equal(grid.occupancy, occupancy)
    assert grid.origin == (1.0, -2.0)


@pytest.mark.parametrize("text, field", [
    ("image: tiny.pgm\norigin: [0, 0, 0]\n", "resolution"),
    ("image: tiny.pgm\nresolution: -0.1\norigin: [0, 0, 0]\n", "resolution"),
    ("image: tiny.pgm\nresolution: fine\norigin: [0, 0, 0]\n", "resolution"),
    ("image: nothere.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", "image"),
    ("resolution: 0.1\norigin: [0, 0, 0]\n", "image"),
    ("image: tiny.pgm\nresolution: 0.1\norigin: [0, 0]\n", "origin"),
    ("image: tiny.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 2\n", "negate"),
    ("image: tiny.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thresh: 0.9\noccupied_thresh: 0.5\n",
     "occupied_thresh"),
    ("image: [tiny.pgm\n", "(file)"),
])
def test_bad_map_file_names_file_and_field(tmp_path, text, field):
    path = tiny_map(tmp_path, text=text)
    with pytest.raises(MapError) as err:
        load_map(path)
    assert str(path) in str(err.value)
    assert f"'{field}'" in str(err.value)
    assert err.value.field == field


@pytest.mark.parametrize("name", ["room", "corridors", "sparse"])
def test_shipped_worlds_load_with_a_free_start(name):
    world = load_world(subsim.world_path(name))
    assert world.map.resolution == 0.05
    sim = subsim.Simulation(world)
    robot = sim.robots["robot0"]
    assert sim.gap(robot.x, robot.y, robot.radius, sim.circles("robot0")) >= 0.05


def test_shipped_map_sizes():
    sizes = {name: load_world(subsim.world_path(name)).map for name in ("room", "corridors", "sparse")}
    assert (sizes["room"].width_m, sizes["room"].height_m) == (6.0, 6.0)
    assert (sizes["corridors"].width_m, sizes["corridors"].height_m) == (20.0, 12.0)
    assert (sizes["sparse"].width_m, sizes["sparse"].height_m) == (20.0, 20.0)


def world_file(tmp_path: Path, body: str) -> Path:
    tiny_map(tmp_path)
    path = tmp_path / "w.yaml"
    path.write_text("map: tiny.yaml\n" + body)
    return path


@pytest.mark.parametrize("body, field", [
    ("robots: []\n", "robots"),
    ("robots:\n  - {name: r, limits: {max_v: fast}}\n", "robots[0].limits.max_v"),
    ("robots:\n  - {name: r, limits: {top_speed: 1}}\n", "robots[0].limits.top_speed"),
    ("robots:\n  - {name: r, start: [1, 2, 3, 4]}\n", "robots[0].start"),
    ("robots:\n  - {name: r, radius: 0}\n", "robots[0].radius"),
    ("robots:\n  - {name: r, sensors: {sonar: {count: 0}}}\n", "robots[0].sensors.sonar.count"),
    ("robots:\n  - {name: r}\n  - {name: r}\n", "robots[1].name"),
    ("robots:\n  - {name: a, namespace: ''}\n  - {name: b}\n", "robots[0].namespace"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, motion: fly}\n", "agents[0].motion"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p}\n", "agents[0].waypoints"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, motion: wander}\n", "agents[0].start"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 2], [3]]}\n", "agents[0].waypoints[1]"),
    ("robot:\n  - {name: r}\n", "robot"),
    ("robots:\n  - {name: r, odom_turn_noise: -0.1}\n", "robots[0].odom_turn_noise"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 2]], cue: {robot: s, near: [0, 0], within: 1}}\n",
     "agents[0].cue.robot"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 2]], cue: {robot: r, near: [0, 0]}}\n",
     "agents[0].cue.within"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 2]], cue: {robot: r, at: [0, 0], within: 1}}\n",
     "agents[0].cue.at"),
])
def test_bad_world_file_names_file_and_field(tmp_path, body, field):
    path = world_file(tmp_path, body)
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert str(path) in str(err.value)
    assert err.value.field == field, str(err.value)


def test_world_with_missing_map_names_the_map_field(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text("map: nowhere.yaml\nrobots: [{name: r}]\n")
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert err.value.field == "map" and "nowhere.yaml" in str(err.value)


def test_world_whose_map_name_the_system_cannot_look_up_names_the_map_field(tmp_path):
    """A map path longer than the system looks up (ENAMETOOLONG) is a WorldError on 'map', not an OSError."""
    path = tmp_path / "w.yaml"
    path.write_text(f"map: {'x' * 300}.yaml\nrobots: [{{name: r}}]\n")
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert err.value.field == "map" and "cannot look up" in str(err.value) and str(path) in str(err.value)


def test_world_fields_are_read(tmp_path):
    path = world_file(tmp_path, """robots:
  - name: r
    namespace: ''
    start: [0.0, 2.5]
    limits: {max_v: 0.3}
    sensors: {laser: false, sonar: {count: 8, noise: 0.01}}
agents:
  - {name: p, waypoints: [[0, 2.1], [0.5, 2.1]], speed: 0.5}
  - {name: q, kind: robot, motion: wander, start: [0, 2.3, 1.0]}
""")
    world = load_world(path)
    r = world.robots[0]
    assert (r.namespace, r.start, r.limits.max_v, r.laser, r.sonar.count, r.sonar.noise) == \
        ("", (0.0, 2.5, 0.0), 0.3, None, 8, 0.01)
    p, q = world.agents
    assert (p.kind, p.motion, p.speed, p.radius, p.waypoints) == ("person", "waypoints", 0.5, 0.25,
                                                                  ((0.0, 2.1), (0.5, 2.1)))
    assert (q.kind, q.motion, q.radius, q.start) == ("robot", "wander", 0.18, (0.0, 2.3, 1.0))


def test_start_pose_inside_a_wall_is_an_error_naming_the_robot(tmp_path):
    path = world_file(tmp_path, "robots:\n  - {name: r, start: [-0.95, 2.15, 0]}\n")  # the black cell
    with pytest.raises(WorldError) as err:
        subsim.Simulation(path)
    assert err.value.field == "robots[0].start" and str(path) in str(err.value)


def test_agent_starting_in_a_wall_is_an_error_naming_its_field():
    path = subsim.MAPS / "room_world.yaml"
    world = load_world(path)
    from subsim.world import AgentSpec
    world.agents = [AgentSpec("p", waypoints=((0.1, 3.0), (2.0, 3.0)))]
    with pytest.raises(WorldError) as err:
        subsim.Simulation(world)
    assert err.value.field == "agents[0].waypoints[0]" and str(path) in str(err.value)
