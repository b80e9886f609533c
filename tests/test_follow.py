"""The follow module's commands for a box left, right, near and far; depth first, size when depth has none."""
from __future__ import annotations

import math

import genpy
import numpy as np
import pytest
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import CameraInfo

from subsumption.images import from_array
from subsumption.testing import Harness
from support import photoscene as ps
from vision.boxes import Box, Pinhole
from vision.follow import FollowSettings, follow_command
from vision.modules import Follow

CAMERA = Pinhole.from_k(ps.intrinsics().ravel(), ps.WIDTH, ps.HEIGHT)


def _face_box(x_m: float, d_m: float) -> tuple[Box, np.ndarray]:
    """Where a 0.16 m face at lateral x and distance d appears (the scene's own projection), and the depth."""
    frame = ps.render([ps.Placed(ps.astronaut(), x_m, d_m, 0.45)], noise=0)
    return Box.of(frame.faces["astronaut"]), frame.depth


@pytest.mark.parametrize("x_m, d_m, turn, drive", [
    (-0.5, 1.2, "left", "hold"), (0.5, 1.2, "right", "hold"),
    (0.0, 2.5, "straight", "forward"), (0.0, 0.7, "straight", "back"),
])
def test_box_left_right_near_far(x_m, d_m, turn, drive):
    box, depth = _face_box(x_m, d_m)
    command = follow_command(box, CAMERA, depth, FollowSettings(distance_m=1.2))
    assert command.range_from == "depth" and command.range_m == pytest.approx(d_m, abs=0.05)
    assert {"left": command.w > 0.3, "right": command.w < -0.3, "straight": abs(command.w) < 0.05}[turn]
    assert {"hold": abs(command.v) < 0.1, "forward": command.v > 0.3, "back": command.v < -0.1}[drive]


def test_range_from_size_when_depth_has_no_reading():
    box, depth = _face_box(0.0, 4.5)
    depth[:] = np.nan  # beyond the sensor's range
    command = follow_command(box, CAMERA, depth, FollowSettings(distance_m=1.2, target_height_m=0.16))
    assert command.range_from == "size" and command.range_m == pytest.approx(4.5, rel=0.1) and command.v > 0


def test_no_forward_motion_into_something_near_ahead():
    box, depth = _face_box(0.0, 2.5)
    depth[200:280, 250:390] = 0.3  # something 0.3 m in front of the base
    assert follow_command(box, CAMERA, depth, FollowSettings()).v == 0.0


def test_no_forward_motion_into_a_door_jamb_beside_the_way():
    """A jamb 0.5 m ahead and 0.15 m to the side: outside the image's middle third, inside the robot's width."""
    box, depth = _face_box(0.0, 2.5)
    u = int(round(CAMERA.cx + 0.15 / 0.5 * CAMERA.fx))  # the column where a point 0.5 m ahead is 0.15 m right
    assert u > 2 * depth.shape[1] // 3
    depth[:, u:u + 12] = 0.5
    assert follow_command(box, CAMERA, depth, FollowSettings(stop_m=0.6)).v == 0.0
    depth[:, u:u + 12] = 3.0  # the same jamb farther away than the target: the way is clear
    assert follow_command(box, CAMERA, depth, FollowSettings(stop_m=0.6)).v > 0.3


def test_no_forward_motion_into_a_wall_too_near_for_the_depth_sensor():
    """The target seen (with depth) past the edge of a wall nearer than the Kinect's 0.45 m: no reading ahead."""
    box, depth = _face_box(0.6, 2.5)
    depth[:, 213:427] = np.nan
    assert not math.isnan(depth[int(box.y + box.h / 2), int(box.x + box.w / 2)])
    assert follow_command(box, CAMERA, depth, FollowSettings()).v == 0.0


def test_follow_module_turns_towards_the_target_then_holds_still_then_falls_silent():
    harness = Harness(Follow, params={"distance_m": 1.2, "hold_s": 1.0})
    frame = ps.render([ps.Placed(ps.astronaut(), 0.6, 2.0, 0.45)], noise=0)
    _, depth, info = ps.messages(frame, 1.0)
    harness.feed("depth", depth)
    info.roi = Box.of(frame.faces["astronaut"]).to_roi()
    harness.feed("box_info", info)
    twist = harness.sent("cmd_vel")[-1]
    assert twist.angular.z < -0.3 and twist.linear.x > 0  # right of centre, too far: turn right, go
    lost = CameraInfo(K=info.K)
    harness.feed("box_info", lost)
    harness.run_for(0.5)
    harness.feed("box_info", lost)
    assert [t.linear.x for t in harness.sent("cmd_vel")[-2:]] == [0.0, 0.0]
    count = len(harness.sent("cmd_vel"))
    harness.run_for(0.6)
    harness.feed("box_info", lost)
    assert len(harness.sent("cmd_vel")) == count  # silent: the suppressor gives the motors back


def test_follow_reads_16uc1_depth_in_millimetres():
    box, depth = _face_box(0.0, 2.0)
    millimetres = np.nan_to_num(depth * 1000).astype(np.uint16)
    harness = Harness(Follow)
    harness.feed("depth", from_array(millimetres, "16UC1"))
    info = CameraInfo(K=list(ps.intrinsics().ravel()), width=640, height=480, roi=box.to_roi())
    harness.feed("box_info", info)
    assert harness.module.last.range_m == pytest.approx(2.0, abs=0.05)


def test_bad_follow_parameter_is_named():
    with pytest.raises(ValueError, match="follow setting distance_m must be > 0"):
        Harness(Follow, params={"distance_m": -1.0})
    assert math.isfinite(CAMERA.fx)


def _target_ahead(gap: float, info: CameraInfo) -> tuple[Box, np.ndarray]:
    """What the Kinect gives of a TurtleBot `gap` m straight ahead with a 0.16 m face on its back, its middle
    0.45 m up: the face's box (f * H / d), and depth: the robot's body and card at `gap`, a wall 6 m away."""
    fx, cx, fy, cy = info.K[0], info.K[2], info.K[4], info.K[5]
    depth = np.full((info.height, info.width), 6.0, np.float32)
    half = int(fx * 0.18 / gap)
    top = int(cy - fy * (0.45 - 0.3 + 0.3) / gap)
    depth[max(0, top):, int(cx) - half:int(cx) + half] = gap  # the card and body below it, down to the floor
    h = fy * 0.16 / gap
    return Box(cx - h / 2, cy - fy * (0.45 - 0.3) / gap - h / 2, h, h), depth


@pytest.mark.parametrize("target_v", [0.0, 0.3])
def test_follow_module_keeps_the_set_distance_behind_a_target_driving_away(target_v):
    """Closed loop in one dimension: the target drives away at target_v; the robot moves as the module
    commands (max_v 0.6). After 20 s the range is the set distance: a proportional law alone trails a 0.3 m/s
    target by 0.3 / k_v = 0.375 m."""
    harness = Harness(Follow, params={"distance_m": 1.2, "max_v": 0.6})
    # a small camera: a quick test
    info = CameraInfo(K=list(ps.intrinsics(160, 120, ps.FOCAL_PX / 4).ravel()), width=160, height=120)
    gap, dt, ranges = 3.0, 1 / 15, []
    for step in range(int(25 / dt)):
        t = 1.0 + step * dt
        box, depth = _target_ahead(gap, info)
        harness.runtime.run_until(t)
        harness.feed("depth", from_array(depth, "32FC1"))
        info.header.stamp = genpy.Time.from_sec(t)
        info.roi = box.to_roi()
        harness.feed("box_info", info)
        v = harness.sent("cmd_vel")[-1].linear.x
        gap += (target_v - v) * dt
        ranges.append(gap)
    assert np.mean(ranges[-75:]) == pytest.approx(1.2, abs=0.08)
    assert min(ranges) > 0.9


def test_follow_stands_still_at_once_on_the_alarm_and_the_wait_counts_from_it():
    """The alarm (detect's, the suspect just found) brings a zero at once, before track's first box; boxes within
    `still_s` of the alarm still get zeros, later ones drive."""
    harness = Harness(Follow, params={"still_s": 1.0, "hold_s": 1.0})
    harness.run_for(5.0)
    harness.feed("alarm", PointStamped())
    assert [(t.linear.x, t.angular.z) for t in harness.sent("cmd_vel")] == [(0.0, 0.0)]
    box, depth = _face_box(0.0, 2.5)  # far: free to drive forward
    harness.feed("depth", from_array(depth, "32FC1"))
    info = CameraInfo(K=list(ps.intrinsics().ravel()), width=640, height=480, roi=box.to_roi())
    harness.run_for(0.6)
    harness.feed("box_info", info)
    assert harness.sent("cmd_vel")[-1].linear.x == 0.0   # track's first box, 0.6 s after the alarm: still
    harness.run_for(0.5)
    harness.feed("box_info", info)
    assert harness.sent("cmd_vel")[-1].linear.x > 0.1    # 1.1 s after the alarm: following


def test_follow_takes_a_target_back_after_an_occlusion_at_once_and_stands_still_for_a_new_one():
    """`still_s` is for a target taken up (the stop): a box after a gap under `new_target_after_s` (5 s, the
    pursuit's `lost_s`) is the target back from behind a passer-by and is followed at once -- standing still
    a second more there let the office's target drive 0.3 m further off; after a longer gap it is a new one."""
    harness = Harness(Follow, params={"still_s": 1.0, "hold_s": 1.0})
    box, depth = _face_box(0.0, 2.5)  # far: free to drive forward
    harness.feed("depth", from_array(depth, "32FC1"))
    info = CameraInfo(K=list(ps.intrinsics().ravel()), width=640, height=480, roi=box.to_roi())
    lost = CameraInfo(K=list(ps.intrinsics().ravel()), width=640, height=480)
    harness.run_for(5.0)
    harness.feed("box_info", info)
    assert harness.sent("cmd_vel")[-1].linear.x == 0.0   # taken up: still
    harness.run_for(1.1)
    harness.feed("box_info", info)
    assert harness.sent("cmd_vel")[-1].linear.x > 0.1    # following
    for _ in range(33):                                  # 3.3 s hidden
        harness.run_for(0.1)
        harness.feed("box_info", lost)
    harness.feed("box_info", info)
    assert harness.sent("cmd_vel")[-1].linear.x > 0.1    # back: followed at once
    harness.run_for(6.0)
    harness.feed("box_info", info)
    assert harness.sent("cmd_vel")[-1].linear.x == 0.0   # 6 s without a box: a new target, still first
