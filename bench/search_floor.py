"""What the correlative search's score floor saves (:func:`navigation.slam_correlative.search`, ``floor``): one
whole-map search, as global localization makes it (:meth:`navigation.global_search.GlobalSearch.correlate`), with
and without the floor, for a view that is on the map and one that is not.

The maps are those the corrected poses draw (``reference.yaml`` of :mod:`bench.real_laser`'s 0% runs, made under
``--out`` if missing). The view: the walls of another map within 8 m of its centre (not on the map searched: no
good match), and of the map searched itself (a match). Prints CPU seconds, score and pose of each; the pose found
must be the same with and without the floor.

    .venv/bin/python -m bench.search_floor [--map aces] [--view intel] [--out out/search_floor]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from navigation.global_search import GlobalSearch
from navigation.slam_match import evenly
from subsim.mapio import load_map
from subsumption.mapfile import OCCUPIED

from .real_laser import LOGS, run_map


def reference(log_name: str, out: Path):
    """The map the corrected poses of `log_name` draw."""
    path = out / f"{log_name}_drift0_seed1" / "reference.yaml"
    if not path.exists():
        run_map(log_name, 0.0, 1, out)
    return load_map(path)


def view_of(grid, reach: float = 8.0, points: int = 400) -> np.ndarray:
    """The walls of `grid` within `reach` of their centre, in a frame at that centre, thinned."""
    rows, cols = np.nonzero(grid.occupancy == OCCUPIED)
    walls = np.column_stack([grid.origin[0] + (cols + 0.5) * grid.resolution,
                             grid.origin[1] + (rows + 0.5) * grid.resolution])
    centre = walls.mean(axis=0)
    return evenly(walls[np.hypot(*(walls - centre).T) < reach] - centre, points)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--map", default="aces", choices=LOGS)
    parser.add_argument("--view", default="intel", choices=LOGS)
    parser.add_argument("--out", type=Path, default=Path("out/search_floor"))
    args = parser.parse_args(argv)
    searched = reference(args.map, args.out)
    finder = GlobalSearch(searched)
    min_score = finder.params.min_score
    for name, view in ((f"{args.view} (not on the map)", view_of(reference(args.view, args.out))),
                       (f"{args.map} (on the map)", view_of(searched))):
        print("| view | floor | CPU s | score | pose |")
        print("|---|---|---|---|---|")
        poses = []
        for floor in (0.0, min_score):
            cpu = time.process_time()
            found = finder.correlate(view, floor)
            cpu = time.process_time() - cpu
            poses.append(found.pose if found.score >= min_score else None)
            print(f"| {name} | {floor:g} | {cpu:.1f} | {found.score:.3f} | "
                  f"{np.round(found.pose, 2).tolist() if found.score >= min_score else '-'} |", flush=True)
        same = (poses[0] is None and poses[1] is None) or (poses[0] is not None and poses[1] is not None
                                                           and np.array_equal(poses[0], poses[1]))
        print(f"\n{name}: the same pose with and without the floor: {'yes' if same else 'NO'}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
