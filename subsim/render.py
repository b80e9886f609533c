"""The RGB-D camera's renderer, compiled with numba: the 2D world extruded into 2.5D, one ray per image column.

For each column the ray is cast through the grid once (:func:`subsim.raycast.ray_skip`, the same exact
Amanatides-Woo walk the laser uses, sped up by the wall distance map) and does not stop at the first solid cell
unless that cell is a full-height wall: every run of solid cells of one height becomes a *span* (a box standing
on the floor from the distance where the ray enters it to where it leaves). Circles (people, robots) add spans
with their own height, pictures add thin spans between their bottom and top edges with a texture. Then each
pixel of the column walks the spans, nearest first: row v looks along the slope (v - cy) / fy, so at distance z
the ray is at height ``cam_h - z (v - cy) / fy``; the first span whose front face (or top, seen from above) the
ray meets is what the pixel shows; if the ray reaches the floor or the ceiling first, it shows that. Nearer
things hide farther ones, low boxes (tables) let the camera see over them, and nothing is seen through a wall.

Depth is the z of the optical frame (the distance along the optical axis, not along the ray), as a Kinect's
registered depth image has it; colour and depth come from the same hit, so they are registered by construction.
Pictures are sampled bilinearly from a mip level chosen by their size on screen, so a far face is not aliased.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .raycast import grid_walk_axis, ray_skip

MAX_SPANS = 32  # per column: plenty for a room; farther spans beyond are dropped
LEVELS = 6  # mip levels per picture (full size, 1/2, ... 1/32)

BLOCK, CIRCLE, CARD_FRONT, CARD_BACK = 0, 1, 2, 3
CARD_BACK_RGB = (235.0, 235.0, 228.0)
SKIRTING_M = 0.08  # walls are darker this close to the floor: where a wall meets the floor shows


@njit(cache=True)
def _grid_spans(solid, wall_distance, height, colour, ox, oy, res, x, y, c, s, max_dist, ceiling,
                t0, t1, top, rgb, kind, n):
    """Append the grid's spans along the ray to the span arrays from index n; returns (n, distance of the
    full-height wall that ends the ray, or inf)."""
    rows, cols = solid.shape
    t = 0.0
    while n < MAX_SPANS:
        d = ray_skip(solid, wall_distance, ox, oy, res, x + t * c, y + t * s, c, s, max_dist - t)
        if d == math.inf:
            return n, math.inf
        t += d
        gx = (x + t * c - ox) / res
        gy = (y + t * s - oy) / res
        # the face crossed: the grid line the entry point lies on (vertical lines: x faces, lit fully)
        shade = 1.0 if abs(gx - round(gx)) <= abs(gy - round(gy)) else 0.82
        ix = int(math.floor(gx + c * 1e-6))
        iy = int(math.floor(gy + s * 1e-6))
        if not (0 <= ix < cols and 0 <= iy < rows):
            return n, math.inf
        h = height[iy, ix]
        # walk exactly while the cells stay solid and of the same height
        step_x, next_x, delta_x, _ = grid_walk_axis(ix, gx, c, cols)
        step_y, next_y, delta_y, _ = grid_walk_axis(iy, gy, s, rows)
        jx, jy = ix, iy
        while True:
            if next_x < next_y:
                local = next_x
                jx += step_x
                next_x += delta_x
            else:
                local = next_y
                jy += step_y
                next_y += delta_y
            if not (0 <= jx < cols and 0 <= jy < rows) or not solid[jy, jx] or height[jy, jx] != h:
                break
        t_exit = t + local * res
        t0[n] = t
        t1[n] = t_exit
        top[n] = h
        for k in range(3):
            rgb[n, k] = colour[iy, ix, k] * shade
        kind[n] = BLOCK
        n += 1
        if h >= ceiling - 1e-6:
            return n, t
        t = t_exit + 1e-6
        if t >= max_dist:
            return n, math.inf
    return n, math.inf


@njit(cache=True)
def _sample(atlas, tex_size, tex, level, u, v, out):
    """Bilinear sample of picture `tex` at mip `level`, at (u, v) in [0, 1] (u across, v down)."""
    h = tex_size[tex, level, 0]
    w = tex_size[tex, level, 1]
    fx = min(max(u, 0.0), 1.0) * (w - 1)
    fy = min(max(v, 0.0), 1.0) * (h - 1)
    x0 = int(fx)
    y0 = int(fy)
    x1 = min(x0 + 1, w - 1)
    y1 = min(y0 + 1, h - 1)
    ax = fx - x0
    ay = fy - y0
    for k in range(3):
        top = atlas[tex, level, y0, x0, k] * (1.0 - ax) + atlas[tex, level, y0, x1, k] * ax
        bottom = atlas[tex, level, y1, x0, k] * (1.0 - ax) + atlas[tex, level, y1, x1, k] * ax
        out[k] = top * (1.0 - ay) + bottom * ay


@njit(cache=True)
def render(solid, wall_distance, height, colour, ox, oy, res,
           cam_x, cam_y, cam_yaw, cam_h, fx, fy, cx, cy, width, row0, row1, max_dist, ceiling,
           floor_rgb, ceiling_rgb, min_depth, max_depth,
           circles, circle_rgb, cards, card_tex, atlas, tex_size, want_rgb, rgb_out, depth_out):
    """Render image rows [row0, row1) of a level pinhole camera at (cam_x, cam_y, cam_h) facing cam_yaw.

    circles: (n, 4) x, y, radius, height; circle_rgb (n, 3). cards: (m, 6) left end x, y, right end x, y (as
    seen from the front), bottom, top; card_tex (m,) picture index into atlas (T, LEVELS, H, W, 3) uint8 with
    tex_size (T, LEVELS, 2) = (h, w). Writes depth_out (width, rows) float32 (z in metres; NaN outside
    [min_depth, max_depth]) and, if want_rgb, rgb_out (width, rows, 3) uint8: column-major, because a column
    is rendered at a time (cv2.transpose makes images of them at memory speed)."""
    t0 = np.empty(MAX_SPANS)
    t1 = np.empty(MAX_SPANS)
    bottom = np.empty(MAX_SPANS)
    top = np.empty(MAX_SPANS)
    span_rgb = np.empty((MAX_SPANS, 3))
    kind = np.empty(MAX_SPANS, np.int64)
    tex = np.empty(MAX_SPANS, np.int64)
    tex_u = np.empty(MAX_SPANS)
    tex_level = np.empty(MAX_SPANS, np.int64)
    order = np.empty(MAX_SPANS, np.int64)
    texel = np.empty(3)
    nan = np.float32(np.nan)
    rows = row1 - row0
    covered = np.zeros(rows, np.uint8)
    floor_z = np.empty(rows)  # z where each row's ray meets the floor (below the horizon) or the ceiling
    for v in range(row0, row1):
        slope = (v - cy) / fy
        floor_z[v - row0] = cam_h / slope if slope > 0 else ((ceiling - cam_h) / -slope if slope < 0 else math.inf)
    for u in range(width):
        xn = (u - cx) / fx  # x of the optical frame at z = 1 (right of the axis positive)
        alpha = -math.atan(xn)  # the column's bearing from the optical axis (left positive)
        cos_a = math.cos(alpha)
        c = math.cos(cam_yaw + alpha)
        s = math.sin(cam_yaw + alpha)
        for k in range(MAX_SPANS):
            bottom[k] = 0.0
        n, t_block = _grid_spans(solid, wall_distance, height, colour, ox, oy, res, cam_x, cam_y, c, s,
                                 max_dist, ceiling, t0, t1, top, span_rgb, kind, 0)
        for k in range(circles.shape[0]):
            if n >= MAX_SPANS:
                break
            dx = cam_x - circles[k, 0]
            dy = cam_y - circles[k, 1]
            r = circles[k, 2]
            b = dx * c + dy * s
            q = dx * dx + dy * dy - r * r
            disc = b * b - q
            if disc <= 0.0 or q <= 0.0:
                continue
            root = math.sqrt(disc)
            near = -b - root
            if near <= 0.0 or near >= t_block:
                continue
            # Lambert shading by the surface normal at the hit: a cylinder looks round
            nx = (dx + near * c) / r
            ny = (dy + near * s) / r
            shade = 0.45 + 0.55 * max(0.0, -(nx * c + ny * s))
            t0[n] = near
            t1[n] = -b + root
            top[n] = circles[k, 3]
            for j in range(3):
                span_rgb[n, j] = circle_rgb[k, j] * shade
            kind[n] = CIRCLE
            n += 1
        for k in range(cards.shape[0]):
            if n >= MAX_SPANS:
                break
            ex = cards[k, 2] - cards[k, 0]
            ey = cards[k, 3] - cards[k, 1]
            den = c * ey - s * ex
            if abs(den) < 1e-12:
                continue
            wx = cards[k, 0] - cam_x
            wy = cards[k, 1] - cam_y
            t = (wx * ey - wy * ex) / den
            along = (wx * s - wy * c) / den
            if t <= 0.0 or t >= t_block or along < 0.0 or along > 1.0:
                continue
            t0[n] = t
            t1[n] = t
            bottom[n] = cards[k, 4]
            top[n] = cards[k, 5]
            # the card's front faces along (ey, -ex) (its left-to-right edge turned clockwise): seen if the
            # ray runs against it
            if den < 0.0:
                kind[n] = CARD_FRONT
                tex[n] = card_tex[k]
                tex_u[n] = along
                z = t * cos_a
                on_screen = fy * (cards[k, 5] - cards[k, 4]) / max(z, 1e-6)
                level = 0
                while level < LEVELS - 1 and tex_size[card_tex[k], level + 1, 0] >= on_screen:
                    level += 1
                tex_level[n] = level
            else:
                kind[n] = CARD_BACK
                span_rgb[n, 0] = CARD_BACK_RGB[0]
                span_rgb[n, 1] = CARD_BACK_RGB[1]
                span_rgb[n, 2] = CARD_BACK_RGB[2]
            n += 1
        # nearest first (insertion sort of a few spans)
        for k in range(n):
            order[k] = k
        for k in range(1, n):
            key = order[k]
            j = k - 1
            while j >= 0 and t0[order[j]] > t0[key]:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = key
        # paint the spans nearest first, each over the rows its face covers that nothing nearer covers
        for r in range(rows):
            covered[r] = 0
        dcol = depth_out[u]
        ccol = rgb_out[u] if want_rgb else rgb_out[0]
        for k in range(n):
            i = order[k]
            z_in = t0[i] * cos_a
            if z_in <= 1e-6:
                continue
            inv = fy / z_in
            v_top = cy + (cam_h - top[i]) * inv
            first = max(row0, int(math.ceil(v_top)))
            last = min(row1 - 1, int(math.floor(cy + (cam_h - bottom[i]) * inv)))
            depth = z_in if min_depth <= z_in <= max_depth else nan
            if kind[i] == CARD_FRONT:
                span_px = (cam_h - bottom[i]) * inv - (cam_h - top[i]) * inv
                for v in range(first, last + 1):
                    if covered[v - row0]:
                        continue
                    covered[v - row0] = 1
                    dcol[v - row0] = depth
                    if want_rgb:
                        _sample(atlas, tex_size, tex[i], tex_level[i], tex_u[i], (v - v_top) / span_px, texel)
                        for j in range(3):
                            ccol[v - row0, j] = np.uint8(min(255.0, texel[j]))
                continue
            skirting = cy + (cam_h - SKIRTING_M) * inv if kind[i] == BLOCK and top[i] >= ceiling - 1e-6 else 1e9
            for v in range(first, last + 1):
                if covered[v - row0]:
                    continue
                covered[v - row0] = 1
                dcol[v - row0] = depth
                if want_rgb:
                    shade = 0.55 if v > skirting else 1.0
                    for j in range(3):
                        ccol[v - row0, j] = np.uint8(span_rgb[i, j] * shade)
            if kind[i] <= CIRCLE and cam_h > top[i]:  # seen from above: its top, up to where the ray leaves it
                z_out = t1[i] * cos_a
                top_first = max(row0, int(math.ceil(cy + (cam_h - top[i]) * fy / z_out)))
                for v in range(top_first, min(first, row1)):
                    if covered[v - row0]:
                        continue
                    covered[v - row0] = 1
                    z = (cam_h - top[i]) * fy / (v - cy)
                    dcol[v - row0] = z if min_depth <= z <= max_depth else nan
                    if want_rgb:
                        for j in range(3):
                            ccol[v - row0, j] = np.uint8(min(255.0, span_rgb[i, j] * 1.12))
        # what is left is floor (below the horizon) or ceiling
        for v in range(row0, row1):
            if covered[v - row0]:
                continue
            z = floor_z[v - row0]
            dcol[v - row0] = z if min_depth <= z <= max_depth else nan
            if not want_rgb:
                continue
            if v > cy:
                px = cam_x + z * c / cos_a
                py = cam_y + z * s / cos_a
                shade = 1.0 if ((int(math.floor(px * 2.0)) + int(math.floor(py * 2.0))) & 1) == 0 else 0.9
                for j in range(3):
                    ccol[v - row0, j] = np.uint8(floor_rgb[j] * shade)
            else:
                for j in range(3):
                    ccol[v - row0, j] = np.uint8(ceiling_rgb[j])


def warm_up() -> None:
    """Compile (or load from cache) the renderer once."""
    solid = np.zeros((4, 4), np.uint8)
    solid[0, :] = 1
    height = solid.astype(np.float32) * 2.5
    colour = np.zeros((4, 4, 3), np.uint8)
    atlas = np.zeros((1, LEVELS, 2, 2, 3), np.uint8)
    tex_size = np.ones((1, LEVELS, 2), np.int64) * 2
    rgb = np.zeros((2, 2, 3), np.uint8)
    depth = np.zeros((2, 2), np.float32)  # (columns, rows)
    render(solid, np.zeros((4, 4), np.float32), height, colour, 0.0, 0.0, 0.05, 0.1, 0.1, 0.0, 0.3, 1.0, 1.0,
           0.5, 0.5, 2, 0, 2, 5.0, 2.5, np.zeros(3), np.zeros(3), 0.1, 5.0, np.zeros((1, 4)), np.zeros((1, 3)),
           np.zeros((1, 6)), np.zeros(1, np.int64), atlas, tex_size, True, rgb, depth)
