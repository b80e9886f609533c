"""SLAM learns odometry's error from the scans (``odometry_adapt``): a robot whose odometry is better than
gmapping's model says is trusted more, one whose odometry is worse is trusted less, axis by axis."""
from __future__ import annotations

import math

import numpy as np

from navigation.slam_core import GraphSlam, SlamParams
from subsumption.planar import compose
from tests.support.laser_room import laser_scan, room

START = np.array([1.5, 1.2, 0.0])
STRAIGHT = np.array([0.3, 0.0, 0.0])
TURN = np.array([0.0, 0.0, math.pi / 8])


def _drive(adapt: bool, heading_noise: float = 0.0, half_fov: float = math.pi / 2) -> tuple[GraphSlam, float]:
    """Twice round the room (tracking alone, no loop closure) with odometry whose heading errs by `heading_noise`
    rad a step (seeded); returns the SLAM core and the keyframes' RMS position error."""
    rng = np.random.default_rng(0)
    grid = room()
    slam = GraphSlam(SlamParams(loop_closure=False, odometry_adapt=adapt), start=START)
    truth, odom, truths = START.copy(), START.copy(), [START.copy()]
    slam.add_scan(0.0, odom, laser_scan(truth, grid, half_fov))
    lap = [STRAIGHT] * 27 + [TURN] * 4 + [STRAIGHT] * 16 + [TURN] * 4
    for k, step in enumerate(lap * 2, 1):
        truth = compose(truth, step)
        odom = compose(odom, step + np.array([0.0, 0.0, heading_noise * rng.standard_normal()]))
        truths.append(truth.copy())
        slam.add_scan(float(k), odom, laser_scan(truth, grid, half_fov))
    error = np.array([kf.pose[:2] - truths[int(kf.stamp)][:2] for kf in slam.keyframes])
    return slam, float(np.sqrt(np.mean(np.sum(error ** 2, axis=1))))


def _learned(slam: GraphSlam, step: np.ndarray) -> np.ndarray:
    """Odometry's (along, across, heading) standard deviations for `step` as learned, over the model's."""
    return slam._odometry_sigmas(step) / slam._odometry_model(step)


def test_odometry_better_than_its_model_is_trusted_more():
    """Perfect odometry: its learned error along the step and in heading falls far below the model's (5% of the
    distance), and the keyframes land nearer the truth than with the model."""
    adapted, error = _drive(adapt=True)
    _, model_error = _drive(adapt=False)
    assert _learned(adapted, STRAIGHT)[[0, 2]].max() < 0.3
    assert error < 0.9 * model_error


def test_odometry_worse_than_its_model_is_trusted_less():
    """Heading off by 0.06 rad (3.4 degrees) a step where the model allows 0.02: the learned heading error
    grows past the model's (here the scans decide the heading either way, so the keyframes land as near)."""
    adapted, error = _drive(adapt=True, heading_noise=0.06)
    _, model_error = _drive(adapt=False, heading_noise=0.06)
    assert _learned(adapted, STRAIGHT)[2] > 1.5
    assert error < 1.05 * model_error


def test_a_narrow_scan_leaves_odometry_s_model_as_it_is():
    """A 58-degree depth scan pins the pose down too seldom to learn from (``odometry_adapt_min_fov``)."""
    slam, _ = _drive(adapt=True, heading_noise=0.06, half_fov=math.radians(29))
    assert np.allclose(_learned(slam, STRAIGHT), 1.0) and np.allclose(_learned(slam, TURN), 1.0)
