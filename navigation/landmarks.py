"""Landmarks for the global planner's A* (ALT: A*, landmarks, triangle inequality), built on the static costmap.

Why: on a 1000 x 1000 map of hallways the octile heuristic knows neither the walls nor the inflation cost, and the
worst plans' A* closed 96% of the cells the robot can enter (40-50 ms). With the exact cost ``d(L, n)`` from a few
landmark cells ``L`` to every cell, ``d(L, goal) - d(L, n)`` is a lower bound of the cost from ``n`` to the goal
(triangle inequality: ``d(L, goal) <= d(L, n) + d(n, goal)``), and it is consistent, so A* stays exact: it closes
less than half the cells in the worst case.

The bound holds on any costmap whose step costs are at least the landmark graph's. The landmarks are built on a
*relaxation* of the static costmap (an inscribed cell counts as passable at the highest inflation cost, since the
planner lets the robot out of one; an unknown cell as free), and the live costmap only adds the scan's obstacles,
so its costs are never lower; :func:`relaxes` checks that per plan, and a plan on a costmap that is not so
(another map, other parameters) uses the octile heuristic alone.

A build costs one Dijkstra over the whole map per landmark and one to spread them (about 30-50 ms each on the
1000 x 1000 hallways map), so it is
worth it only on a map that is planned on often: :class:`LandmarkCache` builds once the searches on that map
have closed as many cells as the build would (a ski-rental rule: planning costs at most twice what it would with
foresight, on a map that changes at every SLAM update as on one that never changes). The build can run in a
thread of its own (``background``, as move_base asks under ROS, where a 0.5-1.5 s pause in its thread would
leave the robot on its last command): plans go on with the octile heuristic meanwhile, and the Dijkstra kernel
releases the GIL and the thread runs at a lower priority, so they keep their pace.
"""
from __future__ import annotations

import logging
import os
import threading
import weakref
from dataclasses import dataclass

import numba
import numpy as np

from . import grid_heap as heap
from .costmap import INSCRIBED, NO_INFORMATION

_log = logging.getLogger(__name__)


def step_weights(cost_factor: float, allow_unknown: bool, lethal_from: int) -> np.ndarray:
    """A step's multiplier per cost value, -1 where a cell cannot be entered (the planner's table)."""
    values = np.arange(256, dtype=np.float64)
    weight = 1.0 + cost_factor * values / 252.0
    weight[lethal_from:NO_INFORMATION] = -1.0
    weight[NO_INFORMATION] = 1.0 if allow_unknown else -1.0
    return weight


def relaxed_weights(cost_factor: float, lethal_from: int) -> np.ndarray:
    """The landmark graph's table: no step dearer than the planner's on the same cell, with inscribed cells
    passable (the planner frees those round the start) and unknown cells free (whether or not it plans through
    them)."""
    weight = step_weights(cost_factor, True, lethal_from)
    if lethal_from <= INSCRIBED:
        weight[INSCRIBED] = 1.0 + cost_factor * 252 / 252.0
    return weight


@numba.njit(cache=True, nogil=True)
def _dijkstra(costs, weight, source):
    """Cost from `source` to every cell (entering a cell costs step length x its weight), float32, inf where
    it cannot be reached: the planner's A* without a goal, with the same indexed 4-ary heap."""
    rows, cols = costs.shape
    n = rows * cols
    g, pos, keys, vals, size = heap.start(n, source)
    flat = costs.ravel()
    cells = np.empty(8, dtype=np.int64)
    reached = np.empty(8)
    while size > 0:
        current, size = heap.pop(keys, vals, pos, size)
        for j in range(heap.cheaper_neighbours(current, rows, cols, flat, weight, g, pos, cells, reached)):
            g[cells[j]] = reached[j]
            size = heap.push(keys, vals, pos, size, cells[j], reached[j])
    # float32: half the memory traffic; its rounding (6e-8 relative) is far below the planner's 1e-4 tie-break
    out = np.empty(n, dtype=np.float32)
    for i in range(n):
        out[i] = np.float32(g[i])
    return out


@numba.njit(cache=True)
def relaxes(static, live, relaxed, weight):
    """True when no cell of `live` (under the planner's `weight` table) is cheaper to enter than the same cell of
    `static` under the landmark graph's `relaxed` table: the condition for the landmarks' bound to hold."""
    a = static.ravel()
    b = live.ravel()
    for i in range(a.size):
        w = weight[b[i]]
        if w < 0.0:
            continue
        v = relaxed[a[i]]
        if v < 0.0 or v > w:
            return False
    return True


@dataclass
class Landmarks:
    """Costs from `cells` (flat indices) to every cell of the map they were built on: (count, rows * cols)."""

    cells: np.ndarray
    distances: np.ndarray
    relaxed: np.ndarray  # the weight table they were built with


def build(static: np.ndarray, relaxed: np.ndarray, count: int, seed: int | None = None) -> Landmarks:
    """`count` landmarks spread by farthest-point selection from cell `seed` (flat index; the first enterable
    cell in row order without one): the cell whose cost from the seed is largest, then each time the cell whose
    cost from the nearest chosen landmark is largest. Landmarks round the rim of the seed's part of the map
    bound most pairs in it well; a seed where the robot is keeps them out of closed pockets of the map."""
    static = np.ascontiguousarray(static, dtype=np.uint8)
    relaxed = np.asarray(relaxed, dtype=np.float64)
    empty = Landmarks(np.zeros(0, np.int64), np.zeros((0, static.size), np.float32), relaxed)
    if seed is None or not 0 <= seed < static.size or relaxed[static.flat[seed]] < 0.0:
        enterable = np.flatnonzero(relaxed[static.ravel()] >= 0.0)
        if len(enterable) == 0:
            return empty
        seed = int(enterable[0])
    nearest = _dijkstra(static, relaxed, int(seed))
    cells: list[int] = []
    rows: list[np.ndarray] = []
    while len(cells) < count:
        spread = np.where(np.isfinite(nearest), nearest, -1.0)
        far = int(np.argmax(spread))
        if spread[far] <= 0.0:
            break
        cells.append(far)
        rows.append(_dijkstra(static, relaxed, far))
        nearest = rows[0].copy() if len(rows) == 1 else np.minimum(nearest, rows[-1])
    if not cells:
        return empty
    return Landmarks(np.array(cells, dtype=np.int64), np.stack(rows), relaxed)


@dataclass
class _State:
    static: np.ndarray
    key: tuple
    enterable: int
    closed: int = 0
    landmarks: Landmarks | None = None  # set once, whole, when a build has finished
    builder: threading.Thread | None = None  # the background build, once started
    failures: int = 0  # background builds that raised (each logged; the next is due after as many searches again)


class LandmarkCache:
    """Landmarks per costmap (held weakly: a costmap that is dropped takes its landmarks with it), rebuilt when
    its static costs or the planner's parameters change, built only once searches on it have closed as many
    cells as the build visits (``count`` x the enterable cells).

    Thread safety: a build, in the foreground or in a thread, writes only the :class:`_State` it was started
    for, and only its finished landmarks (one assignment). A change of the static costs or the parameters gives
    the owner a new state, so a build under way for the old one can never hand out stale landmarks."""

    def __init__(self) -> None:
        self._states: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
        self._lock = threading.Lock()  # a state's build is started at most once

    def get(self, owner: object, static: np.ndarray, cost_factor: float, lethal_from: int,
            count: int) -> tuple[_State, Landmarks | None]:
        """The landmark state for `owner`'s static costmap; a new build starts when the map or the cost settings
        change."""
        key = (float(cost_factor), int(lethal_from), int(count))
        with self._lock:
            state = self._states.get(owner)
            if state is None or state.static is not static or state.key != key:
                relaxed = relaxed_weights(cost_factor, lethal_from)
                state = _State(static, key, int(np.count_nonzero(relaxed[static] >= 0.0)))
                self._states[owner] = state
        return state, state.landmarks

    def prepare(self, owner: object, static: np.ndarray, cost_factor: float, lethal_from: int,
                count: int, seed: int | None = None) -> Landmarks:
        """Build `owner`'s landmarks now (when a caller knows the map will be planned on often)."""
        state, landmarks = self.get(owner, static, cost_factor, lethal_from, count)
        if landmarks is None:
            _build(state, seed)
        return state.landmarks

    def searched(self, state: _State, closed: int, seed: int, background: bool = False) -> None:
        """Count a search's closed cells; build the landmarks (spread from `seed`, the search's start, a flat
        index) once the searches have cost as much as a build: ``count + 1`` passes over the enterable cells.
        With `background` the build runs in a daemon thread (``state.builder``) and this returns at once."""
        with self._lock:
            state.closed += closed
            count = state.key[2]
            if (state.landmarks is not None or state.builder is not None or count <= 0
                    or state.closed < (count + 1) * state.enterable):
                return
            if background:
                state.builder = threading.Thread(target=self._build_aside, args=(state, seed), name="landmarks",
                                                 daemon=True)
                state.builder.start()
                return
        _build(state, seed)

    def _build_aside(self, state: _State, seed: int | None) -> None:
        """_build in a thread of its own, at a lower priority (Linux threads have their own nice value). A build
        that raises (memory, most likely, on a huge map) is logged and leaves the plans on the octile heuristic,
        exact but slower; the searches' count starts again, so the build is tried once more after as many
        searches, not at the next plan."""
        try:
            me = threading.get_native_id()
            os.setpriority(os.PRIO_PROCESS, me, min(os.getpriority(os.PRIO_PROCESS, me) + BUILD_NICENESS, 19))
        except (AttributeError, OSError):  # no per-thread priority here: build at the caller's
            pass
        try:
            _build(state, seed)
        except Exception:  # noqa: BLE001 - a thread's exception would otherwise vanish into stderr
            _log.exception("landmarks: building them for the planner's A* failed; plans use the octile heuristic "
                           "until a new try after as many searches again")
            with self._lock:
                state.failures += 1
                state.closed = 0
                state.builder = None


def _build(state: _State, seed: int | None) -> None:
    """Build `state`'s landmarks and install them whole."""
    cost_factor, lethal_from, count = state.key
    state.landmarks = build(state.static, relaxed_weights(cost_factor, lethal_from), count, seed)


BUILD_NICENESS = 5  # added to a background build's thread: on a busy machine the control loop's thread goes first

