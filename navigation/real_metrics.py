"""Scores of a map built from a real log against the log's corrected poses (the reference: scoring only, never an
input to mapping).

* ``ate_m``: RMS distance of the optimised keyframe poses from the reference poses at the same instants, in the
  frame both start in: the trajectory moved so that its first pose is the reference's pose of that instant
  (:func:`start_alignment`; nothing moves for a converted Carmen log, whose odometry starts at the reference's first
  pose; a robot's bag has its odometry frame start where the robot did, and its /ground_truth in the world's).
* ``rpe_trans_m`` / ``rpe_rot_deg``: Kümmerle et al.'s relative error, mean absolute translation and rotation error
  of the motion between consecutive keyframes against the reference's (pairs of consecutive keyframes here,
  not the hand-checked relation files of the paper: the figures compare in kind, not to the digit).
* ``walls_within_0p1m``: of the reference map's occupied cells (every scan drawn at its reference pose, the same
  counting model and threshold), the share with an occupied cell of the built map within 0.1 m.
* ``ate_aligned_m``, ``walls_within_0p1m_aligned``, ``alignment_deg``: the same after the trajectory is moved onto
  the reference by the rigid motion that fits it best (least squares, Umeyama's method; the ATE of
  Sturm et al.'s TUM benchmark), the built map moved with it, and that motion's turn. The unaligned figures count
  a map that is right but turned as a whole (its first keyframes fix its frame) as wrong everywhere; the aligned
  ones measure its shape.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree
from skimage.transform import EuclideanTransform

from subsumption.mapfile import OCCUPIED, OccupancyMap
from subsumption.planar import between, compose, inverse, transform_points, wrap

from .scan_geometry import Beams
from .slam_grid import CountGrid


def at_stamps(stamps: np.ndarray, ref_stamps: np.ndarray, ref_poses: np.ndarray,
              tolerance: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """(mask, poses): the reference pose nearest each stamp, where one lies within `tolerance` s."""
    if not len(ref_stamps):
        return np.zeros(len(stamps), bool), np.zeros((len(stamps), 3))
    i = np.clip(np.searchsorted(ref_stamps, stamps), 1, len(ref_stamps) - 1) if len(ref_stamps) > 1 else \
        np.zeros(len(stamps), int)
    if len(ref_stamps) > 1:
        left = np.abs(ref_stamps[i - 1] - stamps) <= np.abs(ref_stamps[i] - stamps)
        i = np.where(left, i - 1, i)
    ok = np.abs(ref_stamps[i] - stamps) <= tolerance
    return ok, ref_poses[i]


def ate(poses: np.ndarray, reference: np.ndarray) -> float:
    """Absolute trajectory error: RMS of the position differences between poses and their reference poses, m (NaN for
    no poses)."""
    if not len(poses):
        return math.nan
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - reference[:, :2]) ** 2, axis=1))))


def rigid_alignment(positions: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The planar rigid motion (x, y, yaw) that, applied to `positions` (n, 2), brings them nearest `reference`
    (n, 2) in the least-squares sense (scikit-image's EuclideanTransform, Umeyama's method); with fewer than two
    positions, a shift alone."""
    if not len(positions):
        return np.zeros(3)
    fit = EuclideanTransform.from_estimate(positions, reference)
    if not fit:
        shift = (reference - positions).mean(axis=0)
        return np.array([shift[0], shift[1], 0.0])
    return np.array([fit.translation[0], fit.translation[1], fit.rotation])


def start_alignment(poses: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The planar rigid motion (x, y, yaw) that puts the first of `poses` (n, 3) on the first of `reference`: the
    frame both start in, for the scores "as it is" (zeros for no poses)."""
    if not len(poses):
        return np.zeros(3)
    return compose(reference[0], inverse(poses[0]))


def ate_moved(poses: np.ndarray, reference: np.ndarray, motion: np.ndarray) -> float:
    """The ATE of `poses` first moved by the planar rigid motion `motion` (x, y, yaw); NaN for no poses."""
    if not len(poses):
        return math.nan
    return ate(np.column_stack((transform_points(motion, poses[:, :2]), poses[:, 2])), reference)


def ate_aligned(poses: np.ndarray, reference: np.ndarray) -> tuple[float, np.ndarray]:
    """(ATE after the best rigid alignment, that alignment (x, y, yaw)): the trajectory's shape, whatever its turn."""
    motion = rigid_alignment(poses[:, :2], reference[:, :2])
    return ate_moved(poses, reference, motion), motion


def rpe(poses: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """(mean |translation error| m, mean |rotation error| deg) of consecutive pairs."""
    if len(poses) < 2:
        return math.nan, math.nan
    trans, rot = [], []
    for k in range(1, len(poses)):
        est, ref = between(poses[k - 1], poses[k]), between(reference[k - 1], reference[k])
        err = between(ref, est)
        trans.append(math.hypot(err[0], err[1]))
        rot.append(abs(float(wrap(err[2]))))
    return float(np.mean(trans)), math.degrees(float(np.mean(rot)))


def reference_map(scans: list[tuple[np.ndarray, Beams]], resolution: float, occ_thresh: float) -> OccupancyMap:
    """The reference map: the scans drawn from their reference (corrected) poses, to score a built map's walls
    against."""
    grid = CountGrid(resolution, occ_thresh)
    for pose, beams in scans:
        grid.integrate(pose, beams)
    return grid.to_map("reference")


def wall_gaps(built: OccupancyMap, reference: OccupancyMap, motion: np.ndarray | None = None) -> np.ndarray:
    """For each of the reference's occupied cells, in the order ``np.nonzero(reference.occupancy == OCCUPIED)``
    gives them, the distance in m to the nearest occupied cell of the built map, moved first by `motion` (x, y, yaw;
    None: as it is): where the built map's walls are off, and by how much (cell centres, exact distances; +inf
    everywhere for a built map without walls)."""
    ref_rows, ref_cols = np.nonzero(reference.occupancy == OCCUPIED)
    rows, cols = np.nonzero(built.occupancy == OCCUPIED)
    if not len(rows) or not len(ref_rows):
        return np.full(len(ref_rows), math.inf)
    centres = lambda m, r, c: np.column_stack((m.origin[0] + (c + 0.5) * m.resolution,  # noqa: E731
                                               m.origin[1] + (r + 0.5) * m.resolution))
    built_walls = centres(built, rows, cols)
    walls = cKDTree(built_walls if motion is None else transform_points(motion, built_walls))
    return walls.query(centres(reference, ref_rows, ref_cols), k=1)[0]


def walls_within(built: OccupancyMap, reference: OccupancyMap, distance: float = 0.1,
                 motion: np.ndarray | None = None) -> float:
    """Share of the reference's occupied cells with a built occupied cell within `distance` m (:func:`wall_gaps`),
    the built map first moved by `motion` (x, y, yaw; None: as it is). NaN for a reference with no wall."""
    gaps = wall_gaps(built, reference, motion)
    return float(np.mean(gaps <= distance + 1e-6)) if len(gaps) else math.nan


def half_against_half(scans: list[tuple[np.ndarray, Beams]], resolution: float, occ_thresh: float) -> float:
    """How well scans agree with each other at the poses given, with no reference: the wall score
    (:func:`walls_within`, 0.1 m) of the map drawn from every other scan against the map drawn from the rest, and the
    other way round, averaged. Poses off by more than the cells' width draw the two halves' walls apart; each half
    sees a little less than the whole, so even exact poses score a little under 1. NaN for scans that draw no wall."""
    even = reference_map(scans[0::2], resolution, occ_thresh)
    odd = reference_map(scans[1::2], resolution, occ_thresh)
    return 0.5 * (walls_within(even, odd) + walls_within(odd, even))
