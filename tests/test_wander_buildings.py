"""The wander robot in a building it was not made on: level 2 on a generated office (a seed the coverage bench
does not use) goes through a doorway into a room, out again and into another, without touching anything.

One 5-minute local run (a few seconds of CPU alone); bench/wander_coverage gives the full figures."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from experiments.runner import RunSpec, run_local
from subsim.maps import generate
from subsim.mapio import FREE, OCCUPIED

SEED = 23  # bench/wander_coverage uses seeds 1-5; the modules were never looked at on this map
MINUTES = 5


def rooms_visited(layout: generate.Layout, xy: np.ndarray) -> list[int]:
    """The rooms (numbered by connected region with every doorway closed) the path went into, in the order it
    first entered them; the corridor is region 0. A point counts once the robot's centre is 0.4 m past the
    doorway (the robot is 0.36 m across), so standing in a doorway is not entering."""
    closed = layout.grid.copy()
    for x0, y0, x1, y1 in layout.doors:  # a door is drawn in its wall: grow it to block the gap fully
        generate.fill(closed, x0, y0 - 0.4, x1, y1 + 0.4, OCCUPIED)
    labels, _ = ndimage.label(closed == FREE)
    cells = np.floor(xy / generate.RES).astype(int)
    region = labels[cells[:, 1], cells[:, 0]]
    corridor = region[0]
    order: list[int] = []
    for r in region:
        if r and r != corridor and r not in order:
            order.append(int(r))
    return order


@pytest.fixture(scope="module")
def office_run(tmp_path_factory):
    layout = generate.office(seed=SEED)
    world = generate.write_layout(layout, tmp_path_factory.mktemp("office"), f"office_seed{SEED}")
    result = run_local(RunSpec("wander", 2, world, MINUTES * 60.0, seed=SEED))
    return layout, result


def test_level_2_goes_into_a_room_and_out_again_into_another_without_a_collision(office_run):
    """Two rooms entered means one was left again, by its doorway (the only way out): the issue's robot never
    got into a room at all."""
    layout, result = office_run
    xy = np.asarray(result.trajectory, dtype=float)
    assert result.metrics["collisions"] == 0
    visited = rooms_visited(layout, xy)
    assert len(visited) >= 2, f"rooms entered in {MINUTES} minutes: {len(visited)} of 4 (doorways " \
                              f"{[round(w, 2) for w in layout.door_widths]} m)"
