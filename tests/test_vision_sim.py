"""Level 4's vision on the simulator's rendered camera frames (not composited photos): faces found at known
distances where the ground truth projects them, an enrolled person told from a stranger, and the target kept
through a 3 s occlusion by a person walking between. The truth boxes come from experiments.face_truth's
projection, so these tests also check the scoring the level-4 metrics rest on."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from experiments.face_truth import CameraModel, face_cards, in_view, iou, project_face
from subsim import Simulation, world_path
from subsim.world import load_world
from support import photoscene as ps
from vision.boxes import Box
from vision.faces import FaceDetector, to_gray
from vision.recognition import enrol
from vision.replay import Pipeline
from vision.tracking import TargetTracker

PICTURES = Path(world_path("pingpong")).parent.parent / "pictures"
ROBOT_AT = (1.0, 1.5, 0.0)  # the ping-pong room's south strip: 9 m free ahead (east), the table north of it


def _world(tmp_path: Path, agents: list[dict]) -> Path:
    """The ping-pong room with the robot at ROBOT_AT and these agents."""
    data = yaml.safe_load(world_path("pingpong").read_text())
    base = world_path("pingpong").parent
    data["map"] = str((base / data["map"]).resolve())
    for picture in data["scene"]["pictures"]:
        picture["file"] = str((base / picture["file"]).resolve())
    data["robots"][0]["start"] = list(ROBOT_AT)
    data["agents"] = agents
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _standing(name: str, face: str, x: float, y: float = ROBOT_AT[1], facing_west: bool = True) -> dict:
    """A target robot standing still at (x, y) with a face card turned towards the camera (west)."""
    return {"name": name, "kind": "robot", "motion": "waypoints", "speed": 0.3, "wait": 1000.0, "loop": False,
            "waypoints": [[x, y], [x - 1.0 if facing_west else x + 1.0, y]],
            "picture": {"file": str(PICTURES / f"face_{face}.png"), "height": 0.45, "centre": 0.62}}


def _truth(world: Path, sim: Simulation, card_index: int = 0) -> np.ndarray | None:
    loaded = load_world(world)
    camera = CameraModel.of(loaded.robots[0].camera)
    card = face_cards(loaded)[card_index]
    agent = list(sim.agents.values())[card.agent]
    box, _ = project_face(camera, sim.robots["robot0"].pose(), card, (agent.x, agent.y, agent.theta),
                          (loaded.map, loaded.map.solid))
    return box if in_view(box, camera) else None


@pytest.mark.parametrize("distance", [1.5, 2.5, 3.5])
def test_face_found_at_known_distance_where_the_truth_projects_it(tmp_path, distance):
    world = _world(tmp_path, [_standing("target", "astronaut", ROBOT_AT[0] + distance)])
    sim = Simulation(world, seed=0, record=False)
    frame = sim.render("robot0")
    truth = _truth(world, sim)
    assert truth is not None
    found = FaceDetector().detect(to_gray(frame.rgb))
    assert len(found) == 1
    box = found[0]
    assert iou(np.array([box.x, box.y, box.x + box.w, box.y + box.h]), truth) >= 0.5
    agent = next(iter(sim.agents.values()))
    camera_to_card = distance + 0.087 - agent.radius - 0.01  # the camera 8.7 cm behind the centre, the card on the rim
    expected_px = ps.FOCAL_PX * 0.16 / camera_to_card
    assert box.h == pytest.approx(expected_px, rel=0.25)
    depth = frame.depth[int(box.y + box.h / 2), int(box.x + box.w / 2)]
    assert depth == pytest.approx(camera_to_card, abs=0.05)


@pytest.fixture(scope="module")
def staff_model(tmp_path_factory):
    """Grace Hopper enrolled from the photo in robots/patrol/staff (what the patrol robot's run enrols)."""
    folder = Path(__file__).resolve().parent.parent / "robots" / "patrol" / "staff"
    return enrol(folder, log=lambda _: None).save(tmp_path_factory.mktemp("staff") / "staff.npz")


def _frames(sim: Simulation, seconds: float, fps: float):
    """(time, photoscene Frame) of the robot's camera, the world stepped between frames."""
    frames = []
    for k in range(int(seconds * fps)):
        while sim.time < k / fps - 1e-9:
            sim.step(0.02)
        rendered = sim.render("robot0")
        frames.append((sim.time, ps.Frame(rendered.rgb.copy(), rendered.depth.copy())))
    return frames


def test_enrolled_person_no_alarm_stranger_alarm(tmp_path, staff_model):
    world = _world(tmp_path, [_standing("grace", "grace_hopper", 3.4, 1.2),
                              _standing("target", "astronaut", 3.6, 1.9)])
    sim = Simulation(world, seed=0, record=False)
    recording = Pipeline(detect={"model": str(staff_model)}).run(_frames(sim, 1.0, 10.0))
    assert len(recording.alarms) == 1 and len(recording.targets) == 1
    truth = _truth(world, sim, card_index=1)  # the astronaut's card
    target = recording.targets[0][1]
    box = np.array([target.x_offset, target.y_offset, target.x_offset + target.width,
                    target.y_offset + target.height], float)
    assert iou(box, truth) >= 0.5
    assert recording.alarms[0][1].point.x < 0  # the stranger stands left of the optical axis (+y in the room)


def test_enrolled_person_alone_and_posters_raise_nothing(tmp_path, staff_model):
    world = _world(tmp_path, [_standing("grace", "grace_hopper", 3.0)])
    data = yaml.safe_load(world.read_text())
    data["robots"][0]["start"] = [1.0, 1.5, 0.6]  # Grace ahead, then the posters on the east and south walls
    world.write_text(yaml.safe_dump(data, sort_keys=False))
    sim = Simulation(world, seed=0, record=False)
    frames = _frames(sim, 1.0, 10.0)
    for yaw in (0.0, -0.4, -1.2, -1.57):  # look round: Grace, the rocket poster, the cat poster
        sim.robots["robot0"].theta = yaw
        rendered = sim.render("robot0")
        frames += [(frames[-1][0] + 0.1 * (k + 1), ps.Frame(rendered.rgb.copy(), rendered.depth.copy()))
                   for k in range(3)]
    recording = Pipeline(detect={"model": str(staff_model)}).run(frames)
    assert recording.alarms == [] and recording.targets == []


def test_target_kept_through_a_3_s_occlusion_by_a_person_walking_between(tmp_path):
    """The target stands 3 m ahead; a person walks slowly across between, hiding its face for about 3 s."""
    fps = 12.0
    target_x = ROBOT_AT[0] + 3.0
    person = {"name": "passer", "kind": "person", "motion": "waypoints", "speed": 0.17, "loop": False,
              "waypoints": [[2.4, 0.85], [2.4, 2.2]], "colour": [90, 60, 40]}
    world = _world(tmp_path, [_standing("target", "astronaut", target_x), person])
    sim = Simulation(world, seed=0, record=False)
    frames = _frames(sim, 8.0, fps)
    # the truth needs the sim at each frame's time: replay the same world alongside
    replay = Simulation(world, seed=0, record=False)
    truths, covers = [], []
    for t, _ in frames:
        while replay.time < t - 1e-9:
            replay.step(0.02)
        truths.append(_truth(world, replay))
        covers.append(_cover(replay))
    # in view: at least half the face shows (its centre is not behind the person); hidden: none of it shows
    in_view = [box is not None and cover != "hidden" and cover != "centre" for box, cover in zip(truths, covers)]
    hidden_s = sum(1 for v in in_view if not v) / fps
    assert 2.5 <= hidden_s <= 4.0  # the occlusion the issue asks for, about 3 s
    last_hidden = max(t for (t, _), v in zip(frames, in_view) if not v)
    tracker = TargetTracker()
    tracker.start(frames[0][1].rgb, Box(*_xywh(truths[0])))
    on_target, confident_while_hidden, refound_at = [], 0, None
    for (t, frame), truth, view, cover in zip(frames[1:], truths[1:], in_view[1:], covers[1:]):
        state = tracker.update(frame.rgb)
        if view:
            ok = state.confident and iou(_xyxy(state.box), truth) >= 0.5
            on_target.append(ok)
            if refound_at is None and t > last_hidden and ok:
                refound_at = t
        elif cover == "hidden" and state.confident:
            confident_while_hidden += 1
    back_in_view = next(t for (t, _), v in zip(frames, in_view) if t > last_hidden and v)
    assert np.mean(on_target) >= 0.95
    assert confident_while_hidden == 0
    assert refound_at is not None and refound_at - back_in_view <= 1.0


def _cover(sim: Simulation) -> str:
    """How the person walking between hides the face: "none", "part" (less than half), "centre" (more than half)
    or "hidden" (all of it), from where the line of sight to the face passes the person's body."""
    robot = sim.robots["robot0"].pose()
    target, person = list(sim.agents.values())
    cx, cy = robot[0] - 0.087 * math.cos(robot[2]), robot[1] - 0.087 * math.sin(robot[2])
    tx, ty = target.x - target.radius - 0.01, target.y
    dx, dy = tx - cx, ty - cy
    s = max(0.0, min(1.0, ((person.x - cx) * dx + (person.y - cy) * dy) / (dx * dx + dy * dy)))
    gap = math.hypot(cx + s * dx - person.x, cy + s * dy - person.y)
    half_face = 0.055 * s  # half the face's width (0.11 m) at the person's distance
    if gap < person.radius - half_face:
        return "hidden"
    if gap < person.radius:
        return "centre"
    return "part" if gap < person.radius + half_face else "none"


def _xywh(box: np.ndarray) -> tuple[float, float, float, float]:
    return box[0], box[1], box[2] - box[0], box[3] - box[1]


def _xyxy(box: Box) -> np.ndarray:
    return np.array([box.x, box.y, box.x + box.w, box.y + box.h], float)
