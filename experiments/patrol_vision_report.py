"""What level 4's run leaves besides its metrics: the paper's Fig. 7(e) for the encounter (``encounter.png``),
camera frames with the tracked and the true face box (``camera_strip.png``), and the scorer's record
(``vision_record.json``, to score the run again with :func:`experiments.patrol_vision.rescore`).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import matplotlib
import numpy as np

from subsim.mapio import load_map
from subsim.world import load_world

from .face_truth import FaceCard, face_cards, iou
from .figures import draw_panel
from .patrol_vision import Encounter, Truth, VisionObserver, score
from .runner import map_of

matplotlib.use("Agg")  # headless: figures are files, on CI and over ssh alike
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)


def write_encounter(encounter: Encounter, observer: VisionObserver, result, goals, out_path: Path,
                    title: str) -> None:
    """The paper's Fig. 7(e): the map with the robot's and the target's paths and the encounter's moments;
    below, the distance to the target over time with the pursuit shaded."""
    m = encounter.metrics
    grid = load_map(map_of(result.spec.world))
    truth = Truth(observer)
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 8 * grid.height_m / grid.width_m + 3.4),
                                 gridspec_kw={"height_ratios": [grid.height_m / grid.width_m * 2.6, 1]})
    draw_panel(ax, grid, np.array(result.trajectory).reshape(-1, 2),
               [np.array(a).reshape(-1, 2) for a in result.agents], result.collision_points, goals, title)
    for start, end in encounter.pursuits:
        ts = truth.rt[(truth.rt >= start) & (truth.rt <= end)]
        if len(ts):
            xy = np.array([truth.robot_at(t)[:2] for t in ts])
            ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:red", lw=3, alpha=0.7,
                    label="pursuit (stop, follow)" if start == encounter.pursuits[0][0] else None)
    marks = [("detected_at_s", "o", "red", "alarm"), ("stopped_at_s", "s", "black", "stopped"),
             ("lost_at_s", "X", "purple", "target lost"), ("resumed_patrol_at_s", "^", "tab:green", "patrol resumed")]
    for key, marker, colour, label in marks:
        t = m.get(key)
        if t is None:
            continue
        x, y, _ = truth.robot_at(t)
        ax.plot(x, y, marker, color=colour, ms=10, mec="white", mew=1.5, label=f"{label} {t:.1f} s", zorder=5)
        if key == "detected_at_s" and len(truth.at):
            card = face_cards_cache(result.spec.world)
            if card:
                tx, ty, _ = truth.agent_at(card[0].agent, t)
                ax.plot([x, tx], [y, ty], ":", color="red", lw=1.5)
                ax.plot(tx, ty, "*", color="red", ms=12, mec="k", label="target at the alarm")
    ax.legend(loc="upper right", fontsize=7, framealpha=0.85)
    cards = face_cards_cache(result.spec.world)
    if cards and len(truth.at):
        ts = truth.rt
        d = [math.hypot(truth.agent_at(cards[0].agent, t)[0] - truth.robot_at(t)[0],
                        truth.agent_at(cards[0].agent, t)[1] - truth.robot_at(t)[1]) for t in ts]
        bx.plot(ts, d, color="tab:orange", lw=1.2, label="distance robot - target (truth)")
        for start, end in encounter.pursuits:
            bx.axvspan(start, end, color="tab:red", alpha=0.15, label="pursuit" if start == encounter.pursuits[0][0]
                       else None)
        for key, _, colour, label in marks:
            if m.get(key) is not None:
                bx.axvline(m[key], color=colour, lw=1, ls="--", label=label)
        closed = [p["closed_in_at_s"] for p in m.get("pursuits", []) if p.get("closed_in_at_s") is not None]
        for k, t in enumerate(closed):  # where mean_follow_distance_m starts counting in each pursuit
            bx.axvline(t, color="tab:blue", lw=1, ls="-.", label="closed in (follow distance from here)" if k == 0
                       else None)
        bx.axhline(1.2, color="gray", lw=0.8, ls=":", label="following distance")
        bx.set_xlabel("simulated time (s)")
        bx.set_ylabel("m")
        bx.legend(loc="upper right", fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(out_path, dpi=100)
    plt.close(fig)


_CARDS: dict[str, list[FaceCard]] = {}


def face_cards_cache(world_file: Path) -> list[FaceCard]:
    """The face cards of a world file's agents, loaded once per file."""
    key = str(world_file)
    if key not in _CARDS:
        _CARDS[key] = face_cards(load_world(world_file))
    return _CARDS[key]


def write_strip(encounter: Encounter, observer: VisionObserver, out_path: Path, count: int = 8) -> bool:
    """Camera frames of the first pursuit (from just before the alarm) with the tracked box (green) and the true
    face box (white, scoring only); False when no frame was kept."""
    if not observer.frames:
        return False
    frames = sorted(observer.frames)
    start = encounter.pursuits[0][0] - 1.0 if encounter.pursuits else frames[0][0]
    end = encounter.pursuits[0][1] if encounter.pursuits else frames[-1][0]
    chosen = [f for f in frames if start <= f[0] <= end] or frames
    box_times = np.array([t for t, _ in observer.boxes]) if observer.boxes else np.zeros(0)
    boxed = [f for f in chosen if len(box_times) and np.min(np.abs(box_times - f[0])) < 0.02]
    picks = []
    for i in np.linspace(0, len(chosen) - 1, min(count, len(chosen))):
        t = chosen[round(i)][0]
        near = min(boxed, key=lambda f: abs(f[0] - t)) if boxed else None  # a frame with a box, if one is near
        picks.append(near if near is not None and abs(near[0] - t) < 0.5 and near not in picks
                     else chosen[round(i)])
    tiles = []
    for t, jpeg in picks:
        bgr = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        truth = encounter.face_boxes.get(t)
        label = "no target"
        if len(box_times):
            k = int(np.argmin(np.abs(box_times - t)))
            if abs(box_times[k] - t) < 0.02:
                box = observer.boxes[k][1]
                if box is not None:
                    cv2.rectangle(bgr, (int(box[0]), int(box[1])), (int(box[2]), int(box[3])), (0, 220, 0), 3)
                    label = "tracked" + (f", IoU {iou(box, truth):.2f}" if truth is not None else "")
                else:
                    label = "target lost"
            elif abs(box_times[k] - t) < 0.5:  # track skipped this frame (it skips frames that queued on a load)
                label = "no box for this frame"
        if truth is not None:  # drawn over the tracked box, so that both show
            cv2.rectangle(bgr, (int(truth[0]), int(truth[1])), (int(truth[2]), int(truth[3])), (255, 255, 255), 1)
        cv2.putText(bgr, f"{t:.1f} s  {label}", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (0, 0, 0), 4)
        cv2.putText(bgr, f"{t:.1f} s  {label}", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (255, 255, 255), 2)
        tiles.append(cv2.resize(bgr, (320, 240), interpolation=cv2.INTER_AREA))
    while len(tiles) % 4:
        tiles.append(np.full_like(tiles[0], 255))
    rows = [np.hstack(tiles[i:i + 4]) for i in range(0, len(tiles), 4)]
    cv2.imwrite(str(out_path), np.vstack(rows))
    return True


def finish(observer: VisionObserver, result, goals, goals_sent, out: Path, duration: float, title: str) -> dict:
    """Score the run, write encounter.png, camera_strip.png and vision_record.json (what the scorer heard, to score
    it again: rescore) in `out`; returns the metrics to add."""
    (out / "vision_record.json").write_text(json.dumps(observer.to_record()))
    encounter = score(observer, result.spec.world, goals_sent, duration)
    write_encounter(encounter, observer, result, goals, out / "encounter.png", title)
    write_strip(encounter, observer, out / "camera_strip.png")
    return encounter.metrics
