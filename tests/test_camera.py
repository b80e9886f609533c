"""The RGB-D camera's geometry, checked against hand-worked pinhole geometry in small made-up rooms, and the
stock OpenCV face detector on rendered faces."""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

import subsim
from subsim.camera import Pinhole
from subsim.mapio import FREE, OCCUPIED, save_map

PICTURES = Path(subsim.__file__).resolve().parent / "pictures"
RES = 0.05
ROOM = 8.0  # m: walls 0.2 m thick, so the inside runs from 0.2 to 7.8
CAM_X = 1.0  # camera x (the robot's camera sits at its centre in these worlds)


def make_world(tmp_path: Path, agents=(), boxes=(), pictures=(), camera=None, robot_y=4.0, robot_yaw=0.0) -> Path:
    grid = np.full((int(ROOM / RES), int(ROOM / RES)), FREE, np.int8)
    wall = int(0.2 / RES)
    grid[:wall, :], grid[-wall:, :], grid[:, :wall], grid[:, -wall:] = OCCUPIED, OCCUPIED, OCCUPIED, OCCUPIED
    save_map(grid, tmp_path / "room.yaml", RES)
    cam = {"x": 0.0, "max_range": 10.0}
    cam.update(camera or {})
    world = {"map": "room.yaml",
             "scene": {"boxes": list(boxes), "pictures": list(pictures)},
             "robots": [{"name": "tb", "namespace": "", "kind": "turtlebot", "start": [CAM_X, robot_y, robot_yaw],
                         "sensors": {"camera": cam, "laser": {"max_range": 10.0}}}],
             "agents": list(agents)}
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(world))
    return path


def solid_png(tmp_path: Path, name: str, rgb: tuple[int, int, int], size=(100, 100)) -> str:
    path = tmp_path / f"{name}.png"
    image = np.zeros((*size, 3), np.uint8)
    image[:] = rgb[::-1]
    cv2.imwrite(str(path), image)
    return str(path)


def frame_of(path: Path, seed: int = 0):
    sim = subsim.Simulation(path, seed=seed)
    return sim, sim.render("tb"), sim.camera("tb").pinhole


def test_pinhole_is_the_kinects():
    spec = subsim.world.CameraSpec()
    p = Pinhole.from_fov(spec.width, spec.height, math.radians(spec.hfov_deg))
    assert p.fx == pytest.approx(320 / math.tan(math.radians(28.5))) and p.fx == p.fy
    assert (p.cx, p.cy, p.width, p.height) == (319.5, 239.5, 640, 480)
    assert p.vfov_deg == pytest.approx(44.3, abs=0.1)
    assert p.P[:3] == p.K[:3] and p.P[3] == 0.0


def test_wall_at_known_distance_has_that_depth_in_every_column(tmp_path):
    """Facing a wall square on, the optical z of every pixel of it is the wall's distance (within a cell)."""
    _, frame, p = frame_of(make_world(tmp_path))
    distance = 7.8 - CAM_X
    wall_rows = slice(int(p.cy - 60), int(p.cy + 20))  # the wall meets the floor at cy + fy * 0.287 / 6.8 = cy + 25
    assert np.all(np.abs(frame.depth[wall_rows] - distance) <= RES)
    # the floor below: row v sees the floor at z = fy * h / (v - cy)
    v = 400
    assert frame.depth[v, 320] == pytest.approx(p.fy * 0.287 / (v - p.cy), rel=1e-4)
    # and the colour is registered: the wall's colour where depth says wall, the floor's where it says floor
    assert tuple(frame.rgb[240, 320]) == (196, 192, 180)


def test_picture_of_known_width_spans_f_w_over_d_pixels(tmp_path):
    red = solid_png(tmp_path, "red", (255, 0, 0), size=(100, 150))  # 1.5 : 1
    for distance in (2.0, 4.0):
        folder = tmp_path / f"d{distance}"
        folder.mkdir()
        picture = {"file": red, "at": [CAM_X + distance, 4.0], "yaw": math.pi, "height": 0.4, "centre": 0.287}
        _, frame, p = frame_of(make_world(folder, pictures=[picture]))
        row = frame.rgb[240]
        red_columns = np.flatnonzero((row[:, 0] > 200) & (row[:, 1] < 50))
        expected = p.fx * 0.6 / distance
        assert len(red_columns) == pytest.approx(expected, abs=2), distance
        assert red_columns.mean() == pytest.approx(p.cx, abs=1)
        column = frame.rgb[:, 320]
        red_rows = np.flatnonzero((column[:, 0] > 200) & (column[:, 1] < 50))
        assert len(red_rows) == pytest.approx(p.fy * 0.4 / distance, abs=2)
        assert np.all(np.abs(frame.depth[red_rows, 320] - distance) < 1e-3)


def test_box_hides_what_is_behind_it_and_nothing_is_seen_through_walls(tmp_path):
    red = solid_png(tmp_path, "red", (255, 0, 0))
    picture = {"file": red, "at": [6.0, 4.0], "yaw": math.pi, "height": 1.0, "centre": 0.5}
    box = {"name": "crate", "rect": [3.0, 3.7, 3.4, 4.3], "height": 1.5, "colour": [0, 0, 255]}
    # a person behind the far wall (outside the room is solid here; a second room would be the same)
    _, frame, p = frame_of(make_world(tmp_path, boxes=[box], pictures=[picture]))
    band = frame.rgb[200:280]
    # the picture is 1 m wide at 5 m (118 px), the crate 0.6 m at 2 m (177 px): the picture is all hidden
    assert not np.any((band[..., 0] > 200) & (band[..., 2] < 50))
    centre = frame.depth[200:280, 300:340]
    assert np.all(np.abs(centre - (3.0 - CAM_X)) <= RES)
    # beside the crate, the wall at 6.8 m
    assert abs(frame.depth[240, 5] - (7.8 - CAM_X)) <= RES


def test_camera_sees_over_a_table_to_the_wall_beyond(tmp_path):
    table = {"name": "table", "rect": [3.0, 2.5, 4.5, 5.5], "height": 0.76, "colour": [30, 70, 130]}
    _, frame, p = frame_of(make_world(tmp_path, boxes=[table]))
    z_table, z_wall = 3.0 - CAM_X, 7.8 - CAM_X
    top_row = p.cy - p.fy * (0.76 - 0.287) / z_table  # the table's front top edge
    column = frame.depth[:, 320]
    assert np.all(np.abs(column[int(top_row) + 2:int(top_row) + 40] - z_table) <= RES)  # the table's side
    # over the table top the rays reach the wall at 0.287 + (0.76 - 0.287) * 6.8 / 2 = 1.9 m and above
    above = column[int(top_row) - 40:int(top_row) - 1]
    assert np.all(np.abs(above - z_wall) <= RES)  # the far wall, over the table
    # in the scan plane (0.287 m) the table is an obstacle
    assert abs(frame.depth[int(p.cy), 320] - z_table) <= RES


def test_agent_is_an_upright_cylinder_of_its_height(tmp_path):
    person = {"name": "p", "kind": "person", "motion": "waypoints", "waypoints": [[7.0, 4.0]], "radius": 0.25,
              "height": 1.7, "colour": [200, 20, 20]}
    _, frame, p = frame_of(make_world(tmp_path, agents=[person]))
    z = 7.0 - 0.25 - CAM_X
    head = p.cy - p.fy * (1.7 - 0.287) / z
    assert abs(frame.depth[int(head) + 3, 320] - z) <= 0.01
    assert abs(frame.depth[int(head) - 3, 320] - (7.8 - CAM_X)) <= RES  # over its head: the wall
    width = np.count_nonzero(frame.depth[240] < 6.3)  # the body's columns (it is round: 5.75-6.0 m)
    assert width == pytest.approx(2 * p.fx * math.tan(math.asin(0.25 / 6.0)), abs=2)


def test_depth_limits_and_noise_are_seeded(tmp_path):
    path = make_world(tmp_path, camera={"max_range": 5.0, "noise": 0.01})
    _, a, _ = frame_of(path, seed=3)
    _, b, _ = frame_of(path, seed=3)
    _, c, _ = frame_of(path, seed=4)
    assert np.array_equal(a.depth, b.depth, equal_nan=True) and np.array_equal(a.rgb, b.rgb)
    assert not np.array_equal(a.depth, c.depth, equal_nan=True)
    assert np.all(np.isnan(a.depth[200:260]))  # the wall at 6.8 m is beyond max_range (floor nearer from 273)
    near = a.depth[470]  # floor 0.65 m ahead
    assert np.all(np.isfinite(near)) and np.std(near - np.median(near)) < 0.02


def test_render_uses_the_same_state_as_the_laser(tmp_path):
    """After steps with an agent walking, the camera and the laser see the agent at the same place."""
    person = {"name": "p", "kind": "person", "motion": "waypoints", "waypoints": [[4.0, 6.0], [4.0, 2.0]],
              "speed": 1.0}
    sim = subsim.Simulation(make_world(tmp_path, agents=[person]))
    for _ in range(100):
        sim.step(0.02)
    frame, reading = sim.render("tb"), sim.sense("tb")
    centre_beam = len(reading.laser) // 2
    p = sim.camera("tb").pinhole
    assert frame.depth[int(p.cy), int(p.cx)] == pytest.approx(reading.laser[centre_beam], abs=RES)


def test_depth_band_mode_renders_only_the_band(tmp_path):
    _, full, p = frame_of(make_world(tmp_path))
    folder = tmp_path / "band"
    folder.mkdir()
    _, band, _ = frame_of(make_world(folder, camera={"mode": "depth_band", "band_rows": 12}))
    assert band.rgb is None and band.depth.shape == (12, 640)
    assert np.array_equal(band.depth, full.depth[band.row0:band.row0 + 12], equal_nan=True)
    assert band.row0 == round(p.cy - 5.5)


# Faces ---------------------------------------------------------------------------------------------------
HAAR = cv2.data.haarcascades + "haarcascade_frontalface_alt2.xml"


def faces_in(rgb: np.ndarray) -> list:
    cascade = cv2.CascadeClassifier(HAAR)
    gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    return list(cascade.detectMultiScale(gray, 1.1, 3, minSize=(20, 20)))


def target_view(tmp_path: Path, picture: str, distance: float, turn_deg: float, height: float = 0.45):
    """The camera looking at a robot `distance` m ahead (to its card) that carries `picture`, turned by turn_deg."""
    folder = tmp_path / f"{Path(picture).stem}_{distance}_{turn_deg}"
    folder.mkdir()
    x = CAM_X + distance + 0.19
    target = {"name": "target", "kind": "robot", "motion": "waypoints", "waypoints": [[x, 4.0]],
              "start": [x, 4.0, math.pi + math.radians(turn_deg)],
              "picture": {"file": picture, "height": height, "centre": 0.62}}
    _, frame, p = frame_of(make_world(folder, agents=[target]))
    return frame, p


@pytest.mark.parametrize("distance", [1.5, 3.0])
@pytest.mark.parametrize("turn_deg", [0.0, 30.0])
@pytest.mark.parametrize("face", ["face_astronaut", "face_grace_hopper"])
def test_stock_haar_finds_the_rendered_face(tmp_path, face, distance, turn_deg):
    frame, p = target_view(tmp_path, str(PICTURES / f"{face}.png"), distance, turn_deg,
                           0.45 if face == "face_astronaut" else 0.42)
    found = faces_in(frame.rgb)
    assert len(found) == 1, found
    x, y, w, h = found[0]
    assert w == pytest.approx(p.fx * 0.16 / distance, rel=0.3)  # the face is 0.16 m tall: f * H / d
    assert abs(x + w / 2 - p.cx) < p.fx * 0.23 / distance  # on the card (0.45 m wide), in the middle


@pytest.mark.parametrize("poster", ["poster_chelsea", "poster_coffee", "poster_rocket", "poster_clock"])
def test_stock_haar_finds_no_face_in_a_poster_in_its_place(tmp_path, poster):
    for distance in (1.5, 3.0):
        frame, _ = target_view(tmp_path, str(PICTURES / f"{poster}.png"), distance, 0.0, 0.3)
        assert faces_in(frame.rgb) == []
