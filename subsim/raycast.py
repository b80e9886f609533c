"""Geometry kernels, compiled with numba: exact ray casting on the grid, ray-circle hits, circle contacts.

Rays walk the grid with Amanatides & Woo's traversal, so the range is exact to the cell boundary the ray
enters (no fixed step that could skip a thin wall); in open space they first jump ahead by the distance the
wall distance map guarantees free (sphere tracing), which changes the speed and not the result. Circles
(other robots, people) are intersected analytically. Contact tests look only at the few cells around a robot, so the cost of the physics does not
depend on the size of the map. Everything here takes and returns numpy arrays; there are no per-cell Python
loops on the hot path.

Conventions: ``solid`` is a uint8 grid with row 0 at the lowest y; ``ox, oy`` is the world position of the
lower-left corner of cell (0, 0); circles are an (n, 3) float64 array of (x, y, radius). Everything outside
the grid is solid for contacts (robots cannot leave the map) but empty for rays (a ray that leaves the map
returns no echo).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

BUMP_LEFT, BUMP_CENTRE, BUMP_RIGHT = 1, 2, 4
CENTRE_HALF_ANGLE = math.radians(30.0)  # contacts within +-30 deg of the heading press the centre bumper


@njit(cache=True)
def grid_walk_axis(i, g, d, n):
    """Amanatides-Woo set-up along one axis, for a ray at grid coordinate g (in cell i of n) with direction
    component d: (step, t of the first boundary, t between boundaries, t where the ray leaves the grid)."""
    if d > 0.0:
        return 1, (i + 1 - g) / d, 1.0 / d, (n - g) / d
    if d < 0.0:
        return -1, (i - g) / d, -1.0 / d, -g / d
    return -1, math.inf, math.inf, math.inf


@njit(cache=True)
def _ray_grid(solid, ox, oy, res, x, y, c, s, max_range):
    """Distance along (c, s) from (x, y) to the first solid cell, or inf if none within max_range.
    A ray that starts outside the grid returns inf."""
    rows, cols = solid.shape
    gx = (x - ox) / res
    gy = (y - oy) / res
    ix = int(math.floor(gx))
    iy = int(math.floor(gy))
    if not (0 <= ix < cols and 0 <= iy < rows):
        return math.inf
    if solid[iy, ix]:
        return 0.0
    # Stop where the ray leaves the grid as well as at max_range.
    step_x, next_x, delta_x, exit_x = grid_walk_axis(ix, gx, c, cols)
    step_y, next_y, delta_y, exit_y = grid_walk_axis(iy, gy, s, rows)
    max_t = min(max_range / res, exit_x, exit_y)
    while True:
        if next_x < next_y:
            t = next_x
            ix += step_x
            next_x += delta_x
        else:
            t = next_y
            iy += step_y
            next_y += delta_y
        if t >= max_t or ix < 0 or iy < 0 or ix >= cols or iy >= rows:  # (bounds: against rounding)
            return math.inf
        if solid[iy, ix]:
            return t * res


SKIP_CHUNK = 4  # cells walked exactly near a wall before trying to skip again


@njit(cache=True)
def ray_skip(solid, wall_distance, ox, oy, res, x, y, c, s, max_range):
    """Like _ray_grid, and as exact, but faster in open space: where the wall distance map says the nearest
    solid cell is further than a cell away, jump by that (lower-bound) distance; near walls, walk the cells
    exactly, a few at a time."""
    rows, cols = solid.shape
    margin = res * 1.4142135623730951  # point-to-cell-centre, twice: makes the map distance a lower bound
    t = 0.0
    while True:
        px = x + t * c
        py = y + t * s
        ix = int(math.floor((px - ox) / res))
        iy = int(math.floor((py - oy) / res))
        if not (0 <= ix < cols and 0 <= iy < rows):
            return math.inf
        free = wall_distance[iy, ix] - margin
        if free > res:
            t += free
        else:
            chunk = min(SKIP_CHUNK * res, max_range - t)
            d = _ray_grid(solid, ox, oy, res, px, py, c, s, chunk)
            if d < math.inf:
                return t + d
            t += chunk
        if t >= max_range:
            return math.inf


@njit(cache=True)
def _ray_circle(x, y, c, s, cx, cy, r):
    """Distance along the unit direction (c, s) from (x, y) to the circle, inf if missed, 0 if inside."""
    dx = x - cx
    dy = y - cy
    b = dx * c + dy * s
    q = dx * dx + dy * dy - r * r
    if q <= 0.0:
        return 0.0
    disc = b * b - q
    if disc < 0.0 or b > 0.0:
        return math.inf
    return -b - math.sqrt(disc)


@njit(cache=True)
def cast_rays(solid, wall_distance, ox, oy, res, xs, ys, angles, max_ranges, circles):
    """Ranges (metres, inf = no echo within max_ranges[i]) of rays from (xs[i], ys[i]) at angles[i]."""
    n = xs.shape[0]
    out = np.empty(n, dtype=np.float64)
    for i in range(n):
        c = math.cos(angles[i])
        s = math.sin(angles[i])
        max_range = max_ranges[i]
        best = ray_skip(solid, wall_distance, ox, oy, res, xs[i], ys[i], c, s, max_range)
        for k in range(circles.shape[0]):
            d = _ray_circle(xs[i], ys[i], c, s, circles[k, 0], circles[k, 1], circles[k, 2])
            if d < best:
                best = d
        out[i] = best if best <= max_range else math.inf
    return out


@njit(cache=True)
def sweep(solid, wall_distance, ox, oy, res, x, y, theta, radius, laser_angles, laser_max, sonar_mounts, sonar_offsets,
          sonar_max, circles):
    """One sweep of a robot's sensors at pose (x, y, theta): laser ranges from the centre, and for each sonar
    on the rim the nearest echo among the rays of its cone. inf where nothing is within (max + 0.1 m)."""
    n_laser = laser_angles.shape[0]
    xs = np.empty(n_laser + sonar_mounts.shape[0] * sonar_offsets.shape[0])
    ys = np.empty_like(xs)
    angles = np.empty_like(xs)
    reach = np.empty_like(xs)
    k = 0
    for i in range(n_laser):
        xs[k], ys[k], angles[k], reach[k] = x, y, theta + laser_angles[i], laser_max + 0.1
        k += 1
    for i in range(sonar_mounts.shape[0]):
        mount = theta + sonar_mounts[i]
        sx, sy = x + radius * math.cos(mount), y + radius * math.sin(mount)
        for j in range(sonar_offsets.shape[0]):
            xs[k], ys[k], angles[k], reach[k] = sx, sy, mount + sonar_offsets[j], sonar_max + 0.1
            k += 1
    ranges = cast_rays(solid, wall_distance, ox, oy, res, xs, ys, angles, reach, circles)
    sonar = np.empty(sonar_mounts.shape[0])
    per = sonar_offsets.shape[0]
    for i in range(sonar_mounts.shape[0]):
        sonar[i] = ranges[n_laser + i * per:n_laser + (i + 1) * per].min()
    return ranges[:n_laser].copy(), sonar


@njit(cache=True)
def _bearing_bit(dx, dy, theta):
    bearing = math.atan2(dy, dx) - theta
    bearing = math.atan2(math.sin(bearing), math.cos(bearing))
    if abs(bearing) <= CENTRE_HALF_ANGLE:
        return BUMP_CENTRE
    return BUMP_LEFT if bearing > 0 else BUMP_RIGHT


@njit(cache=True)
def _walls_near(solid, ox, oy, res, x, y, theta, lim):
    """Over the solid cells (outside the grid counts as solid) within `lim` of (x, y): the distance to the
    nearest one (lim if none) and the bumper bits of their nearest points, seen from heading theta."""
    rows, cols = solid.shape
    best = lim
    bits = 0
    for iy in range(int(math.floor((y - lim - oy) / res)), int(math.floor((y + lim - oy) / res)) + 1):
        for ix in range(int(math.floor((x - lim - ox) / res)), int(math.floor((x + lim - ox) / res)) + 1):
            if 0 <= ix < cols and 0 <= iy < rows and not solid[iy, ix]:
                continue
            # the point of the square cell nearest to (x, y)
            dx = min(max(x, ox + ix * res), ox + (ix + 1) * res) - x
            dy = min(max(y, oy + iy * res), oy + (iy + 1) * res) - y
            d = math.hypot(dx, dy)
            if d <= lim:
                best = min(best, d)
                bits |= _bearing_bit(dx, dy, theta)
    return best, bits


@njit(cache=True)
def wall_gap(solid, ox, oy, res, x, y, r, reach):
    """Distance from the rim of the circle (x, y, r) to the nearest solid cell looked for within `reach` of
    the rim; returns reach when there is none that close. Negative means overlap. Outside the grid is solid."""
    return _walls_near(solid, ox, oy, res, x, y, 0.0, r + reach)[0] - r


@njit(cache=True)
def contact_bits(solid, ox, oy, res, x, y, theta, r, touch, circles):
    """Bumper bitmask (1 left, 2 centre, 4 right) of everything within `touch` of the circle's rim: solid
    cells and the given circles. The side is the bearing of the contact point from the heading."""
    lim = r + touch
    bits = _walls_near(solid, ox, oy, res, x, y, theta, lim)[1]
    for k in range(circles.shape[0]):
        dx = circles[k, 0] - x
        dy = circles[k, 1] - y
        if math.hypot(dx, dy) - circles[k, 2] <= lim:
            bits |= _bearing_bit(dx, dy, theta)
    return bits


@njit(cache=True)
def body_gap(solid, wall_distance, ox, oy, res, x, y, r, reach, circles):
    """Free distance from the rim of circle (x, y, r) to walls and circles, capped at `reach` (negative:
    overlap). The precomputed wall distance map answers at once when the circle is far from every wall."""
    rows, cols = solid.shape
    ix = int(math.floor((x - ox) / res))
    iy = int(math.floor((y - oy) / res))
    wall = -1.0
    if 0 <= ix < cols and 0 <= iy < rows:
        # centre-to-centre distance minus both half-diagonals: a lower bound on the true distance
        wall = wall_distance[iy, ix] - res * 1.4142135623730951 - r
        wall = min(wall, x - ox - r, y - oy - r, ox + cols * res - x - r, oy + rows * res - y - r)
    if wall <= reach:
        wall = wall_gap(solid, ox, oy, res, x, y, r, reach)
    return min(wall, reach, circles_gap(x, y, r, circles))


@njit(cache=True)
def circles_gap(x, y, r, circles):
    """Smallest rim-to-rim distance from circle (x, y, r) to the given circles (inf if there are none)."""
    best = math.inf
    for k in range(circles.shape[0]):
        d = math.hypot(circles[k, 0] - x, circles[k, 1] - y) - circles[k, 2] - r
        if d < best:
            best = d
    return best


NO_CIRCLES = np.zeros((0, 3), dtype=np.float64)


def warm_up() -> None:
    """Compile (or load from cache) every kernel once, so the first simulated step is not slow."""
    solid = np.zeros((4, 4), dtype=np.uint8)
    solid[0, 0] = 1
    one = np.ones(1)
    sweep(solid, np.zeros((4, 4), dtype=np.float32), 0.0, 0.0, 0.05, 0.1, 0.1, 0.0, 0.02, one, 1.0, one, one, 1.0, NO_CIRCLES)
    wall_gap(solid, 0.0, 0.0, 0.05, 0.1, 0.1, 0.02, 0.01)
    contact_bits(solid, 0.0, 0.0, 0.05, 0.1, 0.1, 0.0, 0.02, 0.01, NO_CIRCLES)
    body_gap(solid, np.zeros((4, 4), dtype=np.float32), 0.0, 0.0, 0.05, 0.1, 0.1, 0.02, 0.01, NO_CIRCLES)
