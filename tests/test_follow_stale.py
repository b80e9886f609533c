"""Follow and track on a loaded ROS graph: messages queue behind slow callbacks and arrive seconds after their
image (level 4 in the office at load 22: follow steered on boxes up to 12 s old and drove into a room the target
never entered). A box on an image older than a second steers nothing (follow holds still as if the target
were lost); an image older than half a second is not tracked."""
from __future__ import annotations

from subsumption.testing import Harness
from vision import photoscene as ps
from vision.boxes import Box
from vision.modules import Follow, Track


def test_follow_holds_still_on_a_box_from_an_old_image():
    harness = Harness(Follow, params={"distance_m": 1.2})
    frame = ps.render([ps.Placed(ps.astronaut(), 0.6, 2.5, 0.45)], noise=0)
    harness.run_for(5.0)
    _, depth, info = ps.messages(frame, 4.8)
    harness.feed("depth", depth)
    info.roi = Box.of(frame.faces["astronaut"]).to_roi()
    harness.feed("box_info", info)
    fresh = harness.sent("cmd_vel")[-1]
    assert fresh.linear.x > 0 and fresh.angular.z < 0    # a box 0.2 s old: follow it
    _, _, old = ps.messages(frame, 3.0)
    old.roi = info.roi
    harness.feed("box_info", old)
    held = harness.sent("cmd_vel")[-1]
    assert held.linear.x == 0.0 and held.angular.z == 0.0  # 2 s old: hold still


def test_track_skips_images_that_waited_in_the_queue():
    harness = Harness(Track)
    frame = ps.render([ps.Placed(ps.astronaut(), 0.0, 1.5, 0.45)], seed=1)
    harness.run_for(5.0)
    image, _, info = ps.messages(frame, 4.9)
    harness.feed("camera_info", info)
    harness.feed("image", image)
    harness.feed("target", Box.of(frame.faces["astronaut"]).to_roi())
    harness.feed("image", ps.messages(frame, 4.95)[0])
    count = len(harness.sent("box_info"))
    assert count == 1
    harness.feed("image", ps.messages(frame, 4.0)[0])      # a second old: not tracked, nothing sent
    assert len(harness.sent("box_info")) == count
