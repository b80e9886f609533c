"""Level 4's scorer (experiments.patrol_vision) on a constructed run as the ROS graph delivers it: detect raises the
alarm on a small (about 20 px) face while the robot turns, the scorer hears the alarm a detection's time after the
image it was found in, and detect's target box on another connection a few milliseconds after the alarm. The
alarm must count as on the target (it was scored at the time heard, with the box looked up by that exact time: a
false alarm), and a box where no suspect's face is must still count as false. The record the scorer writes
(vision_record.json) must score the same when read back."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from experiments.patrol_vision import CameraModel, VisionObserver, face_cards, project_face, rescore, score
from subsim.world import load_world

WORLD = Path(__file__).resolve().parent.parent / "experiments" / "worlds" / "pingpong_intruder_short_world.yaml"
TARGET = (3.6, 5.4, math.pi)       # standing, its card (yaw pi on the agent) facing east, towards the robot
TURN = 0.25                         # rad/s: the robot turns on the spot 4.6 m east of it


def _robot(t: float) -> tuple[float, float, float]:
    return 8.2, 5.4, math.pi - 0.25 + TURN * t


def _observer() -> tuple[VisionObserver, np.ndarray]:
    observer = VisionObserver(None)
    for k in range(31):  # 3 s of 10 Hz ground truth and camera frames
        t = 0.1 * k
        observer.robot_path.append((t, *_robot(t)))
        observer.agent_path.append((t, [TARGET]))
        observer.frame_times.append(t)
    world = load_world(WORLD)
    card = face_cards(world)[0]
    face, _ = project_face(CameraModel.of(world.robots[0].camera), _robot(1.0), card, TARGET)
    assert face is not None and 15 <= face[3] - face[1] <= 25  # a face about 20 px tall, found at t = 1.0 s
    centre, size = (face[:2] + face[2:]) / 2, (face[2:] - face[:2]) * 1.25  # the detector's box: forehead, chin
    box = np.concatenate([centre - size / 2, centre + size / 2]).round()
    observer.alarms.append((1.4, 1.0, (-0.1, 0.3, 4.6)))   # heard 0.4 s after its image, the robot turned 0.1 rad
    observer.targets.append((1.403, box))
    return observer, box


def test_an_alarm_is_scored_in_the_image_it_was_raised_on():
    observer, box = _observer()
    metrics = score(observer, WORLD, [], 3.0).metrics
    assert metrics["false_alarms"] == 0 and metrics["alarms_on_target"] == 1, metrics["alarm_scores"]
    assert metrics["detected_at_s"] == 1.4 and metrics["detected_in_image_s"] == 1.0
    assert metrics["alarm_scores"][0]["iou"] >= 0.5


def test_a_box_where_no_suspect_face_is_stays_a_false_alarm():
    observer, box = _observer()
    shifted = box + np.array([60.0, 0.0, 60.0, 0.0])       # beside the face: a poster, an enrolled person
    observer.alarms.append((2.2, 2.0, (0.4, 0.3, 4.6)))
    observer.targets.append((2.19, shifted))               # heard before its alarm (another connection)
    observer.alarms.append((2.6, 2.5, (0.4, 0.3, 4.6)))    # an alarm whose box never came: not on the target
    metrics = score(observer, WORLD, [], 3.0).metrics
    assert metrics["alarms_on_target"] == 1 and metrics["false_alarms"] == 2, metrics["alarm_scores"]


def test_the_record_scores_the_same_read_back(tmp_path):
    observer, _ = _observer()
    record = tmp_path / "vision_record.json"
    record.write_text(json.dumps(observer.to_record()))
    again = rescore(record, WORLD, duration=3.0)
    assert again == score(observer, WORLD, [], 3.0).metrics
