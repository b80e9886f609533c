"""What the grid searches share (the planner's A*, the landmarks' Dijkstra), as numba kernels: an indexed 4-ary
min-heap, and the step that finds the 8-connected neighbours a popped cell reaches more cheaply than before.

Why a heap of our own: each cell is in the heap at most once, and a cheaper way to a queued cell moves it up in
place (decrease-key) instead of pushing a duplicate; four children per node halve the heap's depth, and 32-bit
cell indices halve the memory traffic on a 1000 x 1000 grid. ``pos[cell]`` is the cell's place in the heap, -1
while never queued and -2 once popped (closed).

numba's cache keys a kernel on its own file only: after editing this one, delete navigation/__pycache__ so that
the planner's and the landmarks' kernels, which inline these, are compiled again.
"""
from __future__ import annotations

import math

import numba
import numpy as np

SQRT2 = math.sqrt(2.0)


@numba.njit(cache=True, inline="always")
def start(n, source):
    """A search over `n` cells from `source`: (g, pos, keys, vals, size), with g the cost so far (inf: not
    reached) and the heap holding `source` at cost 0."""
    g = np.full(n, np.inf)
    pos = np.full(n, -1, dtype=np.int32)
    keys = np.empty(n, dtype=np.float64)
    vals = np.empty(n, dtype=np.int32)
    g[source] = 0.0
    keys[0] = 0.0
    vals[0] = source
    pos[source] = 0
    return g, pos, keys, vals, 1


@numba.njit(cache=True, inline="always")
def _put(keys, vals, pos, i, key, cell):
    """Heap slot `i` holds `cell` with `key` (and `pos` says so): one step of a sift, or its end."""
    keys[i] = key
    vals[i] = cell
    pos[cell] = i


@numba.njit(cache=True, inline="always")
def pop(keys, vals, pos, size):
    """Take the cell with the least key off the heap of `size` entries; return (cell, new size). It is marked
    closed (pos -2)."""
    current = vals[0]
    pos[current] = -2
    size -= 1
    if size > 0:  # move the last entry to the root and sift it down
        key = keys[size]
        val = vals[size]
        i = 0
        while True:
            first = 4 * i + 1
            if first >= size:
                break
            child = first
            last = min(first + 4, size)
            for q in range(first + 1, last):
                if keys[q] < keys[child]:
                    child = q
            if keys[child] >= key:
                break
            _put(keys, vals, pos, i, keys[child], vals[child])
            i = child
        _put(keys, vals, pos, i, key, val)
    return current, size


@numba.njit(cache=True, inline="always")
def push(keys, vals, pos, size, cell, key):
    """Queue `cell` with `key`, or lower its key if it is queued already; return the new size."""
    i = pos[cell]
    if i < 0:
        i = size
        size += 1
    while i > 0:  # sift up
        up = (i - 1) >> 2
        if keys[up] <= key:
            break
        _put(keys, vals, pos, i, keys[up], vals[up])
        i = up
    _put(keys, vals, pos, i, key, cell)
    return size


@numba.njit(cache=True, inline="always")
def cheaper_neighbours(current, rows, cols, flat, weight, g, pos, cells, costs):
    """The 8-connected neighbours of `current` that are not closed, can be entered (`weight` of their cost value
    >= 0; a step costs its length times that) and are reached more cheaply through it than `g` says: written
    into `cells` and `costs` (8 each); returns how many."""
    r = current // cols
    c = current - r * cols
    gc = g[current]
    inner = r > 0 and r < rows - 1 and c > 0 and c < cols - 1
    found = 0
    dr = (-1, -1, -1, 0, 0, 1, 1, 1)
    dc = (-1, 0, 1, -1, 1, -1, 0, 1)
    for k in range(8):
        nr = r + dr[k]
        nc = c + dc[k]
        if not inner and (nr < 0 or nr >= rows or nc < 0 or nc >= cols):
            continue
        nxt = nr * cols + nc
        if pos[nxt] == -2:
            continue
        w = weight[flat[nxt]]
        if w < 0.0:
            continue
        candidate = gc + (1.0 if (k == 1 or k == 3 or k == 4 or k == 6) else SQRT2) * w
        if candidate >= g[nxt]:
            continue
        cells[found] = nxt
        costs[found] = candidate
        found += 1
    return found
