"""The TurtleBot robot kind, the camera's world-file fields and the ping-pong world: defaults, sensors, bumpers,
and bad input that names the file and the field."""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

import subsim
from subsim.raycast import BUMP_CENTRE, BUMP_LEFT, BUMP_RIGHT
from subsim.world import CameraSpec, WorldError, load_world

PICTURES = Path(subsim.__file__).resolve().parent / "pictures"


def world_file(tmp_path: Path, body: str, size: int = 60) -> Path:
    """A 3 m x 3 m walled room at 5 cm, and a world file with `body` (YAML) after its map line."""
    image = np.full((size, size), 254, np.uint8)
    image[:4, :], image[-4:, :], image[:, :4], image[:, -4:] = 0, 0, 0, 0
    cv2.imwrite(str(tmp_path / "box.pgm"), image)
    (tmp_path / "box.yaml").write_text("image: box.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                                       "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    path = tmp_path / "w.yaml"
    path.write_text("map: box.yaml\n" + body)
    return path


def test_turtlebot_defaults_kobuki_base_kinect_and_no_sonar_or_laser(tmp_path):
    world = load_world(world_file(tmp_path, "robots:\n  - {name: tb, kind: turtlebot, start: [1.5, 1.5, 0]}\n"))
    spec = world.robots[0]
    assert spec.kind == "turtlebot" and spec.radius == 0.177
    assert (spec.limits.max_v, spec.limits.max_w) == (0.7, 3.0)
    assert spec.sonar is None and spec.laser is None
    assert spec.camera == CameraSpec()
    assert (spec.camera.width, spec.camera.height, spec.camera.hfov_deg) == (640, 480, 57.0)


def test_turtlebot_sensors_only_when_asked_and_plain_robots_unchanged(tmp_path):
    world = load_world(world_file(tmp_path, """robots:
  - {name: tb, kind: turtlebot, start: [1.0, 1.0, 0], sensors: {sonar: {count: 6}, laser: true, camera: false},
     limits: {max_v: 0.5}}
  - {name: old, start: [2.0, 2.0, 0]}
"""))
    tb, old = world.robots
    assert tb.sonar.count == 6 and tb.laser is not None and tb.camera is None
    assert (tb.limits.max_v, tb.limits.max_w) == (0.5, 3.0)  # the given field, the Kobuki's for the rest
    assert old.kind == "robot" and old.radius == 0.18 and old.sonar.count == 12 and old.camera is None
    assert old.limits.max_w == 2.0


@pytest.mark.parametrize("heading, bit", [(0.0, BUMP_CENTRE), (-math.pi / 2, BUMP_LEFT), (math.pi / 2, BUMP_RIGHT)])
def test_turtlebot_bumpers_tell_the_side(tmp_path, heading, bit):
    """Driving into the east wall: head-on presses the centre bumper; with the wall on its left (heading south)
    the left one, on its right the right one."""
    x = 3.0 - 0.2 - 0.177 - 0.01 if heading == 0.0 else 3.0 - 0.2 - 0.177 - 0.002
    sim = subsim.Simulation(world_file(tmp_path, f"robots:\n  - {{name: tb, kind: turtlebot, start: [{x}, 1.5, {heading}]}}\n"))
    robot = sim.robots["tb"]
    for _ in range(25):
        sim.set_command("tb", 0.3 if heading == 0.0 else 0.0, 0.0)
        sim.step(0.02)
        if heading != 0.0:  # brush the wall sideways
            robot.x += 0.001
    assert robot.bumper == bit and robot.collisions >= 1


def test_turtlebot_has_no_scan_of_its_own():
    """Its scan is the depth scan (vision.depth_scan), not a laser of the simulator's."""
    sim = subsim.Simulation(subsim.world_path("pingpong"))
    reading = sim.sense("robot0")
    assert reading.laser.size == 0 and reading.sonar.size == 0


def test_pingpong_world():
    world = load_world(subsim.world_path("pingpong"))
    assert world.robots[0].kind == "turtlebot"
    table = world.scene.boxes[0]
    x0, y0, x1, y1 = table.rect
    assert (x1 - x0, y1 - y0) == pytest.approx((2.74, 1.525)) and table.height == 0.76
    # the table is solid in the map (robots go round it); the room is 10 m x 6 m inside its walls
    assert world.map.occupancy[world.map.cell_of(5.2, 3.2)] == 100
    target = world.agents[0]
    assert target.picture is not None and Path(target.picture.file).name == "face_astronaut.png"
    sim = subsim.Simulation(world)
    start = sim.agents["target"].pose()
    for _ in range(int(9.0 / 0.05)):  # it waits 10 s in the corridor before coming in
        sim.step(0.05)
    assert sim.agents["target"].pose() == start
    seen_in_room = left_east = False
    for _ in range(int(90 / 0.05)):
        sim.step(0.05)
        target = sim.agents["target"]
        seen_in_room |= target.y < 3.0
        left_east |= seen_in_room and target.y > 6.4 and target.x > 7.0
    assert seen_in_room and left_east  # came in by the west door, crossed the room, left by the east door


@pytest.mark.parametrize("body, field", [
    ("robots:\n  - {name: r, kind: roomba}\n", "robots[0].kind"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {x: 0.5}}}\n", "robots[0].sensors.camera.x"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {hfov_deg: 170}}}\n", "robots[0].sensors.camera.hfov_deg"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {width: 5}}}\n", "robots[0].sensors.camera.width"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {height: 480.5}}}\n", "robots[0].sensors.camera.height"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {mode: colour}}}\n", "robots[0].sensors.camera.mode"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {depth_encoding: 16UC3}}}\n",
     "robots[0].sensors.camera.depth_encoding"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {min_range: 9}}}\n", "robots[0].sensors.camera.min_range"),
    ("robots:\n  - {name: r, kind: turtlebot, sensors: {camera: {zoom: 2}}}\n", "robots[0].sensors.camera.zoom"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 1]], picture: {file: nothere.png}}\n",
     "agents[0].picture.file"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 1]], picture: {height: 0.4}}\n",
     "agents[0].picture.file"),
    ("robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 1]], colour: [300, 0, 0]}\n", "agents[0].colour"),
    ("robots:\n  - {name: r}\nscene: {boxes: [{rect: [1, 1, 0.5, 2], height: 0.7}]}\n", "scene.boxes[0].rect"),
    ("robots:\n  - {name: r}\nscene: {boxes: [{rect: [1, 1, 1.5, 2]}]}\n", "scene.boxes[0].height"),
    ("robots:\n  - {name: r}\nscene: {pictures: [{file: " + str(PICTURES / "poster_clock.png") + "}]}\n",
     "scene.pictures[0].at"),
])
def test_bad_camera_world_input_names_file_and_field(tmp_path, body, field):
    path = world_file(tmp_path, body)
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert str(path) in str(err.value) and err.value.field == field, str(err.value)


def test_unreadable_picture_names_file_and_field(tmp_path):
    (tmp_path / "broken.png").write_bytes(b"not a png")
    path = world_file(tmp_path, "robots:\n  - {name: r}\nagents:\n  - {name: p, waypoints: [[1, 1]], "
                                "picture: {file: broken.png}}\n")
    with pytest.raises(WorldError, match=r"w.yaml: field 'agents\[0\].picture.file': cannot read .*broken.png"):
        load_world(path)
