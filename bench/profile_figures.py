"""Pictures of bench/profile_patrol.py's runs (``--figure DIR``), drawn with the experiments' own figure code:
level 1, the landing between two stairwells with the robot's path, the stairwells and where the Kobuki's cliff
sensors fired; level 3, the path and the goals; levels 4-5, the patrol experiment's encounter picture (the paper's
Fig. 7(e): both paths, the goals, where the alarm came, the stop, the pursuit; the distance to the target below).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: figures are files
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402

from experiments.figures import draw_panel  # noqa: E402
from experiments.runner import RunResult, RunSpec, map_of  # noqa: E402
from subsim.mapio import load_map  # noqa: E402
from subsim.world import load_world  # noqa: E402


def _title(seen: dict, f: dict) -> str:
    text = (f"patrol.launch robot:={seen['robot']} level:={seen['level']}, {seen['t']:.0f} simulated s: "
            f"{f['collisions']} collisions")
    if seen["level"] == 1:
        return text + f", {f['cliffs']} cliff events"
    return text + f", goals reached (move_base) {f['succeeded']}"


def draw(seen: dict, f: dict, goals: list[list[float]], folder: Path) -> Path:
    """The picture of the run `seen` (its figures `f`, its goals) in `folder`; returns its path."""
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / f"profile_patrol_{seen['robot']}_level{seen['level']}.png"
    world_file = Path(seen["world"])
    path = np.array([p[1:3] for p in seen["path"]]).reshape(-1, 2)
    goals = [tuple(g) for g in goals] or None
    if "vision" in seen:  # levels 4-5
        from experiments.patrol_vision import VisionObserver, score
        from experiments.patrol_vision_report import write_encounter

        observer = VisionObserver.from_record(seen["vision"])
        encounter = score(observer, world_file, seen["sent"], seen["t"])
        agents = [np.array([a[k][:2] for _, a in observer.agent_path]) for k in range(len(observer.agent_path[0][1]))]
        result = RunResult(RunSpec("patrol", seen["level"], world_file, seen["duration"], runtime="ros"), encounter.metrics,
                           trajectory=[tuple(p) for p in path], agents=[a.tolist() for a in agents])
        write_encounter(encounter, observer, result, goals, out, _title(seen, f))
        return out
    grid = load_map(map_of(world_file))
    fig, ax = plt.subplots(figsize=(8, 8 * grid.height_m / grid.width_m + 0.8))
    draw_panel(ax, grid, path, [], [], goals, _title(seen, f))
    if seen["level"] == 1:
        world = load_world(world_file)
        for k, polygon in enumerate(world.cliffs):
            ax.add_patch(Polygon(polygon, closed=True, facecolor="tab:red", alpha=0.18, hatch="//",
                                 edgecolor="tab:red", label="stairwell (the floor drops away)" if k == 0 else None))
        events = np.array([c[3:5] for c in seen.get("cliffs", []) if c[2] == 1 and c[3] is not None]).reshape(-1, 2)
        if len(events):  # the robot's outline where a cliff sensor (on its front rim) fired
            radius = world.robots[0].radius
            for k, (x, y) in enumerate(events):
                ax.add_patch(plt.Circle((x, y), radius, fill=False, color="tab:red", lw=1.2,
                                        label=f"the robot when a cliff sensor fired ({len(events)})" if k == 0
                                        else None))
        corners = np.array([p for polygon in world.cliffs for p in polygon] + path.tolist())
        lo, hi = corners.min(axis=0) - 0.5, corners.max(axis=0) + 0.5
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
