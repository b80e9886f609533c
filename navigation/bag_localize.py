"""Localization along a recorded bag on a known map, offline: amcl's filter (:mod:`navigation.amcl_core`, the one
the live ``amcl`` node runs) fed the bag's scans and odometry in recorded order, as the node's ``_process`` does
(an update after ``update_min_d`` / ``update_min_a`` of motion, the scan's beams thinned to ``laser_max_beams``).

Start: ``initial`` (x, y, yaw) with amcl's default spread (0.5 m, 15 degrees), or the whole free space
(``global_localization``), the filter then also restarted round the pose a whole-map search of the recent scans
finds unambiguous (:mod:`navigation.global_search`; ``global_search=False``: the filter alone, as amcl). Scored,
when the bag has ``/ground_truth``, at every filter update: ``rms_m`` and ``worst_m`` of the estimate's distance
from the reference (after ``settle`` updates: a start within 0.5 m is still a start), ``final_error_m``, and for a
global start ``found_after_updates`` (the first update from which the error stays below 0.5 m).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from subsumption.mapfile import OccupancyMap, read_map_file
from subsumption.planar import between

from .amcl_core import AmclParams, LikelihoodField, ParticleFilter
from .bag_read import BagError, inspect, messages, truth_track
from .real_metrics import at_stamps, ate_aligned
from .scan_geometry import beams_of
from .global_search import START_COVARIANCE, Found, GlobalSearch
from .map_picture import draw_map, walls_extent
from .scan_sync import ScanOdometrySync

FOUND_WITHIN = 0.5  # m: a global localization has found the pose once its error stays below this


@dataclass
class LocalizeRun:
    stamps: list[float] = field(default_factory=list)
    poses: list[np.ndarray] = field(default_factory=list)
    truth: list[tuple[float, np.ndarray]] = field(default_factory=list)
    cpu_time_s: float = 0.0
    wall_time_s: float = 0.0
    duration_s: float = 0.0
    found: Found | None = None  # a global start: where the whole-map search put the robot, and when
    search_attempts: int = 0
    start: np.ndarray | None = None  # the pose the filter was started round (None: a global start)


def truth_at(truth: list[tuple[float, np.ndarray]], stamp: float) -> np.ndarray | None:
    """The /ground_truth pose nearest `stamp` in time (None without any): where the filter starts when no start
    pose is given, whichever of the two topics the bag recorded first."""
    if not truth:
        return None
    _, poses = at_stamps(np.array([stamp]), np.array([t for t, _ in truth]), np.array([p for _, p in truth]), math.inf)
    return poses[0]


def localize_bag(bag: str | Path, map_yaml: str | Path, initial: np.ndarray | None, global_start: bool = False,
                 scan_topic: str = "/scan", odom_topic: str | None = None, params: dict | None = None,
                 seed: int = 0, global_search: bool = True) -> LocalizeRun:
    """Run amcl's filter along a bag's scans and odometry on a map_server map, offline, as fast as the CPU allows;
    from `initial` (x, y, yaw) or, with `global_start`, from particles spread over the map's free space and (with
    `global_search`) restarted round the pose the whole-map search finds."""
    contents = inspect(bag, scan_topic, odom_topic)
    try:
        grid = read_map_file(map_yaml)
    except Exception as error:  # MapError names the file and field; anything else is a file that is not a map
        raise BagError(str(error)) from None
    p = AmclParams.from_mapping(params or {})
    pf = ParticleFilter(LikelihoodField(grid, p.laser_likelihood_max_dist), p, seed=seed)
    run = LocalizeRun(duration_s=contents.end - contents.start)
    searcher = GlobalSearch(grid) if global_start and global_search else None
    state = {"last": None, "started": False}
    run.truth = truth_track(contents)

    def process(scan, odom: np.ndarray) -> None:
        mount = contents.mounts.mount(sync.frames[1], scan.header.frame_id)  # in the base frame odometry names
        if mount is None:
            raise BagError(f"{contents.path}: {contents.scan_topic}: frame {scan.header.frame_id} has no mount in "
                           f"{sync.frames[1]} on /tf_static")
        if not state["started"]:
            if global_start:
                pf.spread_globally()
            else:
                start = initial if initial is not None else truth_at(run.truth, scan.header.stamp.to_sec())
                if start is None:
                    raise BagError(f"{contents.path}: no start pose: give --initial-pose X Y YAW or --global "
                                   f"(the bag has no /ground_truth to start from)")
                run.start = np.asarray(start, float)
                pf.set_pose(run.start, np.diag([0.25, 0.25, (math.pi / 12) ** 2]))
            state["started"] = True
        elif state["last"] is not None:
            step = between(state["last"], odom)
            if math.hypot(step[0], step[1]) < p.update_min_d and abs(step[2]) < p.update_min_a:
                return
            pf.predict(state["last"], odom)
        state["last"] = odom
        max_range = p.laser_max_range if p.laser_max_range > 0 else math.inf
        all_beams = beams_of(scan, mount, max_range)
        beams = all_beams.subsample(p.laser_max_beams)
        pf.correct(beams.endpoints(), min(scan.range_max, max_range), beams.hit, beams.origin)
        if searcher is not None and run.found is None:
            run.found = searcher.add(scan.header.stamp.to_sec(), odom, all_beams.hits())
            run.search_attempts = searcher.attempts
            if run.found is not None:  # the filter from here on, as after a start pose given by hand
                pf.set_pose(run.found.pose, START_COVARIANCE)
        run.stamps.append(scan.header.stamp.to_sec())
        run.poses.append(pf.estimate().pose.copy())

    sync = ScanOdometrySync(process)
    started, cpu = time.monotonic(), time.process_time()  # wall clock meant: how fast the CPU goes through the log
    for kind, msg in messages(contents):
        if kind == "scan":
            sync.on_scan(msg)
        else:
            sync.on_odom(msg)
    run.cpu_time_s = time.process_time() - cpu
    run.wall_time_s = time.monotonic() - started
    return run


def scores(run: LocalizeRun, settle: int = 5) -> dict:
    """The run's metrics.json figures: updates, CPU and wall time, real-time factor, and against /ground_truth (when
    the bag has it) RMS, worst and final error, skipping the first `settle` updates; and the RMS after the rigid
    motion that best fits the estimates onto /ground_truth (``rms_aligned_m``: what to read on a map whose frame is
    not /ground_truth's, as a map built from the same bag is not)."""
    m = {"updates": len(run.poses), "cpu_time_s": round(run.cpu_time_s, 3), "wall_time_s": round(run.wall_time_s, 3),
         "duration_s": round(run.duration_s, 3),
         "real_time_factor": round(run.duration_s / run.wall_time_s, 2) if run.wall_time_s > 0 else None}
    if not run.truth or not run.poses:
        return m
    ref_stamps = np.array([t for t, _ in run.truth])
    ref_poses = np.array([p for _, p in run.truth])
    ok, ref = at_stamps(np.array(run.stamps), ref_stamps, ref_poses)
    poses = np.array(run.poses)
    errors = np.where(ok, np.hypot(poses[:, 0] - ref[:, 0], poses[:, 1] - ref[:, 1]), np.nan)
    scored = errors[settle:][np.isfinite(errors[settle:])]
    found = next((i for i in range(len(errors)) if np.all(errors[i:][np.isfinite(errors[i:])] < FOUND_WITHIN)), None)
    m.update({"rms_m": round(float(np.sqrt(np.mean(scored ** 2))), 4) if len(scored) else None,
              "worst_m": round(float(scored.max()), 4) if len(scored) else None,
              "final_error_m": round(float(errors[-1]), 4) if np.isfinite(errors[-1]) else None,
              "found_after_updates": found})
    kept = np.flatnonzero(ok)
    kept = kept[kept >= settle]
    if len(kept) >= 2:  # a map drawn in another frame than /ground_truth's (one `subsumption map` built): its shape
        m["rms_aligned_m"] = round(ate_aligned(poses[kept], ref[kept])[0], 4)
    if run.found is not None or run.search_attempts:
        m["global_search"] = {"attempts": run.search_attempts,
                              "found_at_s": round(run.found.stamp - run.stamps[0], 3) if run.found else None,
                              "score": round(run.found.score, 3) if run.found else None}
    return m


def picture(run: LocalizeRun, grid: OccupancyMap, path: Path, title: str) -> None:
    """Draw the filter's estimates (blue: a circle where the filter started, a square where it ended, a star where a
    global start's search found the robot) and /ground_truth (green, when the bag has it) over the map into
    `path`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xmin, xmax, ymin, ymax = walls_extent(grid)
    aspect = (ymax - ymin) / max(xmax - xmin, 1e-9)
    fig, ax = plt.subplots(figsize=(10, min(12.0, max(4.0, 10 * aspect + 0.8))))
    draw_map(ax, grid)
    truth = np.array([p for _, p in run.truth]).reshape(-1, 3)
    if len(truth):
        ax.plot(truth[:, 0], truth[:, 1], "-", color="tab:green", lw=0.8, label="/ground_truth")
    poses = np.array(run.poses).reshape(-1, 3)
    if len(poses):
        ax.plot(poses[:, 0], poses[:, 1], "-", color="tab:blue", lw=0.8, label="amcl's estimate")
        ax.plot(poses[0, 0], poses[0, 1], "o", color="tab:blue", ms=8, mfc="none", mew=2)
        ax.plot(poses[-1, 0], poses[-1, 1], "s", color="tab:blue", ms=7)
    if run.found is not None:
        ax.plot(run.found.pose[0], run.found.pose[1], "*", color="tab:red", ms=16, mec="k",
                label="found by the whole-map search")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80, format="png")
    plt.close(fig)
