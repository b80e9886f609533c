"""Offline mapping from a bag, as fast as the CPU allows: `subsumption map --bag FILE.bag [--scan T] [--odom T]`.

The bag's messages go, in recorded order, through the same pieces the live node uses (:class:`ScanOdometrySync`
pairs each scan with the odometry of its instant, :class:`navigation.slam.SlamFeed` turns it into beams and feeds
:class:`navigation.slam_core.GraphSlam`), so ``rosbag play --clock`` into ``rosrun subsumption slam`` gives the
same map when no message is dropped. Written into the output folder, each file by a rename once complete (an error
leaves nothing half written):

* ``map.yaml`` / ``map.pgm``: the map, as map_saver writes it;
* ``trajectory.txt``: the optimised keyframes in TUM format (``stamp x y z qx qy qz qw``);
* ``map.png``: the map with the trajectory; when the bag has ``/ground_truth``, beside it the reference map and
  the reference's walls coloured by how far the built map's are from them, aligned (where the map is off);
* ``reference.yaml`` / ``reference.pgm`` (bags with ``/ground_truth``): the map the reference poses draw;
* ``metrics.json``: ``scans``, ``keyframes``, ``loop_closures_tried`` / ``_accepted`` / ``_rejected``,
  ``cpu_time_s``, ``wall_time_s``, ``duration_s`` (the log's), ``real_time_factor`` (log seconds per wall second),
  ``cpu_real_time_factor`` (per CPU second),
  ``walls_half_against_half`` (how well the keyframes' scans agree with each other at the optimised poses:
  :func:`navigation.real_metrics.half_against_half`, no reference needed) and, with ``/ground_truth``, the scores of
  :mod:`navigation.real_metrics` and ``walls_half_against_half_reference`` (the same at the reference's poses).
"""
from __future__ import annotations

import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from subsumption.mapfile import OCCUPIED, OccupancyMap, save_map
from subsumption.metricsfile import write_metrics
from subsumption.planar import transform_points

from .bag_read import BagContents, BagError, inspect, messages, truth_track, usable
from .map_picture import draw_map
from .real_metrics import (at_stamps, ate_aligned, ate_moved, half_against_half, reference_map, rpe, start_alignment,
                           wall_gaps, walls_within)
from .scan_geometry import beams_of
from .scan_sync import ODOM_HISTORY, ScanOdometrySync
from .slam import SCANS_WAITING, SlamFeed
from .slam_core import SlamParams


@dataclass
class BagMapRun:
    contents: BagContents
    feed: SlamFeed
    scans: int = 0
    scans_unusable: int = 0
    scans_without_odometry: int = 0
    scans_without_mount: int = 0
    frames_without_mount: set[str] = field(default_factory=set)  # "frame in base": what /tf_static does not place
    cpu_time_s: float = 0.0
    wall_time_s: float = 0.0
    truth: list[tuple[float, np.ndarray]] = field(default_factory=list)
    # (stamp, odometry pose, scan) of every scan, kept only when there is a reference to score against
    paired: list[tuple[float, np.ndarray, object]] = field(default_factory=list)


def map_bag(path: str | Path, scan_topic: str = "/scan", odom_topic: str | None = None,
            params: dict | None = None) -> BagMapRun:
    """Build the map of a bag (see the module's doc); BagError for what cannot be used."""
    contents = inspect(path, scan_topic, odom_topic)
    slam_params = SlamParams.from_mapping(params or {})
    feed = SlamFeed(slam_params, float((params or {}).get("maxUrange", 0.0)), (params or {}).get("initial_pose"))
    run = BagMapRun(contents, feed, truth=truth_track(contents))  # read apart: scoring is not the mapping's time
    keep = bool(run.truth)

    def process(scan, odom: np.ndarray) -> None:
        mount = contents.mounts.mount(sync.frames[1], scan.header.frame_id)  # in the base frame odometry names
        if mount is None:
            run.scans_without_mount += 1
            run.frames_without_mount.add(f"{scan.header.frame_id} in {sync.frames[1]}")
            return
        if not usable(scan):
            run.scans_unusable += 1
            return
        feed.process(scan, odom, mount)
        if keep:
            run.paired.append((scan.header.stamp.to_sec(), odom, beams_of(scan, mount, _urange(feed))))

    def missing(scan) -> None:
        run.scans_without_odometry += 1

    sync = ScanOdometrySync(process, missing, ODOM_HISTORY, SCANS_WAITING)
    started, cpu = time.monotonic(), time.process_time()  # wall clock meant: how fast the CPU maps the log
    for kind, msg in messages(contents):
        if kind == "scan":
            run.scans += 1
            sync.on_scan(msg)
        else:
            sync.on_odom(msg)
    if feed.core is None:
        why = (f"{run.scans_unusable} had no usable range (NaN, inf or zero everywhere)" if run.scans_unusable else
               f"{run.scans_without_odometry} had no odometry at their stamps" if run.scans_without_odometry else
               f"{run.scans_without_mount} had a frame with no mount on /tf_static: "
               f"{', '.join(sorted(run.frames_without_mount))}")
        raise BagError(f"{contents.path}: no scan on {scan_topic} could be used ({run.scans} scans: {why})")
    feed.core.occupancy()  # the map drawn now, at the end of the bag, and counted in the mapping's time
    run.cpu_time_s = time.process_time() - cpu
    run.wall_time_s = time.monotonic() - started
    return run


def _urange(feed: SlamFeed) -> float:
    return feed.max_urange if feed.max_urange > 0 else math.inf


def metrics(run: BagMapRun, built: OccupancyMap) -> tuple[dict, OccupancyMap | None, np.ndarray | None]:
    """The run's metrics.json figures: scans, keyframes, loop closures tried/accepted/rejected, CPU time and real-time
    factor, and against /ground_truth (when the bag has it) ATE, RPE and walls right; also the reference map drawn
    from the true poses and the rigid motion (x, y, yaw) that aligns the built trajectory with them (None, None
    without them)."""
    core = run.feed.core
    stats = core.stats
    duration = run.contents.end - run.contents.start
    m = {
        "bag": str(run.contents.path),
        "scan_topic": run.contents.scan_topic,
        "odom_topic": run.contents.odom_topic or "/tf",
        "scans": run.scans,
        "scans_unusable": run.scans_unusable,
        "scans_without_odometry": run.scans_without_odometry,
        "keyframes": stats.keyframes,
        "loop_closures_tried": stats.loop_attempts,
        "loop_closures_accepted": stats.loop_closures,
        "loop_closures_rejected": stats.loop_attempts - stats.loop_closures,
        "cpu_time_s": round(run.cpu_time_s, 3),
        "wall_time_s": round(run.wall_time_s, 3),
        "duration_s": round(duration, 3),
        "real_time_factor": round(duration / run.wall_time_s, 2) if run.wall_time_s > 0 else None,
        # the same against CPU time: what one core does when it is not shared
        "cpu_real_time_factor": round(duration / run.cpu_time_s, 2) if run.cpu_time_s > 0 else None,
        # no reference needed: how well the keyframes' scans agree with each other where the mapper put them
        "walls_half_against_half": _rounded(half_against_half([(k.pose, k.beams) for k in core.keyframes],
                                                              built.resolution, core.params.occ_thresh)),
    }
    reference = motion = None
    if run.truth:
        ref_stamps = np.array([t for t, _ in run.truth])
        ref_poses = np.array([p for _, p in run.truth])
        stamps, poses = core.trajectory()
        ok, ref = at_stamps(stamps, ref_stamps, ref_poses)
        odom_stamps = np.array([t for t, _, _ in run.paired])
        odom = np.array([o for _, o, _ in run.paired]).reshape(-1, 3)
        ok_o, ref_o = at_stamps(odom_stamps, ref_stamps, ref_poses)
        drawn = [(ref_o[i], run.paired[i][2]) for i in np.flatnonzero(ok_o)]
        reference = reference_map(drawn, built.resolution, core.params.occ_thresh)
        trans, rot = rpe(poses[ok], ref[ok])
        aligned, motion = ate_aligned(poses[ok], ref[ok])
        start = start_alignment(poses[ok], ref[ok])  # "as it is": in the frame both start in
        m.update({
            "ate_m": round(ate_moved(poses[ok], ref[ok], start), 4),
            "odometry_ate_m": round(ate_moved(odom[ok_o], ref_o[ok_o], start_alignment(odom[ok_o], ref_o[ok_o])), 4),
            "rpe_trans_m": round(trans, 4),
            "rpe_rot_deg": round(rot, 3),
            "walls_within_0p1m": round(walls_within(built, reference, 0.1, start), 4),
            "keyframes_scored": int(ok.sum()),
            "ate_aligned_m": round(aligned, 4),
            "walls_within_0p1m_aligned": round(walls_within(built, reference, 0.1, motion), 4),
            "alignment_deg": round(math.degrees(float(motion[2])), 3),
            # the same keyframes' scans at the reference's poses: how well the reference agrees with them
            "walls_half_against_half_reference": _rounded(half_against_half(
                [(ref[i], core.keyframes[i].beams) for i in np.flatnonzero(ok)], built.resolution,
                core.params.occ_thresh)),
        })
    return m, reference, motion


def _rounded(share: float) -> float | None:
    """A share for metrics.json: 4 decimals, None for NaN (JSON has no NaN)."""
    return None if math.isnan(share) else round(share, 4)


def trajectory_tum(stamps: np.ndarray, poses: np.ndarray) -> str:
    """Poses (x, y, yaw) at their stamps as TUM trajectory lines: `stamp x y z qx qy qz qw`, planar (z = 0, rotation
    about z)."""
    lines = [f"{t:.6f} {p[0]:.6f} {p[1]:.6f} 0 0 0 {math.sin(p[2] / 2):.9f} {math.cos(p[2] / 2):.9f}"
             for t, p in zip(stamps, poses)]
    return "\n".join(lines) + "\n"


WALL_GAP_COLOURS = ((0.1, (0.0, 0.0, 0.0)), (0.3, (1.0, 0.55, 0.0)), (math.inf, (0.85, 0.0, 0.0)))  # up to m: RGB


def picture(run: BagMapRun, built: OccupancyMap, reference: OccupancyMap | None, motion: np.ndarray | None,
            path: Path, title: str) -> None:
    """Draw the built map with the optimised trajectory into `path`; with a reference, beside it the reference map
    and its walls coloured by how far the built map's walls are from them once the built trajectory is aligned
    (`motion`): black within 0.1 m (what the walls score counts), orange to 0.3 m, red beyond."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("built", built, "built map, optimised keyframes")]
    if reference is not None:
        panels += [("reference", reference, "reference: the scans at /ground_truth's poses"),
                   ("gaps", reference, "reference walls by the aligned map's: within 0.1 m black, 0.3 m orange, "
                                       "beyond red")]
    fig, axes = plt.subplots(1, len(panels), figsize=(8 * len(panels), 8), squeeze=False)
    _, poses = run.feed.core.trajectory()
    ref = np.array([p for _, p in run.truth]).reshape(-1, 3)
    for ax, (kind, grid, name) in zip(axes[0], panels):
        draw_map(ax, grid, _gap_image(built, grid, motion) if kind == "gaps" else None)
        if kind != "built" and len(ref):
            ax.plot(ref[:, 0], ref[:, 1], "-", color="tab:green", lw=0.6)
        if len(poses) and (kind == "built" or kind == "gaps" and motion is not None):
            drawn = poses[:, :2] if kind == "built" else transform_points(motion, poses[:, :2])
            ax.plot(drawn[:, 0], drawn[:, 1], "-", color="tab:blue", lw=0.6)
        ax.set_title(name)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1, 0.96))  # room for the title above the panels' own
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _gap_image(built: OccupancyMap, reference: OccupancyMap, motion: np.ndarray | None) -> np.ndarray:
    """An RGB image of the reference grid: white, its walls in WALL_GAP_COLOURS by their distance to the built map's
    walls (moved by `motion`), each wall cell drawn a cell wider on every side (a building's one-cell walls vanish
    at a page's scale), the larger distances on top."""
    from scipy.ndimage import binary_dilation

    image = np.ones(reference.shape + (3,))
    rows, cols = np.nonzero(reference.occupancy == OCCUPIED)  # the order of wall_gaps' answer
    gaps = wall_gaps(built, reference, motion)
    lower = -math.inf
    for upper, colour in WALL_GAP_COLOURS:
        band = (gaps > lower + 1e-6) & (gaps <= upper + 1e-6)
        mask = np.zeros(reference.shape, bool)
        mask[rows[band], cols[band]] = True
        image[binary_dilation(mask)] = colour
        lower = upper
    return image


def write_outputs(run: BagMapRun, out: Path, extra: dict | None = None) -> dict:
    """Every output into `out`, each file complete before it takes its name."""
    built = run.feed.core.occupancy()  # as drawn at the end of map_bag: nothing moved since
    m, reference, motion = metrics(run, built)
    m.update(extra or {})
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".map_bag.", dir=out))
    try:
        save_map(built, stage / "map.yaml")
        stamps, poses = run.feed.core.trajectory()
        (stage / "trajectory.txt").write_text(trajectory_tum(stamps, poses))
        score = (f": ATE {m['ate_m']:.3f} m, aligned {m['ate_aligned_m']:.3f} m "
                 f"(odometry {m['odometry_ate_m']:.2f} m), walls within 0.1 m {m['walls_within_0p1m']:.1%}, "
                 f"aligned {m['walls_within_0p1m_aligned']:.1%}" if "ate_m" in m else "")
        picture(run, built, reference, motion, stage / "map.png", f"{run.contents.path.name}{score}")
        write_metrics(stage, m)
        names = ["map.pgm", "map.yaml", "trajectory.txt", "map.png", "metrics.json"]
        if reference is not None:  # the map the corrected poses draw: for localization along the log
            save_map(reference, stage / "reference.yaml")
            names[:0] = ["reference.pgm", "reference.yaml"]
        for name in names:
            os.replace(stage / name, out / name)
    finally:
        for leftover in stage.iterdir():
            leftover.unlink()
        stage.rmdir()
    return m


def cli_map_bag(bag: Path, out: Path, scan_topic: str, odom_topic: str | None, params: dict) -> int:
    """The `subsumption map --bag` command: prints one line, exit 0; a BagError's line and exit 2."""
    import sys

    try:
        run = map_bag(bag, scan_topic, odom_topic, params)
        m = write_outputs(run, out)
    except BagError as error:
        print(f"subsumption map: {error}", file=sys.stderr)
        return 2
    score = (f", ATE {m['ate_m']:.3f} m, aligned {m['ate_aligned_m']:.3f} m (odometry alone {m['odometry_ate_m']:.2f} "
             f"m), walls within 0.1 m {m['walls_within_0p1m']:.1%}, aligned {m['walls_within_0p1m_aligned']:.1%}"
             if "ate_m" in m else "")
    print(f"{out}/metrics.json: {m['scans']} scans, {m['keyframes']} keyframes, loop closures "
          f"{m['loop_closures_accepted']}/{m['loop_closures_tried']}, {m['duration_s']:.0f} s of log in "
          f"{m['wall_time_s']:.1f} s ({m['real_time_factor']}x){score}")
    return 0
