"""Correlative scan matching (Olson, "Real-time correlative scan matching", ICRA 2009): where in a wide window of
poses does a scan fit a map best, searched exhaustively rather than by descent from a guess.

ICP (:mod:`navigation.slam_match`) finds the nearest fit to where it starts; it needs a start within a few
decimetres and degrees of the truth. A loop closure after 30 m of driving with 5% odometry drift starts metres
off, so it is searched instead: the map's points become a likelihood field (each cell: how likely a hit there is,
``exp(-d^2 / 2 sigma^2)`` of its distance ``d`` to the nearest map point, from OpenCV's exact distance transform),
and every pose of a window (translations a cell apart, rotations so that the farthest point moves about a cell) is
scored by the mean likelihood of the scan's points there.

Done naively that is millions of look-ups per pose window; a branch and bound keeps it exact and cheap
(Cartographer's idea, Hess et al. 2016, with two levels above the fine one instead of several): the field dilated
by ``k`` cells (each cell the maximum of its neighbourhood, ``cv2.dilate``) scores a coarse pose no lower than any
of the ``(2k + 1)^2`` fine translations around it, so coarse poses are scored first, and the fine poses of a coarse
one are scored only while its bound can still beat the best fine score found. A caller that takes no pose below a
score gives it as ``floor`` (Cartographer's ``min_score``): a coarse pose whose bound does not beat it is never
refined, so a window with no good match (a loop that is not there, a robot that is not on the map) costs the coarse
level alone: a whole-map search of ACES for a view of Intel took 63 CPU s without it and 1.5 with it
(``python -m bench.search_floor``). With a floor, a level above the coarse one goes first: the field dilated over
``TOP_BLOCKS`` x ``TOP_BLOCKS`` coarse blocks bounds them all, and the coarse level is scored only under the top
blocks that can still beat the floor (a loop closure's search on the real logs: half the CPU, the same poses).

The score surface also says how well the match is pinned down: the covariance of the poses weighted by their
likelihood (Olson's), long along a corridor and short across it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _place_cells(points, px, py, theta, x0, y0, res, cells):
    """Into `cells` (n, 2): the field cell (column, row) of each of `points` (robot frame) at pose (px, py, theta)."""
    c, s = math.cos(theta), math.sin(theta)
    for i in range(points.shape[0]):
        wx = px + c * points[i, 0] - s * points[i, 1]
        wy = py + s * points[i, 0] + c * points[i, 1]
        cells[i, 0] = int(math.floor((wx - x0) / res))
        cells[i, 1] = int(math.floor((wy - y0) / res))


@numba.njit(cache=True, nogil=True)
def _mean_at(field, cells, ox, oy):
    """Mean field value at `cells` (n, 2: column, row) moved by (ox, oy) cells; 0 outside the field."""
    rows, cols = field.shape
    total = 0.0
    for i in range(cells.shape[0]):
        col, row = cells[i, 0] + ox, cells[i, 1] + oy
        if 0 <= row < rows and 0 <= col < cols:
            total += field[row, col]
    return total / cells.shape[0]


@numba.njit(cache=True, nogil=True)
def _scores(field, x0, y0, res, points, px, py, thetas, offsets):
    """Mean field value of `points` (robot frame) at pose (px + offset x, py + offset y, theta) for every theta and
    every integer cell offset (k, 2); 0 outside the field. (len(thetas), len(offsets))."""
    out = np.zeros((thetas.shape[0], offsets.shape[0]))
    cells = np.empty((points.shape[0], 2), np.int64)
    for a in range(thetas.shape[0]):
        _place_cells(points, px, py, thetas[a], x0, y0, res, cells)
        for k in range(offsets.shape[0]):
            out[a, k] = _mean_at(field, cells, offsets[k, 0], offsets[k, 1])
    return out


@numba.njit(cache=True, nogil=True)
def _branch_and_bound(field, x0, y0, res, points, px, py, thetas, coarse_offsets, fine, order, bounds, best):
    """The fine level of :func:`search`: the coarse blocks in `order` (flat indices into `bounds`, best bound first)
    are scored at each of their `fine` offsets, as :func:`_scores` would, until a block's bound is at most the best
    score found (starting from `best`). One compiled loop: a block costs its look-ups only, each angle's cells are
    computed once. Returns (best score, its block's flat index or -1, its fine offset's index, the blocks scored in
    order, their scores (blocks, len(fine)))."""
    n, n_fine, n_coarse = points.shape[0], fine.shape[0], bounds.shape[1]
    cells = np.empty((thetas.shape[0], n, 2), np.int64)
    placed = np.zeros(thetas.shape[0], np.bool_)
    blocks = np.empty(min(order.shape[0], 256), np.int64)
    scores = np.empty((blocks.shape[0], n_fine))
    count, best_flat, best_k = 0, -1, -1
    for flat in order:
        a, j = flat // n_coarse, flat % n_coarse
        if bounds[a, j] <= best:
            break
        if not placed[a]:
            _place_cells(points, px, py, thetas[a], x0, y0, res, cells[a])
            placed[a] = True
        if count == blocks.shape[0]:  # room for twice as many
            blocks = np.concatenate((blocks, np.empty(count, np.int64)))
            scores = np.concatenate((scores, np.empty((count, n_fine))))
        top_k = 0
        for k in range(n_fine):
            scores[count, k] = _mean_at(field, cells[a], fine[k, 0] + coarse_offsets[j, 0],
                                        fine[k, 1] + coarse_offsets[j, 1])
            if scores[count, k] > scores[count, top_k]:
                top_k = k
        blocks[count] = flat
        if scores[count, top_k] > best:
            best, best_flat, best_k = scores[count, top_k], flat, top_k
        count += 1
    return best, best_flat, best_k, blocks[:count], scores[:count]


TOP_BLOCKS = 3  # coarse blocks a side of the level above them, scored first when a search has a floor


@dataclass
class LikelihoodField:
    """A map's points as a likelihood grid (row 0 at the lowest y) and its dilation for the coarse level."""

    field: np.ndarray  # float32 (rows, cols)
    coarse: np.ndarray  # the field dilated by `coarse_cells`: an upper bound of every score around a cell
    coarse_cells: int
    origin: tuple[float, float]
    resolution: float
    top: np.ndarray | None = None  # dilated over TOP_BLOCKS x TOP_BLOCKS coarse blocks: a bound of all their poses

    @classmethod
    def of(cls, points: np.ndarray, resolution: float = 0.05, sigma: float = 0.05, margin: float = 1.0,
           coarse_cells: int = 3) -> "LikelihoodField":
        """The field of map points (n, 2), with `margin` metres around them."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        low = points.min(axis=0) - margin
        high = points.max(axis=0) + margin
        cols, rows = (np.ceil((high - low) / resolution).astype(int) + 1).tolist()
        free = np.full((rows, cols), 255, np.uint8)
        cells = np.floor((points - low) / resolution).astype(int)
        free[cells[:, 1], cells[:, 0]] = 0
        # distance (in cells) of every cell's centre to the nearest occupied cell's centre, exact (Felzenszwalb)
        distance = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * resolution
        field = np.exp(-0.5 * (distance / sigma) ** 2).astype(np.float32)
        kernel = np.ones((2 * coarse_cells + 1, 2 * coarse_cells + 1), np.uint8)
        coarse = cv2.dilate(field, kernel)
        top_cells = (TOP_BLOCKS * (2 * coarse_cells + 1) - 1) // 2
        top = cv2.dilate(field, np.ones((2 * top_cells + 1, 2 * top_cells + 1), np.uint8))
        return cls(field, coarse, coarse_cells, (float(low[0]), float(low[1])), float(resolution), top)


@dataclass
class Correlation:
    pose: np.ndarray  # (3,) the best pose found
    score: float  # mean likelihood of the scan's points there (0..1)
    covariance: np.ndarray  # (3, 3) of the poses around the best, weighted by their likelihood
    rival: float = 0.0  # the best score of a pose farther than `apart` from the best (0: none as good as asked)


def angular_step(points: np.ndarray, resolution: float) -> float:
    """The rotation step at which the farthest point moves about one cell (Olson's), between 0.2 and 2 degrees."""
    reach = float(np.sqrt((points ** 2).sum(axis=1)).max()) if len(points) else 1.0
    return float(np.clip(resolution / max(reach, 1e-3), math.radians(0.2), math.radians(2.0)))


def search(points: np.ndarray, lf: LikelihoodField, guess: np.ndarray, window_xy: float, window_theta: float,
           temperature: float = 0.02, apart: float = 0.0, rival_share: float = 0.9,
           floor: float = 0.0) -> Correlation:
    """The best pose for `points` (robot frame, (n, 2)) in the map within +-`window_xy` metres and
    +-`window_theta` radians of `guess`, exactly (branch and bound, see the module's doc).

    The covariance: each pose scored at the fine level near the best (within two coarse blocks) weighs
    ``exp((score - best) / temperature)``; `temperature` is the drop in mean likelihood at which a pose counts
    1/e as likely as the best (the points of one scan are not independent, so the score is not a log-likelihood).

    With `apart` > 0 it also looks for a rival: the best pose more than `apart` metres from the best one that
    scores at least `rival_share` of it (a corridor's look-alike doors, the next of a row of equal rooms). A match
    with a rival is ambiguous whatever its score; the caller decides.

    `floor`: the score below which the caller takes no pose. Blocks whose bound does not exceed it are never
    scored, so a search with no good match ends after the coarse level (Cartographer's ``min_score``); when a pose
    scores above it, it is the same pose as without the floor. With none above it, the result is the guess with
    score 0."""
    res, k = lf.resolution, lf.coarse_cells
    block = 2 * k + 1
    step = angular_step(points, res)
    n_theta = int(math.ceil(window_theta / step))
    thetas = guess[2] + step * np.arange(-n_theta, n_theta + 1)
    n_cells = int(math.ceil(window_xy / res))
    n_blocks = int(math.ceil(max(n_cells - k, 0) / block))
    centres = np.arange(-n_blocks, n_blocks + 1) * block
    cx, cy = np.meshgrid(centres, centres, indexing="ij")
    coarse_offsets = np.stack([cx.ravel(), cy.ravel()], axis=1).astype(np.int64)
    pts = np.ascontiguousarray(points, dtype=float)
    x0, y0 = lf.origin
    # no block whose bound is at most `prune` is ever refined below (nor looked at for a rival)
    prune = floor * (rival_share if apart > 0 else 1.0)
    if prune > 0 and lf.top is not None:
        bounds = _coarse_bounds_under_top(lf, pts, guess, thetas, coarse_offsets, block, prune)
    else:
        bounds = _scores(lf.coarse, x0, y0, res, pts, float(guess[0]), float(guess[1]), thetas, coarse_offsets)
    fx, fy = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
    fine = np.stack([fx.ravel(), fy.ravel()], axis=1).astype(np.int64)
    order = np.argsort(-bounds, axis=None, kind="stable")  # ties in index order, whatever was left unscored
    start = floor if floor > 0 else -1.0
    best, best_flat, best_k, blocks, block_scores = _branch_and_bound(
        lf.field, x0, y0, res, pts, float(guess[0]), float(guess[1]), thetas, coarse_offsets, fine, order, bounds,
        start)
    best_pose = guess.copy()
    if best_flat >= 0:
        a, j = np.unravel_index(best_flat, bounds.shape)
        best_pose = np.array([guess[0] + (fine[best_k, 0] + coarse_offsets[j, 0]) * res,
                              guess[1] + (fine[best_k, 1] + coarse_offsets[j, 1]) * res, thetas[a]])
    scored = []  # (theta, offsets (m, 2), scores (m,)) of every fine block scored
    for flat, s in zip(blocks, block_scores):
        a, j = np.unravel_index(flat, bounds.shape)
        scored.append((thetas[a], fine + coarse_offsets[j], s))
    if floor > 0 and best == floor:  # nothing scored above the floor
        return Correlation(guess.copy(), 0.0, _covariance([], guess, 0.0, guess, res, temperature, step))
    rival = 0.0
    if apart > 0:
        # blocks whose bound could reach the share, far enough from the best (their nearest fine pose is more
        # than `apart` away), scored exactly: pruning by the best score skipped them
        far = (np.hypot(guess[0] + coarse_offsets[:, 0] * res - best_pose[0],
                        guess[1] + coarse_offsets[:, 1] * res - best_pose[1]) - k * res * math.sqrt(2)) > apart
        for flat in order:
            a, j = np.unravel_index(flat, bounds.shape)
            if bounds[a, j] < max(rival_share * best, rival):
                break
            if not far[j]:
                continue
            s = _scores(lf.field, x0, y0, res, pts, float(guess[0]), float(guess[1]), thetas[a:a + 1],
                        fine + coarse_offsets[j])[0]
            rival = max(rival, float(s.max()))
        rival = rival if rival >= rival_share * best else 0.0
    return Correlation(best_pose, best, _covariance(scored, guess, best, best_pose, res, temperature, step), rival)


def _coarse_bounds_under_top(lf: LikelihoodField, pts: np.ndarray, guess: np.ndarray, thetas: np.ndarray,
                             coarse_offsets: np.ndarray, block: int, prune: float) -> np.ndarray:
    """The coarse level's bounds (len(thetas), len(coarse_offsets)), scored only where the level above (the field
    dilated over TOP_BLOCKS x TOP_BLOCKS coarse blocks, scored at their centres) can still beat `prune`; elsewhere
    -1, as low as a bound that is never refined. Exact: a top bound at most `prune` bounds every coarse bound under
    it. Most windows hold no good match, and then this scores about a ninth of the coarse level."""
    x0, y0 = lf.origin
    parents = np.round(coarse_offsets / (block * TOP_BLOCKS)).astype(np.int64)  # each coarse block's top block
    tops, parent_of = np.unique(parents, axis=0, return_inverse=True)
    parent_of = parent_of.reshape(-1)
    top_bounds = _scores(lf.top, x0, y0, lf.resolution, pts, float(guess[0]), float(guess[1]), thetas,
                         tops * block * TOP_BLOCKS)
    live = top_bounds[:, parent_of] > prune
    bounds = np.full((len(thetas), len(coarse_offsets)), -1.0)
    for a in np.flatnonzero(live.any(axis=1)):
        js = np.flatnonzero(live[a])
        bounds[a, js] = _scores(lf.coarse, x0, y0, lf.resolution, pts, float(guess[0]), float(guess[1]),
                                thetas[a:a + 1], coarse_offsets[js])[0]
    return bounds


def _covariance(scored, guess, best, best_pose, res, temperature, step) -> np.ndarray:
    poses, weights = [], []
    for theta, offsets, s in scored:
        xy = guess[:2] + offsets * res
        near = np.hypot(xy[:, 0] - best_pose[0], xy[:, 1] - best_pose[1]) <= 6 * res * 2
        if not near.any():
            continue
        poses.append(np.column_stack([xy[near], np.full(near.sum(), theta)]))
        weights.append(np.exp((s[near] - best) / temperature))
    floor = np.diag([(res / 2) ** 2, (res / 2) ** 2, (step / 2) ** 2])
    if not poses:
        return floor
    p, w = np.concatenate(poses), np.concatenate(weights)
    d = p - best_pose
    covariance = (d * w[:, None]).T @ d / w.sum()
    return 0.5 * (covariance + covariance.T) + floor
