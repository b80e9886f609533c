"""Monte Carlo localization on a known map (amcl's job), as plain numpy in and out.

* **Motion**: amcl's ``diff`` odometry model (Probabilistic Robotics' sample_motion_model_odometry): the
  odometry step is split into a turn, a straight move and a turn, each disturbed per particle with noise that
  grows with the motion (``odom_alpha1..4``).
* **Sensor**: a likelihood field, ``pz = z_hit * exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max`` per beam,
  the particle's weight multiplied by the product of the beams' pz. By default it is *two-sided*
  (``likelihood_field_two_sided``): d is the larger of the beam end's distance from a wall surface on either
  side (amcl's field reads 0 anywhere inside a wall) and how deep the beam's path goes into a wall; beams that
  saw nothing up to their reach count too (their path must be open). A narrow, short scan (a depth camera's)
  sees too little for amcl's one-sided field to rule out look-alike poses; this rules out the poses whose
  beams would have ended in or gone through walls (docs/mapping.md has the measurements). amcl's own
  ``likelihood_field_prob`` (hits only, product) and ``likelihood_field`` (``1 + sum(pz^3)``) remain. Distances
  are measured to the wall's *surface* (cell centres are half a cell inside) and read bilinearly, so the
  estimate has no half-cell bias.
* **Resampling**: every ``resample_interval`` updates, low-variance resampling to a KLD-sized set
  (``kld_err``, ``kld_z``; between ``min_particles`` and ``max_particles``), with amcl's recovery: when the
  short-term average likelihood drops below the long-term one (``recovery_alpha_fast`` / ``_slow``), some
  particles are drawn uniformly over the free space, so a filter started at a wrong pose finds the right one.
* **Estimate**: particles are binned (0.5 m, 10 degrees, amcl's kd-tree resolution); the connected cluster of
  bins with the largest weight gives the pose (weighted mean) and its covariance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from statistics import NormalDist

import cv2
import numba
import numpy as np
from scipy import ndimage

from subsumption.mapfile import FREE, OCCUPIED, OccupancyMap

from subsumption.planar import wrap


LASER_MODELS = ("likelihood_field_two_sided", "likelihood_field_prob", "likelihood_field")


@dataclass
class AmclParams:
    """amcl's parameter names and meanings; defaults chosen on measurements (docs/mapping.md)."""

    min_particles: int = 300
    max_particles: int = 5000
    kld_err: float = 0.01
    kld_z: float = 0.99
    update_min_d: float = 0.1  # m moved before a filter update
    update_min_a: float = 0.2  # rad turned before a filter update
    resample_interval: int = 1
    recovery_alpha_slow: float = 0.001
    recovery_alpha_fast: float = 0.1
    odom_alpha1: float = 0.02  # rotation noise from rotation
    odom_alpha2: float = 0.02  # rotation noise from translation
    odom_alpha3: float = 0.02  # translation noise from translation
    odom_alpha4: float = 0.02  # translation noise from rotation
    laser_max_beams: int = 60
    laser_z_hit: float = 0.95
    laser_z_rand: float = 0.05
    laser_sigma_hit: float = 0.05
    laser_likelihood_max_dist: float = 2.0
    laser_max_range: float = -1.0  # m, <= 0: the scan's range_max
    laser_model_type: str = "likelihood_field_two_sided"  # or amcl's one-sided "likelihood_field_prob",
    # "likelihood_field" (amcl's 1 + sum pz^3)

    def __post_init__(self) -> None:
        if self.laser_model_type not in LASER_MODELS:
            raise ValueError(f"parameter laser_model_type: {self.laser_model_type!r} is not one of "
                             f"{', '.join(LASER_MODELS)}")

    @classmethod
    def from_mapping(cls, values: dict) -> "AmclParams":
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in values.items() if k in names})


def warm_up() -> None:
    """Compile the likelihood kernels now (or load them from numba's cache), with the argument types the filter
    uses: the first call costs about a second, several on a loaded machine, and in a node it would hold every
    callback at the first scan, ``map -> odom`` among them, while the robot is already driving."""
    particles = np.array([[0.5, 0.5, 0.0]])
    ex, ey, hit = np.array([0.2]), np.array([0.0]), np.ones(1, dtype=bool)
    field, free = np.ones((4, 4)), np.ones((4, 4), dtype=np.uint8)
    _two_sided(particles, 0.0, 0.0, ex, ey, hit, field, free, 0.0, 0.0, 0.25, 2.0, 0.95, 0.01, 0.05)
    _likelihoods(particles, ex, ey, field, free, 0.0, 0.0, 0.25, 2.0, 0.95, 0.01, 0.05, True)


class LikelihoodField:
    """Signed distance from every cell to the nearest wall surface (capped), and the free cells to draw from.

    ``distance`` is what amcl's field holds: from a cell outside the walls to the nearest wall surface, 0 inside
    a wall. ``depth`` is the other side: from a cell inside a wall to the wall's nearest surface (0 outside).
    ``signed`` = distance - depth: positive in the open, negative inside walls, 0 on a surface; read bilinearly
    it is a smooth function of position, which the two-sided model marches beams along. Unknown cells count as
    open: a map built by SLAM says nothing about them, so they neither attract nor repel a beam."""

    def __init__(self, grid: OccupancyMap, max_dist: float) -> None:
        self.grid = grid
        occupied = grid.occupancy == OCCUPIED
        half = 0.5 * grid.resolution
        if occupied.any():
            distance = cv2.distanceTransform((~occupied).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
            distance = np.clip(distance * grid.resolution - half, 0.0, max_dist)
        else:
            distance = np.full(grid.shape, max_dist)
        if (~occupied).any():
            depth = cv2.distanceTransform(occupied.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
            depth = np.clip(depth * grid.resolution - half, 0.0, max_dist)
        else:
            depth = np.full(grid.shape, max_dist)
        self.distance = np.ascontiguousarray(distance, dtype=np.float64)
        self.signed = np.ascontiguousarray(distance - depth, dtype=np.float64)
        # A particle inside a wall would see every beam end at distance 0 (the field is 0 inside walls) and win:
        # only free cells can hold the robot.
        self.free = np.ascontiguousarray(grid.occupancy == FREE, dtype=np.uint8)
        self.max_dist = float(max_dist)
        rows, cols = np.nonzero(grid.occupancy == FREE)
        self.free_xy = np.column_stack((grid.origin[0] + (cols + 0.5) * grid.resolution,
                                        grid.origin[1] + (rows + 0.5) * grid.resolution))

    def sample_free(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n poses uniformly over the free cells, headings uniform."""
        if len(self.free_xy) == 0:
            raise ValueError(f"{self.grid.source}: the map has no free cell to localize in")
        pick = self.free_xy[rng.integers(0, len(self.free_xy), n)]
        jitter = rng.uniform(-0.5, 0.5, (n, 2)) * self.grid.resolution
        return np.column_stack((pick + jitter, rng.uniform(-math.pi, math.pi, n)))


@numba.njit(cache=True, nogil=True, parallel=False)
def _likelihoods(particles, ex, ey, field, free, ox, oy, res, max_dist, z_hit, z_rand_term, sigma, product):
    """Per particle, amcl's likelihood-field weight factor 1 + sum(pz^3), or with `product` the log of the
    product of the pz (likelihood_field_prob); (ex, ey): beam ends in the robot frame. A particle off the
    free space gets (almost) nothing."""
    n, m = particles.shape[0], ex.shape[0]
    rows, cols = field.shape
    out = np.empty(n)
    denom = 2.0 * sigma * sigma
    for i in range(n):
        pc = int(math.floor((particles[i, 0] - ox) / res))
        pr = int(math.floor((particles[i, 1] - oy) / res))
        if pc < 0 or pr < 0 or pc >= cols or pr >= rows or free[pr, pc] == 0:
            out[i] = -1e9 if product else 1e-9
            continue
        c, s = math.cos(particles[i, 2]), math.sin(particles[i, 2])
        total = 0.0 if product else 1.0
        for k in range(m):
            gx = particles[i, 0] + c * ex[k] - s * ey[k]
            gy = particles[i, 1] + s * ex[k] + c * ey[k]
            fx, fy = (gx - ox) / res - 0.5, (gy - oy) / res - 0.5  # cell-centre coordinates
            c0, r0 = int(math.floor(fx)), int(math.floor(fy))
            if c0 < 0 or r0 < 0 or c0 + 1 >= cols or r0 + 1 >= rows:
                d = max_dist
            else:
                tx, ty = fx - c0, fy - r0
                d = ((1 - tx) * (1 - ty) * field[r0, c0] + tx * (1 - ty) * field[r0, c0 + 1]
                     + (1 - tx) * ty * field[r0 + 1, c0] + tx * ty * field[r0 + 1, c0 + 1])
            pz = z_hit * math.exp(-d * d / denom) + z_rand_term
            if product:
                total += math.log(pz)
            else:
                total += pz * pz * pz
        out[i] = total
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def _bilinear(field, fx, fy, outside):
    """`field` at cell-centre coordinates (fx, fy), bilinearly; `outside` off the grid."""
    rows, cols = field.shape
    c0, r0 = int(math.floor(fx)), int(math.floor(fy))
    if c0 < 0 or r0 < 0 or c0 + 1 >= cols or r0 + 1 >= rows:
        return outside
    tx, ty = fx - c0, fy - r0
    return ((1 - tx) * (1 - ty) * field[r0, c0] + tx * (1 - ty) * field[r0, c0 + 1]
            + (1 - tx) * ty * field[r0 + 1, c0] + tx * ty * field[r0 + 1, c0 + 1])


@numba.njit(cache=True, nogil=True, parallel=False)
def _two_sided(particles, sx, sy, ex, ey, hit, signed, free, ox, oy, res, max_dist, z_hit, z_rand_term, sigma):
    """Per particle, the log of the product of the beams' likelihoods under the two-sided field; (sx, sy): the
    sensor in the robot frame, (ex, ey): beam ends (hits and the reach of beams that saw nothing), `hit` which.

    A beam's error is the larger of (a) how far its end lies from a wall surface, on either side (amcl's field
    reads 0 inside a wall; here an end inside a wall is as wrong as one in the open) — for hits only — and
    (b) how deep the beam's path up to its end goes into a wall (through where the map has a wall, though the
    beam went on). (b) is found by marching along the beam on the signed field, in steps as long as the
    distance to the nearest surface (so open space costs few steps), half a cell inside walls, stopping once
    the depth is past where the likelihood is flat. A particle off the free space gets (almost) nothing."""
    n, m = particles.shape[0], ex.shape[0]
    rows, cols = signed.shape
    out = np.empty(n)
    denom = 2.0 * sigma * sigma
    cap = min(max_dist, 5.0 * sigma)  # deeper than this, the likelihood is z_rand's alone
    step_min = 0.5 * res
    for i in range(n):
        pc = int(math.floor((particles[i, 0] - ox) / res))
        pr = int(math.floor((particles[i, 1] - oy) / res))
        if pc < 0 or pr < 0 or pc >= cols or pr >= rows or free[pr, pc] == 0:
            out[i] = -1e9
            continue
        c, s = math.cos(particles[i, 2]), math.sin(particles[i, 2])
        # the sensor and the beams in cell-centre coordinates
        ax = (particles[i, 0] + c * sx - s * sy - ox) / res - 0.5
        ay = (particles[i, 1] + s * sx + c * sy - oy) / res - 0.5
        total = 0.0
        for k in range(m):
            bx = (particles[i, 0] + c * ex[k] - s * ey[k] - ox) / res - 0.5
            by = (particles[i, 1] + s * ex[k] + c * ey[k] - oy) / res - 0.5
            length = math.hypot(bx - ax, by - ay)  # in cells
            d = 0.0
            if hit[k]:
                d = abs(_bilinear(signed, bx, by, max_dist))
            if length > 0 and d < cap:
                ux, uy = (bx - ax) / length, (by - ay) / length
                t = 0.0
                limit = length - 1.0 if hit[k] else length  # a hit's last cell is the end's business
                while t < limit:
                    v = _bilinear(signed, ax + t * ux, ay + t * uy, max_dist)
                    if -v > d:
                        d = -v
                        if d >= cap:
                            break
                    t += max(v, step_min) / res
            if d > max_dist:
                d = max_dist
            total += math.log(z_hit * math.exp(-d * d / denom) + z_rand_term)
        out[i] = total
    return out


def kld_size(bins: int, err: float, z: float) -> float:
    """Fox's KLD-sampling bound: particles needed so that the KL divergence stays below err with
    probability z (z given as the quantile probability, e.g. 0.99)."""
    if bins <= 1:
        return 0.0
    k = bins - 1
    zq = NormalDist().inv_cdf(z)  # not scipy.stats: importing it at the first resample took 1-6 s in a node
    a = 2.0 / (9.0 * k)
    return k / (2.0 * err) * (1.0 - a + math.sqrt(a) * zq) ** 3


@dataclass
class Estimate:
    pose: np.ndarray  # (3,)
    covariance: np.ndarray  # (3, 3) x, y, yaw


class ParticleFilter:
    """Particles (x, y, yaw) in the map frame with weights; see the module's doc."""

    BIN = (0.5, 0.5, math.radians(10.0))

    def __init__(self, field: LikelihoodField, params: AmclParams | None = None, seed: int | None = 0) -> None:
        self.field = field
        self.params = params or AmclParams()
        self.rng = np.random.default_rng(seed)
        self.particles = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self.w_slow = 0.0
        self.w_fast = 0.0
        self.updates = 0

    # Initialisation -------------------------------------------------------------------------------
    def set_pose(self, mean: np.ndarray, covariance: np.ndarray, count: int | None = None) -> None:
        """Particles drawn from a Gaussian around `mean` (3x3 covariance x, y, yaw)."""
        n = count or self.params.max_particles
        cov = np.asarray(covariance, dtype=float) + np.diag([1e-9, 1e-9, 1e-9])
        self.particles = self.rng.multivariate_normal(np.asarray(mean, dtype=float), cov, n)
        self.particles[:, 2] = wrap(self.particles[:, 2])
        self.weights = np.full(n, 1.0 / n)
        self.w_slow = self.w_fast = 0.0

    def spread_globally(self) -> None:
        """Particles over the whole free space (amcl's global localization)."""
        n = self.params.max_particles
        self.particles = self.field.sample_free(n, self.rng)
        self.weights = np.full(n, 1.0 / n)
        self.w_slow = self.w_fast = 0.0

    # Steps ----------------------------------------------------------------------------------------
    def predict(self, previous: np.ndarray, current: np.ndarray) -> None:
        """Move the particles by the odometry step previous -> current (both odometry poses)."""
        p = self.params
        dx, dy = current[0] - previous[0], current[1] - previous[1]
        trans = math.hypot(dx, dy)
        rot1 = float(wrap(math.atan2(dy, dx) - previous[2])) if trans > 0.01 else 0.0
        rot2 = float(wrap(current[2] - previous[2] - rot1))
        # amcl: a backward move is a forward one turned round, for the noise
        r1n = min(abs(rot1), abs(float(wrap(rot1 - math.pi))))
        r2n = min(abs(rot2), abs(float(wrap(rot2 - math.pi))))
        n = len(self.particles)
        sd_rot1 = math.sqrt(p.odom_alpha1 * r1n ** 2 + p.odom_alpha2 * trans ** 2)
        sd_trans = math.sqrt(p.odom_alpha3 * trans ** 2 + p.odom_alpha4 * (r1n ** 2 + r2n ** 2))
        sd_rot2 = math.sqrt(p.odom_alpha1 * r2n ** 2 + p.odom_alpha2 * trans ** 2)
        h1 = rot1 - self.rng.normal(0.0, sd_rot1, n) if sd_rot1 > 0 else np.full(n, rot1)
        t = trans - self.rng.normal(0.0, sd_trans, n) if sd_trans > 0 else np.full(n, trans)
        h2 = rot2 - self.rng.normal(0.0, sd_rot2, n) if sd_rot2 > 0 else np.full(n, rot2)
        heading = self.particles[:, 2] + h1
        self.particles[:, 0] += t * np.cos(heading)
        self.particles[:, 1] += t * np.sin(heading)
        self.particles[:, 2] = wrap(heading + h2)

    def correct(self, ends: np.ndarray, range_max: float, hit: np.ndarray | None = None,
                origin: np.ndarray | None = None) -> None:
        """Weigh the particles by the beams' end points ((m, 2), robot frame). `hit` says which beams ended on
        something (default: all); the others saw nothing up to their end, which the two-sided model uses and
        the one-sided ones drop. `origin`: the sensor in the robot frame (default the robot's centre)."""
        p, f = self.params, self.field
        ends = np.asarray(ends, dtype=float).reshape(-1, 2)
        hit = np.ones(len(ends), dtype=bool) if hit is None else np.asarray(hit, dtype=bool)
        origin = np.zeros(2) if origin is None else np.asarray(origin, dtype=float)
        two_sided = p.laser_model_type == "likelihood_field_two_sided"
        if not two_sided:
            ends = ends[hit]
        if len(ends) == 0 or len(self.particles) == 0:
            return
        g = f.grid
        product = p.laser_model_type != "likelihood_field"
        z_rand_term = p.laser_z_rand / max(range_max, 1e-6)
        if two_sided:
            score = _two_sided(self.particles, float(origin[0]), float(origin[1]),
                               np.ascontiguousarray(ends[:, 0]), np.ascontiguousarray(ends[:, 1]),
                               np.ascontiguousarray(hit), f.signed, f.free, g.origin[0], g.origin[1], g.resolution,
                               f.max_dist, p.laser_z_hit, z_rand_term, p.laser_sigma_hit)
        else:
            score = _likelihoods(self.particles, np.ascontiguousarray(ends[:, 0]),
                                 np.ascontiguousarray(ends[:, 1]), f.distance, f.free, g.origin[0], g.origin[1],
                                 g.resolution, f.max_dist, p.laser_z_hit, z_rand_term, p.laser_sigma_hit, product)
        if product:  # log-likelihoods: scale by the best before leaving the log domain (no underflow)
            likelihood = np.exp(score - score.max())
            fit = np.exp(score / len(ends))  # per-beam geometric mean likelihood: how well the scan fits
        else:
            likelihood = fit = score
        weights = self.weights * likelihood
        total = weights.sum()
        if not total > 0:
            self.weights = np.full(len(self.particles), 1.0 / len(self.particles))
            return
        average = float((self.weights * fit).sum() / self.weights.sum())
        self.weights = weights / total
        if self.w_slow == 0.0:
            self.w_slow = self.w_fast = average
        else:
            self.w_slow += p.recovery_alpha_slow * (average - self.w_slow)
            self.w_fast += p.recovery_alpha_fast * (average - self.w_fast)
        self.updates += 1
        if self.updates % max(1, p.resample_interval) == 0:
            self.resample()

    def _bins(self, particles: np.ndarray) -> np.ndarray:
        bx, by, ba = self.BIN
        return np.column_stack((np.floor(particles[:, 0] / bx), np.floor(particles[:, 1] / by),
                                np.floor(wrap(particles[:, 2]) / ba))).astype(np.int64)

    def resample(self) -> None:
        p = self.params
        bins = self._bins(self.particles)
        occupied = len(np.unique(bins[self.weights > 0], axis=0))
        n = int(np.clip(math.ceil(kld_size(occupied, p.kld_err, p.kld_z)), p.min_particles, p.max_particles))
        random_share = 0.0
        if p.recovery_alpha_slow > 0 and self.w_slow > 0:
            random_share = max(0.0, 1.0 - self.w_fast / self.w_slow)
        n_random = int(self.rng.binomial(n, min(random_share, 1.0))) if random_share > 0 else 0
        n_keep = n - n_random
        cumulative = np.cumsum(self.weights)
        cumulative[-1] = 1.0
        positions = (self.rng.random() + np.arange(n_keep)) / max(n_keep, 1)
        kept = self.particles[np.searchsorted(cumulative, positions)]
        if n_random:
            kept = np.vstack((kept, self.field.sample_free(n_random, self.rng)))
            self.w_slow = self.w_fast = 0.0  # amcl resets the averages after injecting
        self.particles = kept
        self.weights = np.full(n, 1.0 / n)

    # Reading --------------------------------------------------------------------------------------
    def estimate(self) -> Estimate:
        """Weighted mean and covariance of the heaviest cluster of particles."""
        bins = self._bins(self.particles)
        low = bins.min(axis=0)
        shape = bins.max(axis=0) - low + 1
        if np.prod(shape) > 5_000_000:  # spread over a huge map: fall back to the whole set
            members = np.ones(len(self.particles), dtype=bool)
        else:
            grid = np.zeros(shape, dtype=bool)
            index = tuple((bins - low).T)
            grid[index] = True
            labels, count = ndimage.label(grid, structure=np.ones((3, 3, 3)))
            particle_label = labels[index]
            cluster_weight = np.bincount(particle_label, weights=self.weights, minlength=count + 1)
            members = particle_label == int(np.argmax(cluster_weight[1:]) + 1)
        w = self.weights[members]
        w = w / w.sum()
        pts = self.particles[members]
        yaw = math.atan2(float((w * np.sin(pts[:, 2])).sum()), float((w * np.cos(pts[:, 2])).sum()))
        mean = np.array([(w * pts[:, 0]).sum(), (w * pts[:, 1]).sum(), yaw])
        d = pts - mean
        d[:, 2] = wrap(d[:, 2])
        covariance = (d * w[:, None]).T @ d
        return Estimate(mean, covariance)
