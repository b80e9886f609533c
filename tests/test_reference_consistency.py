"""bench.reference_consistency finds how far a log's first pose sits off its own map, and where the reference jumps:
synthetic corrected logs of a room, their poses exact but the first turned by a degree, or every pose after one
turned by 5 degrees, are found so; the exact ones are not."""
from __future__ import annotations

import math

import numpy as np

from bench.reference_consistency import anchor
from navigation.carmen import CarmenScan


def _room_scans(poses: np.ndarray) -> list[CarmenScan]:
    """180-beam scans of an 8 m x 6 m room with a pillar, taken at `poses` (the ranges cast exactly)."""
    angles = np.radians(np.arange(-90.0, 90.5, 1.0))
    walls = [((-4.0, -3.0), (4.0, -3.0)), ((4.0, -3.0), (4.0, 3.0)), ((4.0, 3.0), (-4.0, 3.0)),
             ((-4.0, 3.0), (-4.0, -3.0)), ((1.0, 0.5), (1.5, 0.5)), ((1.5, 0.5), (1.5, 1.0)),
             ((1.5, 1.0), (1.0, 1.0)), ((1.0, 1.0), (1.0, 0.5))]
    scans = []
    for number, pose in enumerate(poses):
        ranges = np.full(len(angles), 80.0)
        for k, a in enumerate(angles):
            d = np.array([math.cos(pose[2] + a), math.sin(pose[2] + a)])
            for (x1, y1), (x2, y2) in walls:
                e = np.array([x2 - x1, y2 - y1])
                m = np.array([[d[0], -e[0]], [d[1], -e[1]]])
                if abs(np.linalg.det(m)) < 1e-12:
                    continue
                t, u = np.linalg.solve(m, np.array([x1 - pose[0], y1 - pose[1]]))
                if t > 0 and 0 <= u <= 1:
                    ranges[k] = min(ranges[k], t)
        scans.append(CarmenScan(number + 1, float(number), ranges, -math.pi / 2, math.radians(1.0), pose.copy(),
                                pose.copy(), np.zeros(3)))
    return scans


def test_a_first_pose_turned_by_a_degree_is_found_a_degree_off():
    path = [np.array([-2.5 + 0.35 * k, -1.5 + 0.1 * math.sin(k / 5), 0.1 * math.sin(k / 7)]) for k in range(16)]
    path += [np.array([3.0 - 0.35 * k, 1.8, math.pi + 0.05 * math.sin(k / 3)]) for k in range(16)]
    path += [np.array([-2.6, 1.5 - 0.35 * k, -math.pi / 2]) for k in range(8)]
    truth = np.array(path)
    exact = anchor(_room_scans(truth), 3)
    assert all(abs(turn) < 0.1 and shift < 1.0 for _, turn, shift, _ in exact)
    scans = _room_scans(truth)
    scans[0].pose = scans[0].pose + np.array([0.0, 0.0, math.radians(1.0)])  # the reference's first pose, turned
    (_, turn, shift, fitted), *_ = anchor(scans, 1)
    assert abs(turn + 1.0) < 0.15 and fitted > 0.9


def test_a_jump_in_the_reference_is_found_where_it_happens():
    """The reference turns 5 degrees between two scans that the robot took without that turn (every pose after it
    turned about the robot's position there): the step-by-step check finds the scan it happens at needing 5 degrees
    back, and no other scan; with exact poses, none."""
    from bench.reference_consistency import JUMP_DEG, step_by_step

    path = [np.array([-2.5 + 0.3 * k, -1.5, 0.0]) for k in range(18)]
    path += [np.array([2.6, -1.5 + 0.3 * k, math.pi / 2]) for k in range(10)]
    truth = np.array(path)
    assert all(abs(turn) < 0.3 for _, turn, _, _ in step_by_step(_room_scans(truth)))
    scans = _room_scans(truth)
    jump, angle = 10, math.radians(5.0)                        # scan 10: a keyframe (every 0.6 m)
    c, s = math.cos(angle), math.sin(angle)
    for scan in scans[jump:]:
        offset = scan.pose[:2] - truth[jump, :2]
        scan.pose = np.array([truth[jump, 0] + c * offset[0] - s * offset[1],
                              truth[jump, 1] + s * offset[0] + c * offset[1], scan.pose[2] + angle])
    flagged = [(k, turn) for k, turn, _, _ in step_by_step(scans) if abs(turn) > JUMP_DEG]
    assert len(flagged) == 1 and flagged[0][0] == jump and abs(flagged[0][1] + 5.0) < 0.5


def test_the_reference_s_two_halves_agree_on_its_walls_only_where_its_poses_do():
    """Half against half: the map drawn from every other scan of the room against the map of the rest, at exact
    poses, finds nearly every wall; with every other pose shifted 0.15 m (beyond the score's 0.1 m), few."""
    from bench.reference_consistency import half_against_half

    path = [np.array([-2.5 + 0.3 * k, -1.5 + 0.1 * math.sin(k / 4), 0.1 * math.sin(k / 5)]) for k in range(18)]
    truth = np.array(path)
    assert half_against_half(_room_scans(truth)) > 0.97
    scans = _room_scans(truth)
    for scan in scans[1::2]:
        scan.pose = scan.pose + np.array([0.0, 0.15, 0.0])
    assert half_against_half(scans) < 0.5


def test_a_perfect_map_loses_walls_only_to_a_reference_that_jitters_by_far_more_than_the_logs_do():
    """The ceiling: the room's map drawn at exact poses scores every wall against the reference drawn at them, nearly
    every one against a reference jittered by half a degree a pose (what the corrected logs' step-by-step turns look
    like), and clearly fewer against one jittered by 5 degrees; the jitter shows in the step-by-step median."""
    from bench.reference_consistency import ceiling_rows

    path = [np.array([-2.5 + 0.1 * k, -1.5 + 0.1 * math.sin(k / 4), 0.1 * math.sin(k / 5)]) for k in range(50)]
    rows = ceiling_rows(_room_scans(np.array(path)), [0.5, 5.0], 0.01)
    (_, exact_median, _, exact), (_, half_median, _, half), (_, five_median, _, five) = rows
    assert exact > 0.99 and half > 0.97 and five < 0.9
    assert exact_median < 0.1 < half_median < 1.0 < five_median


def test_white_jitter_and_a_slow_drift_of_the_reference_are_told_apart():
    """whiteness: a reference off its scans by white noise gives step-by-step turns that do not follow each other
    from keyframe to keyframe; one that drifts slowly off them (a turn coming and going over a few metres) gives
    turns that do. Every scan of the path is a keyframe (it swings 0.7 rad from one to the next)."""
    from bench.reference_consistency import jittered, step_by_step, whiteness

    n = 80
    path = np.array([[-3.0 + 6.0 * k / n, -1.2 + 0.6 * math.sin(k / 9), 0.35 * (-1) ** k] for k in range(n)])
    white = jittered(_room_scans(path), 0.5, 0.01)
    neighbours, _ = whiteness(step_by_step(white), white)
    assert abs(neighbours) < 0.4
    drifting = _room_scans(path)
    for k, scan in enumerate(drifting):
        scan.pose = scan.pose + np.array([0.0, 0.0, math.radians(1.5 * math.sin(k / 6))])
    neighbours, _ = whiteness(step_by_step(drifting), drifting)
    assert neighbours > 0.6


def test_a_jitter_that_is_not_above_zero_is_refused_by_name(capsys):
    """--ceiling's DEG and --jitter-m are checked before any log is read: a one-line error naming the option."""
    import pytest

    from bench.reference_consistency import main

    refused = {"--ceiling": ["--ceiling", "0.5", "-1"], "--jitter-m": ["--ceiling", "0.5", "--jitter-m", "-0.1"]}
    for option, argv in refused.items():
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        assert exit_.value.code == 2 and option in capsys.readouterr().err


def test_a_reference_late_by_its_turn_correlates_its_step_turns_with_the_turn():
    """whiteness's second figure: a reference whose heading is off in proportion to how fast the robot turns there
    (a laser's skew, a late stamp) gives step-by-step turns that follow the turn; white jitter's do not. The robot
    turns 0.35 or 0.7 rad from scan to scan (each a keyframe) near the room's middle."""
    from bench.reference_consistency import jittered, step_by_step, whiteness

    turns = np.where(np.random.default_rng(3).random(80) < 0.5, 0.35, 0.7)
    heading = np.cumsum(turns)
    xy = np.cumsum(0.1 * np.column_stack((np.cos(heading), np.sin(heading))), axis=0)
    path = np.column_stack((xy[:, 0] - 1.5, xy[:, 1] - 0.5, heading))
    white = jittered(_room_scans(path), 0.5, 0.01)
    _, with_turn = whiteness(step_by_step(white), white)
    assert abs(with_turn) < 0.4
    late = _room_scans(path)
    for scan, rate in zip(late, np.gradient(heading)):
        scan.pose = scan.pose + np.array([0.0, 0.0, 0.05 * rate])
    _, with_turn = whiteness(step_by_step(late), late)
    assert abs(with_turn) > 0.6
