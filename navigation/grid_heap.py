"""The indexed 4-ary min-heap the grid searches share (the planner's A*, the landmarks' Dijkstra), as numba kernels.

Why a heap of our own: each cell is in the heap at most once, and a cheaper way to a queued cell moves it up in
place (decrease-key) instead of pushing a duplicate; four children per node halve the heap's depth, and 32-bit
cell indices halve the memory traffic on a 1000 x 1000 grid. ``pos[cell]`` is the cell's place in the heap, -1
while never queued and -2 once popped (closed).

numba's cache keys a kernel on its own file only: after editing this one, delete navigation/__pycache__ so that
the planner's and the landmarks' kernels, which inline these, are compiled again.
"""
from __future__ import annotations

import numba


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
            keys[i] = keys[child]
            vals[i] = vals[child]
            pos[vals[i]] = i
            i = child
        keys[i] = key
        vals[i] = val
        pos[val] = i
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
        keys[i] = keys[up]
        vals[i] = vals[up]
        pos[vals[i]] = i
        i = up
    keys[i] = key
    vals[i] = cell
    pos[cell] = i
    return size
