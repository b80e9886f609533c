"""Scan matching: where does a scan fit onto points seen before? Point-to-line ICP with an odometry prior.

The target is a cloud of earlier scan points with their surface normals (a bucket grid,
:class:`navigation.slam_nearest.BucketGrid`, finds each new point's nearest neighbour exactly). Each Gauss-Newton step minimises the distance of the new points to
the target's local lines (robustly: Huber weights) plus how far the pose strays from where odometry puts it,
weighted by odometry's own uncertainty. The prior is what keeps a narrow scan that sees only one wall, or
two parallel walls of a corridor, from sliding along them: in the direction the scan cannot tell, odometry
decides. Point-to-line on real points (not on a grid) keeps the result free of the half-cell bias that
matching against cell centres has.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from subsumption.planar import transform_points, wrap
from .slam_nearest import BucketGrid


@numba.njit(cache=True, nogil=True)
def scan_normals(points: np.ndarray, window: int, radius: float, growth: float = 0.0) -> np.ndarray:
    """Unit normals of points ordered as the beams were (NaN where the neighbours do not form a line): PCA
    of the neighbours within `window` beams and `radius` metres, or `growth` times the point's range where that is
    more (beams fan out: at 1 degree apart a wall 10 m away has its hits 17 cm apart, more seen at a grazing angle,
    and a fixed radius leaves every far wall without a normal). Each points towards the sensor (at the origin of
    `points`' frame): the side of the surface that was seen, which :func:`match` keeps apart from the other side."""
    n = points.shape[0]
    out = np.full((n, 2), np.nan)
    for i in range(n):
        r_i = max(radius, growth * math.hypot(points[i, 0], points[i, 1]))
        radius2 = r_i * r_i
        sx = sy = sxx = syy = sxy = 0.0
        m = 0
        for j in range(max(0, i - window), min(n, i + window + 1)):
            dx, dy = points[j, 0] - points[i, 0], points[j, 1] - points[i, 1]
            if dx * dx + dy * dy <= radius2:
                x, y = points[j, 0], points[j, 1]
                sx += x
                sy += y
                sxx += x * x
                syy += y * y
                sxy += x * y
                m += 1
        if m < 3:
            continue
        mx, my = sx / m, sy / m
        cxx, cyy, cxy = sxx / m - mx * mx, syy / m - my * my, sxy / m - mx * my
        # eigenvector of the smaller eigenvalue of [[cxx, cxy], [cxy, cyy]]
        tr, det = cxx + cyy, cxx * cyy - cxy * cxy
        disc = math.sqrt(max(tr * tr / 4 - det, 0.0))
        small, large = tr / 2 - disc, tr / 2 + disc
        if large <= 0 or small > 0.1 * large:  # not a line: a corner or scattered points
            continue
        if abs(cxy) > 1e-12:
            nx, ny = small - cyy, cxy
        elif cxx < cyy:
            nx, ny = 1.0, 0.0
        else:
            nx, ny = 0.0, 1.0
        norm = math.hypot(nx, ny)
        if nx * points[i, 0] + ny * points[i, 1] > 0:  # facing the sensor (at the origin): the side that was seen
            norm = -norm
        out[i, 0], out[i, 1] = nx / norm, ny / norm
    return out


@dataclass
class Cloud:
    """Target points (map frame) with normals, and the search structure over them."""

    points: np.ndarray
    normals: np.ndarray
    tree: BucketGrid

    @classmethod
    def of(cls, points: np.ndarray, normals: np.ndarray) -> "Cloud":
        """Points with finite normals only (see :func:`thin`). Built anew for every keyframe, queried a few
        thousand times: see :mod:`navigation.slam_nearest` for why a bucket grid and not a kd-tree."""
        return cls(points, normals, BucketGrid(points))

    def __len__(self) -> int:
        return len(self.points)


@dataclass
class Match:
    pose: np.ndarray  # (3,) map frame
    covariance: np.ndarray  # (3, 3)
    inliers: float  # share of the scan's points within `inlier_distance` of the target's surface
    rms: float  # m, point-to-line, over the inliers
    used: int  # points that had a partner
    structure: np.ndarray = None  # (3,) what the scan alone constrains: see :func:`structure`
    degenerate: int = 0  # directions the scan could not tell, left where the prior put them


ROTATION_ARM = 1.0  # m: a turn of 1 rad weighs like a shift of this much when constraints are compared


def structure(scan_information: np.ndarray, sigma: float) -> np.ndarray:
    """How well a scan pins a pose down, in points' worth along each principal direction: the eigenvalues of
    the scan's own information (no prior), rotation scaled by ``ROTATION_ARM``, divided by one well-fitting
    point's (1/sigma^2), ascending. One flat wall seen head-on gives about (0, n/2, n): the smallest says how
    many points' worth of evidence the scan has along the wall, i.e. none."""
    scale = np.array([1.0, 1.0, 1.0 / ROTATION_ARM])
    values = np.linalg.eigvalsh(scan_information * scale[:, None] * scale[None, :])
    return np.clip(values, 0.0, None) * sigma * sigma


def _well_constrained(scan_information: np.ndarray, sigma: float, min_points: float) -> np.ndarray:
    """(3, k) orthonormal directions (in the scaled pose space of :func:`structure`) the scan constrains with
    at least `min_points` points' worth of information."""
    scale = np.array([1.0, 1.0, 1.0 / ROTATION_ARM])
    values, vectors = np.linalg.eigh(scan_information * scale[:, None] * scale[None, :])
    return vectors[:, values * sigma * sigma >= min_points]


@numba.njit(cache=True, nogil=True)
def _add_residual(hessian, gradient, jac, r, w):
    """One weighted residual `r` with Jacobian `jac` (d r / d(x, y, yaw)) into Gauss-Newton's J^T W J and J^T W r."""
    for u in range(3):
        gradient[u] += w * jac[u] * r
        for v in range(3):
            hessian[u, v] += w * jac[u] * jac[v]


@numba.njit(cache=True, nogil=True)
def _huber_weight(length, huber, sigma):
    """The weight of a residual of this length: 1/sigma^2, down-weighted beyond `huber` (Huber's loss)."""
    return (1.0 if length <= huber else huber / length) / (sigma * sigma)


@numba.njit(cache=True, nogil=True)
def _equations(world, local, idx, dist, points, normals, c, s, huber, sigma, to_line):
    """Gauss-Newton's J^T W J and J^T W r (Huber-weighted) of the pairs found: point to line along the target's
    `normals` (`to_line`), or point to point, Huber-weighted on the residual's length (corner points, which have no
    line to slide along and so pin a pose down along a corridor; `normals` is then not read)."""
    hessian = np.zeros((3, 3))
    gradient = np.zeros(3)
    used = 0
    for i in range(world.shape[0]):
        if not np.isfinite(dist[i]):
            continue
        j = idx[i]
        rx, ry = world[i, 0] - points[j, 0], world[i, 1] - points[j, 1]
        dpx = -s * local[i, 0] - c * local[i, 1]  # d(world point) / d(yaw)
        dpy = c * local[i, 0] - s * local[i, 1]
        if to_line:
            nx, ny = normals[j, 0], normals[j, 1]
            r = rx * nx + ry * ny
            _add_residual(hessian, gradient, (nx, ny, nx * dpx + ny * dpy), r, _huber_weight(abs(r), huber, sigma))
        else:
            w = _huber_weight(math.hypot(rx, ry), huber, sigma)
            _add_residual(hessian, gradient, (1.0, 0.0, dpx), rx, w)
            _add_residual(hessian, gradient, (0.0, 1.0, dpy), ry, w)
        used += 1
    return hessian, gradient, used


_NO_NORMALS = np.zeros((0, 2))  # point-to-point equations read no normals


@dataclass
class Corners:
    """Corner points to match point to point: the scan's (robot frame), the target's (map frame, in their search
    structure), and how far apart a right pair may lie (sigma, m; the beams' spacing at a few metres)."""

    scan: np.ndarray
    target: BucketGrid
    sigma: float = 0.05

    def equations(self, pose: np.ndarray, limit: float, huber: float) -> tuple[np.ndarray, np.ndarray, int]:
        """(J^T W J, J^T W r, pairs) of the scan's corners at `pose` against the target's within `limit` m."""
        if not len(self.scan) or not len(self.target):
            return np.zeros((3, 3)), np.zeros(3), 0
        world = transform_points(pose, self.scan)
        dist, idx = self.target.query(world, distance_upper_bound=limit)
        return _equations(world, self.scan, idx, dist, self.target.points, _NO_NORMALS, math.cos(pose[2]),
                          math.sin(pose[2]), huber, self.sigma, False)


def corner_points(points: np.ndarray, normals: np.ndarray, voxel: float) -> np.ndarray:
    """The points without a normal (corners, door jambs, posts: no line through them), one per `voxel` square."""
    corners = points[~np.isfinite(normals[:, 0])]
    return corners[one_per_square(corners, voxel)]


def match(scan: np.ndarray, target: Cloud, guess: np.ndarray, prior_information: np.ndarray | None = None,
          max_distance: float = 0.4, final_distance: float = 0.1, sigma: float = 0.02, huber: float = 0.03,
          iterations: int = 20, inlier_distance: float = 0.05, min_structure: float = 0.0,
          information_scale: float = 1.0, start: np.ndarray | None = None,
          normals: np.ndarray | None = None, corners: Corners | None = None) -> Match:
    """Fit `scan` ((n, 2) points, robot frame) onto `target` from `guess`. With `prior_information` (3x3,
    inverse covariance) the pose is also pulled towards `guess`, odometry's prediction.

    With the scan's `normals` ((n, 2), robot frame, facing the sensor as :func:`scan_normals` gives them), a point
    pairs with the nearest target point whose normal faces the same way: a thin wall seen from its other side (a
    robot that drove through a door, a box walked round) is not the side seen before, though it lies a few cm from
    it, and a fit of one onto the other turns the pose (by 4 degrees through the office world's door).

    Degeneracy (with `min_structure` > 0): a narrow scan of one flat wall says nothing about where along the
    wall the robot is, yet a few stray pairs (a far corner, a moving person, noise) give that direction a
    weak, wrong pull. Only the directions of the scan's information with at least `min_structure` points'
    worth are updated (solution remapping, Zhang et al. 2016); along the others the pose stays at `guess`,
    and the returned covariance there is the prior's alone.

    `information_scale` multiplies the scan's information (in the solve and in the returned covariance): the
    points of one scan are not independent measurements (the same wall, the same mount error, the same skew of
    a turning laser), so ``n`` points at ``sigma`` pin the pose down far less than ``sigma / sqrt(n)``; below 1
    the odometry prior keeps its say where the scan's evidence is weak, in proportion, instead of all or
    nothing.

    With `corners` (:class:`Corners`: the scan's hits that no line runs through, and the target's), those are paired
    point to point too: a door jamb says where along a corridor the scan is, which the corridor's walls do not."""
    guess = np.asarray(guess, dtype=float)
    local_normals = None if normals is None else np.asarray(normals, dtype=float)

    def facing(at: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The scan's normals turned to `at`'s heading, with the target's: what the search pairs by."""
        if local_normals is None:
            return None
        return transform_points(np.array([0.0, 0.0, at[2]]), local_normals), target.normals

    pose = guess.copy() if start is None else np.asarray(start, dtype=float).copy()
    prior = np.zeros((3, 3)) if prior_information is None else prior_information
    hessian = prior.copy()
    used = 0
    for it in range(iterations):
        distance_limit = max_distance if it < 3 else max(final_distance, max_distance * 0.5 ** (it - 2))
        world = transform_points(pose, scan)
        dist, idx = target.tree.query(world, distance_upper_bound=distance_limit, facing=facing(pose))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        scan_info, gradient, used = _equations(world, scan, idx, dist, target.points, target.normals, c, s,
                                               huber, sigma, True)
        if used < 3:
            break
        if corners is not None:
            corner_info, corner_gradient, _ = corners.equations(pose, distance_limit, max(huber, corners.sigma))
            scan_info += corner_info
            gradient += corner_gradient
        scan_info *= information_scale
        gradient *= information_scale
        error = pose - guess
        error[2] = wrap(error[2])
        hessian = scan_info + prior
        gradient += prior @ error
        try:
            step = -np.linalg.solve(hessian, gradient)
        except np.linalg.LinAlgError:
            break
        before = pose.copy()
        pose = pose + step
        if min_structure > 0:
            pose = _remap(pose, guess, scan_info / information_scale, sigma, min_structure)
        pose[2] = float(wrap(pose[2]))
        moved = pose - before
        if it >= 3 and abs(moved[0]) < 1e-4 and abs(moved[1]) < 1e-4 and abs(wrap(moved[2])) < 1e-4:
            break
    world = transform_points(pose, scan)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dist, idx = target.tree.query(world, distance_upper_bound=final_distance, facing=facing(pose))
    scan_info, _, used = _equations(world, scan, idx, dist, target.points, target.normals, c, s, huber, sigma, True)
    if corners is not None:
        scan_info += corners.equations(pose, final_distance, max(huber, corners.sigma))[0]
    scan_info *= information_scale
    degenerate = 0
    if min_structure > 0:
        good = _well_constrained(scan_info / information_scale, sigma, min_structure)
        degenerate = 3 - good.shape[1]
        scale = np.array([1.0, 1.0, 1.0 / ROTATION_ARM])
        scaled = scan_info * scale[:, None] * scale[None, :]
        kept = good @ (good.T @ scaled @ good) @ good.T  # the scan's information in the directions it constrains
        scan_info = kept / scale[:, None] / scale[None, :]
    hessian = scan_info + prior
    dist, idx = target.tree.query(world, distance_upper_bound=max(inlier_distance * 2, 0.1))
    ok = np.isfinite(dist)
    r = np.abs(((world[ok] - target.points[idx[ok]]) * target.normals[idx[ok]]).sum(axis=1))
    inlier = r <= inlier_distance
    try:
        covariance = np.linalg.inv(hessian)
    except np.linalg.LinAlgError:
        covariance = np.eye(3)
    return Match(pose, covariance, float(inlier.sum() / max(len(scan), 1)),
                 float(np.sqrt(np.mean(r[inlier] ** 2))) if inlier.any() else math.inf, used,
                 structure(scan_info / information_scale, sigma), degenerate)


def _remap(pose: np.ndarray, guess: np.ndarray, scan_information: np.ndarray, sigma: float,
           min_points: float) -> np.ndarray:
    """`pose` with its offset from `guess` kept only along the directions the scan constrains."""
    scale = np.array([1.0, 1.0, 1.0 / ROTATION_ARM])
    good = _well_constrained(scan_information, sigma, min_points)
    offset = (pose - guess) / scale
    offset[2] = wrap(offset[2] * scale[2]) / scale[2]
    return guess + (good @ (good.T @ offset)) * scale


def evenly(points: np.ndarray, most: int) -> np.ndarray:
    """At most `most` of `points` (in the order given: a scan's, beam by beam), evenly spread over them."""
    if len(points) <= most:
        return points
    return points[evenly_index(len(points), most)]


def evenly_index(count: int, most: int) -> np.ndarray:
    """The indices :func:`evenly` keeps of `count` points (for their normals too)."""
    if count <= most:
        return np.arange(count)
    return np.linspace(0, count - 1, most).round().astype(int)


def thin(points: np.ndarray, normals: np.ndarray, voxel: float, return_index: bool = False) -> tuple:
    """One point (with its normal) per `voxel`-sized square, points without a normal dropped: a scan is denser
    near the robot than far away, and matching needs evenly spread points, not many."""
    index = np.flatnonzero(np.isfinite(normals[:, 0]))
    keep = one_per_square(points[index], voxel)
    points, normals, index = points[index][keep], normals[index][keep], index[keep]
    return (points, normals, index) if return_index else (points, normals)


def one_per_square(points: np.ndarray, voxel: float) -> np.ndarray:
    """Indices of the first of `points` in each `voxel`-sized square, in their order (all of them for voxel 0)."""
    if voxel <= 0 or not len(points):
        return np.arange(len(points))
    keys = np.floor(points / voxel).astype(np.int64)
    _, keep = np.unique(keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True)
    return np.sort(keep)
