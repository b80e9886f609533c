"""Figures shared by the experiments: one run drawn on one matplotlib axis (the patrol's trajectory picture and
the vision scorer's panels draw the same way)."""
from __future__ import annotations

import math

import numpy as np

from robots.patrol.level3 import Goal
from subsim.mapio import GridMap


def draw_panel(ax, grid: GridMap, path: np.ndarray, agents: list[np.ndarray], collisions: list,
               goals: list[Goal] | None, title: str) -> None:
    """One run on one axis: the map, the robot's path (start circle, end square), other agents dashed, goals
    numbered, collisions as red crosses."""
    grid.draw(ax)
    for k, agent in enumerate(agents):
        if len(agent):
            ax.plot(agent[:, 0], agent[:, 1], "--", color="tab:orange", lw=1.0, label="person / robot" if k == 0 else None)
    if len(path):
        ax.plot(path[:, 0], path[:, 1], "-", color="tab:blue", lw=1.2, label="patrol robot")
        ax.plot(path[0, 0], path[0, 1], "o", color="tab:blue", ms=7, mfc="none", mew=2)
        ax.plot(path[-1, 0], path[-1, 1], "s", color="tab:blue", ms=6)
    for i, (x, y, yaw) in enumerate(goals or []):
        ax.plot(x, y, "*", color="tab:green", ms=14, mec="k", label="goals" if i == 0 else None)
        ax.annotate("", (x + 0.45 * math.cos(yaw), y + 0.45 * math.sin(yaw)), (x, y),
                    arrowprops={"arrowstyle": "->", "color": "tab:green", "lw": 1.5})
        ax.text(x + 0.15, y + 0.15, str(i), color="darkgreen", fontsize=11, weight="bold")
    if collisions:
        pts = np.asarray(collisions, dtype=float)
        ax.plot(pts[:, 0], pts[:, 1], "x", color="red", ms=10, mew=2.5, label=f"collisions ({len(pts)})")
    ax.set_title(title, fontsize=10)
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=7, framealpha=0.85)
