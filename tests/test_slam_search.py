"""Tracking's correlative start (``match_search_radius``): the scan's best pose in the local map's likelihood field
near odometry's prediction, searched exhaustively, is where ICP starts."""
from __future__ import annotations

import math

import numpy as np

from navigation.scan_geometry import Beams
from navigation.slam_core import GraphSlam, SlamParams
from navigation.slam_match import corner_points, scan_normals, thin
from subsumption.planar import compose
from tests.support.laser_room import laser_scan, room

START = np.array([1.5, 1.2, 0.0])
STEP = np.array([0.4, 0.0, 0.1])


def _first_keyframe(radius: float) -> GraphSlam:
    slam = GraphSlam(SlamParams(loop_closure=False, match_search_radius=radius, match_search_angle=0.15),
                     start=START)
    slam.add_scan(0.0, START, laser_scan(START, room(), math.pi / 2))
    return slam


def _points(beams: Beams) -> tuple[np.ndarray, np.ndarray]:
    """The scan's points and corners as tracking takes them (robot frame)."""
    hits = beams.hits()
    normals = scan_normals(hits, 3, 0.15)
    return thin(hits, normals, 0.03)[0], corner_points(hits, normals, 0.03)


def test_the_search_starts_tracking_at_the_scan_s_best_pose_near_the_prediction():
    """A prediction 0.2 m and 4.6 degrees off: the searched start is the true pose to within a map cell and the
    search's angular step; without the search, ICP starts at the prediction."""
    truth = compose(START, STEP)
    points, corners = _points(laser_scan(truth, room(), math.pi / 2))
    guess = truth + np.array([0.15, -0.13, 0.08])
    start = _first_keyframe(0.3)._searched_start(points, corners, guess)
    assert start is not None
    assert math.hypot(*(start[:2] - truth[:2])) <= 0.05 and abs(start[2] - truth[2]) <= math.radians(0.5)
    assert _first_keyframe(0.0)._searched_start(points, corners, guess) is None

