"""Trajectory pictures of a run over its map: what an experiment shows to say where robots went and hit.

Headless (matplotlib's Agg backend), so it works on CI and over ssh. One colour per robot or agent; a
circle marks where each started, a square where it ended, a red x every collision.
"""
from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
import numpy as np  # noqa: E402

from .mapio import GridMap, load_map  # noqa: E402


def plot_run(map: GridMap | str | Path, trajectories: Mapping[str, np.ndarray],
             collisions: Mapping[str, Sequence[tuple[float, float]]], out_path: str | Path,
             title: str = "") -> Path:
    """Draw `trajectories` ({name: (N, 2) x, y}) and `collisions` ({name: [(x, y), ...]}) over the map and
    save the picture (PNG, or whatever the suffix of out_path says) to out_path."""
    grid = map if isinstance(map, GridMap) else load_map(map)
    aspect = grid.height_m / max(grid.width_m, 1e-9)
    fig, ax = plt.subplots(figsize=(8, max(3.0, min(12.0, 8 * aspect)) + 0.6))
    grid.draw(ax)
    colours = plt.get_cmap("tab10")
    for i, (name, xy) in enumerate(trajectories.items()):
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        if xy.size == 0:
            continue
        colour = colours(i % 10)
        ax.plot(xy[:, 0], xy[:, 1], "-", color=colour, lw=1.5, label=name)
        ax.plot(xy[0, 0], xy[0, 1], "o", color=colour, ms=8, mfc="none", mew=2)
        ax.plot(xy[-1, 0], xy[-1, 1], "s", color=colour, ms=7)
    hits = [p for points in collisions.values() for p in points]
    if hits:
        pts = np.asarray(hits, dtype=float)
        ax.plot(pts[:, 0], pts[:, 1], "x", color="red", ms=10, mew=2.5, label=f"collisions ({len(hits)})")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or Path(grid.source).stem)
    if trajectories or hits:
        ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
    ax.set_aspect("equal")
    fig.tight_layout()
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
