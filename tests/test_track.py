"""The TLD-style tracker through the issue's occlusion: a person walks between the camera and the target and
hides it for 3 s while another face stands beside its path (composited real photos; seeds not tuned on)."""
from __future__ import annotations

import numpy as np
import pytest
from sensor_msgs.msg import RegionOfInterest

from subsumption.testing import Harness
from support import photoscene as ps
from vision.boxes import Box
from vision.modules import Track
from vision.tracking import TargetTracker, TrackerError, TrackerSettings

FPS = 15.0  # half a Kinect's rate: larger steps between frames than the robot's camera gives


def test_target_kept_lost_behind_a_passer_by_and_found_again_not_the_other_face():
    walkers, passersby, still, timing = ps.occlusion_scene(seed=3)
    frames = list(ps.sequence(walkers, timing["duration_s"], FPS, passersby, still, seed=3))
    tracker = TargetTracker()
    tracker.start(frames[0][1].rgb, Box.of(frames[0][1].faces["astronaut"]))
    on_target, confident_while_hidden, on_other, refound_at = [], 0, 0, None
    for t, frame in frames[1:]:
        state = tracker.update(frame.rgb)
        truth, other = frame.faces.get("astronaut"), frame.faces.get("grace_hopper")
        if truth:
            on_target.append(state.confident and state.box.iou(Box.of(truth)) >= 0.5)
            if refound_at is None and t >= timing["hidden_until_s"] and on_target[-1]:
                refound_at = t
        elif state.confident:
            confident_while_hidden += 1
        if state.confident and other and state.box.iou(Box.of(other)) > 0.2:
            on_other += 1
    back_in_view = next(t for t, f in frames if t >= timing["hidden_until_s"] and "astronaut" in f.faces)
    assert np.mean(on_target) >= 0.95
    assert confident_while_hidden == 0 and on_other == 0
    assert refound_at is not None and refound_at - back_in_view <= 1.0


def test_track_module_publishes_the_box_with_the_image_header_and_a_zero_box_when_lost():
    harness = Harness(Track)
    frame = ps.render([ps.Placed(ps.astronaut(), 0.0, 1.5, 0.45)], seed=1)
    image, _, info = ps.messages(frame, 12.5)
    harness.feed("camera_info", info)
    harness.feed("image", image)
    assert harness.sent("box_info") == []  # nothing to track yet
    harness.feed("target", Box.of(frame.faces["astronaut"]).to_roi())
    later, _, _ = ps.messages(frame, 12.6)
    harness.feed("image", later)
    sent = harness.sent("box_info")[-1]
    assert sent.header.stamp == later.header.stamp and sent.header.frame_id == later.header.frame_id
    assert list(sent.K) == list(info.K)
    assert Box.from_roi(sent.roi).iou(Box.of(frame.faces["astronaut"])) >= 0.7
    assert harness.sent("confident")[-1].data is True
    empty = ps.render([], seed=2)
    harness.feed("image", ps.messages(empty, 12.7)[0])
    assert harness.sent("box")[-1] == RegionOfInterest() and harness.sent("confident")[-1].data is False
    harness.feed("target", RegionOfInterest())  # a zero box clears the target: nothing more is sent
    count = len(harness.sent("box_info"))
    harness.feed("image", ps.messages(frame, 12.8)[0])
    assert len(harness.sent("box_info")) == count


def test_bad_tracker_settings_are_named():
    with pytest.raises(TrackerError, match="unknown short-term tracker 'fast'"):
        TrackerSettings(short_term="fast")
    with pytest.raises(TrackerError, match="too small or outside"):
        TargetTracker().start(ps.render([], seed=0).rgb, Box(700, 10, 20, 20))


def test_a_target_lost_for_long_is_searched_for_less_often():
    """Lost, the tracker searches every `search_every` frames; once lost for `slow_after` frames (3 s at 30 frames/s:
    by then detect takes a face seen again for a new suspect and hands track its box) only every
    `slow_search_every`: the whole-image search is the larger part of level 4's CPU while the patrol goes on."""
    frame = ps.render([ps.Placed(ps.astronaut(), 0.0, 1.5, 0.45)], seed=1)
    empty = ps.render([], seed=2).rgb
    tracker = TargetTracker(TrackerSettings(search_every=3, slow_after=30, slow_search_every=10))
    tracker.start(frame.rgb, Box.of(frame.faces["astronaut"]))
    searched: list[int] = []
    search = tracker._search
    tracker._search = lambda *args: searched.append(tracker._lost_frames) or search(*args)
    for _ in range(60):
        assert tracker.update(empty).box is None
    assert searched == [1, 4, 7, 10, 13, 16, 19, 22, 25, 28, 31, 41, 51]
