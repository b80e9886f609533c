"""Record a mapping run's SLAM input once, replay it through the SLAM core many times (for measuring changes).

The wander driver never reads SLAM's output, so what SLAM gets in a run (each scan as beams in the robot frame,
paired with the odometry pose at its stamp, exactly as :class:`navigation.slam.Slam` pairs them) depends only on
the world, the sensor and the seed. Recording it once and feeding it to :class:`navigation.slam_core.GraphSlam`
gives the same keyframes, map and ``ate_m`` as a live ``subsumption map`` run in a fraction of the time: the
simulator and the wander robot do not run again.

    .venv/bin/python -m experiments.mapping_replay record --world W --sensor depth --duration 300 --seed 1 --out R.pkl
    .venv/bin/python -m experiments.mapping_replay record --patrol pingpong --seed 1 --out R.pkl   # as built_map
    .venv/bin/python -m experiments.mapping_replay replay R.pkl [R2.pkl ...] [--param NAME=VALUE ...] [--picture D]

``replay`` prints ``ate_m``, ``ate_yaw_deg``, the map scores of :mod:`experiments.mapping_metrics`, and the
loop-closure counts; the truth scores only, as in a live run. ``ate_online_m`` is not reproduced (it needs
every odometry message); the rest is.
"""
from __future__ import annotations

import argparse
import math
import pickle
import sys
import time
from dataclasses import dataclass, field, fields
from pathlib import Path

import matplotlib
import numpy as np
import yaml
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import UInt32

from navigation.scan_geometry import Beams, MountListener, beams_of
from navigation.scan_sync import ScanOdometrySync
from navigation.slam_core import GraphSlam, SlamParams
from subsim import world_path
from subsim.mapio import load_map
from subsumption.planar import between, compose, from_pose_msg, wrap

from .launch_local import launch_local
from .mapping import MappingResult, draw, prepare_world, run_local, wander_driver
from .mapping_metrics import map_quality, seen_cells, trajectory_error
from .patrol import map_building_world
from .patrol_map import EXPLORE_BOUND, explore_world
from .runner import map_of

matplotlib.use("Agg")  # headless: figures are files, on CI and over ssh alike
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)


@dataclass
class Recording:
    """SLAM's input in one run and the truth to score it by."""

    world: str  # the prepared world file (its map is the truth)
    initial_pose: list  # Slam's initial_pose parameter (the world's start pose)
    inputs: list[tuple[float, np.ndarray, Beams]] = field(default_factory=list)  # (stamp, odometry pose, beams)
    truth: dict[float, np.ndarray] = field(default_factory=dict)  # true pose by stamp rounded to 1 ms
    scans: list[tuple[float, Beams]] = field(default_factory=list)  # every scan (for the seen cells)
    collisions: int = 0
    sim_time: float = 0.0
    live: np.ndarray | None = None  # (n, 4) stamp, x, y, yaw of the run's own SLAM keyframes (frontier runs)


class _Unpickler(pickle.Unpickler):
    """Reads recordings pickled when this module ran as ``__main__``."""

    def find_class(self, module: str, name: str):
        if module == "__main__" and name == "Recording":
            return Recording
        return super().find_class(module, name)


def load(path: Path) -> Recording:
    """A recording written by ``record``."""
    with open(path, "rb") as f:
        data = _Unpickler(f).load()
    return Recording(**data) if isinstance(data, dict) else data


def save(rec: Recording, path: Path) -> None:
    path.write_bytes(pickle.dumps(vars(rec)))


def record(world: Path, start: list, duration: float, seed: int, frontier: bool = False) -> Recording:
    """Run the simulator with the wander robot driving (no SLAM: nothing reads it) and keep SLAM's input. With
    `frontier`, frontier exploration drives instead, as for the patrol's own map (experiments.patrol_map), with
    SLAM in the loop (the explorer reads its map): a replay with other parameters then scores SLAM on the same
    input, though that run's own exploration might have gone elsewhere."""
    rec = Recording(str(world), [float(v) for v in start])

    def setup(runtime) -> None:
        node = runtime.node("replay_recorder")
        mounts = MountListener(node)

        def on_pair(scan: LaserScan, odom: np.ndarray) -> None:
            mount = mounts.mount(sync.frames[1], scan.header.frame_id)
            if mount is not None:  # as Slam._process, with maxUrange 0 (the sensor's range)
                rec.inputs.append((scan.header.stamp.to_sec(), odom.copy(), beams_of(scan, mount, math.inf)))

        def on_scan(msg: LaserScan) -> None:
            mount = mounts.mount("base_link", msg.header.frame_id)
            if mount is not None:
                rec.scans.append((msg.header.stamp.to_sec(), beams_of(msg, mount)))
            sync.on_scan(msg)

        def on_truth(msg: Odometry) -> None:
            t = msg.header.stamp.to_sec()
            rec.truth[round(t, 3)] = from_pose_msg(msg.pose.pose)
            rec.sim_time = max(rec.sim_time, t)

        sync = ScanOdometrySync(on_pair)
        node.subscribe("/odom", Odometry, sync.on_odom)
        node.subscribe("/scan", LaserScan, on_scan)
        node.subscribe("/ground_truth", Odometry, on_truth)
        node.subscribe("/collisions", UInt32, lambda m: setattr(rec, "collisions", max(rec.collisions, m.data)))

    if frontier:  # the patrol's own map's run (experiments.mapping.run_local), this recorder beside its own
        _, _, slam = run_local(world, start, duration, seed, "frontier", also=setup)
        rec.live = np.zeros((0, 4)) if slam.core is None else np.column_stack(slam.core.trajectory())
    else:
        launch_local(world, [wander_driver(seed)], duration, seed, {"map_to_odom": False, "publish_map": False},
                     setup=setup)
    return rec


def replay(rec: Recording, params: dict | None = None) -> tuple[dict, object, dict[float, np.ndarray]]:
    """Feed a recording to a fresh GraphSlam; (metrics as a live run scores them, the GraphSlam, each keyframe's
    pose as tracking put it when it was added, by stamp: before later loop closures moved it)."""
    core = None
    tracked: dict[float, np.ndarray] = {}
    cpu = time.process_time()
    for stamp, odom, beams in rec.inputs:
        if core is None:
            origin = np.asarray(rec.initial_pose, dtype=float) if len(rec.initial_pose) == 3 else np.zeros(3)
            core = GraphSlam(SlamParams.from_mapping(params or {}), compose(origin, odom))
        if core.add_scan(stamp, odom, beams):
            tracked[stamp] = core.keyframes[-1].pose.copy()
    cpu = time.process_time() - cpu
    stamps, poses = core.trajectory()
    ate, ate_yaw, compared = trajectory_error(stamps, poses, rec.truth)
    truth_map = load_map(map_of(Path(rec.world)))
    scans = [(rec.truth[round(t, 3)], b) for t, b in rec.scans if round(t, 3) in rec.truth]
    quality = map_quality(core.occupancy(), truth_map, *seen_cells(truth_map, scans))
    s = core.stats
    live = {}
    if rec.live is not None:  # the run's own SLAM: how far the replay's keyframes are from it (0: the same run)
        same = len(rec.live) == len(stamps) and np.allclose(rec.live[:, 0], stamps)
        live = {"live_keyframes": len(rec.live),
                "live_max_m": round(float(np.hypot(*(rec.live[:, 1:3] - poses[:, :2]).T).max()), 6)
                if same and len(stamps) else None}
    return {"ate_m": round(ate, 4), "ate_yaw_deg": round(ate_yaw, 3), "keyframes": compared, **quality,
            "loop_candidates": s.loop_candidates, "loop_closures": s.loop_closures,
            "slam_cpu_s": round(cpu, 2), "collisions": rec.collisions, "sim_time_s": round(rec.sim_time, 1), **live}, \
        core, \
        tracked


def _odometry_in_map(rec: Recording) -> dict[float, np.ndarray]:
    """Odometry's pose at each scan's stamp, placed at the start pose as SLAM's map is."""
    origin = np.asarray(rec.initial_pose, dtype=float) if len(rec.initial_pose) == 3 else np.zeros(3)
    return {stamp: compose(origin, odom) for stamp, odom, _ in rec.inputs}


def step_errors(rec: Recording, core) -> dict:
    """RMS error of the motion from one keyframe to the next, SLAM's final trajectory and odometry's against the
    truth: whether scan matching beats odometry step by step (a drift that sums up is another matter)."""
    odometry = _odometry_in_map(rec)
    keyframes = [k for k in core.keyframes if round(k.stamp, 3) in rec.truth]
    slam, odom = [], []
    for a, b in zip(keyframes, keyframes[1:]):
        true = between(rec.truth[round(a.stamp, 3)], rec.truth[round(b.stamp, 3)])
        for errors, moved in ((slam, between(a.pose, b.pose)), (odom, between(odometry[a.stamp], odometry[b.stamp]))):
            errors.append((math.hypot(*(moved[:2] - true[:2])), float(wrap(moved[2] - true[2]))))
    rms = {name: np.sqrt(np.mean(np.square(np.array(e)), axis=0)) for name, e in (("slam", slam), ("odometry", odom))}
    return {f"step_{what}_{name}": round(float(scale * rms[name][i]), 4) for name in rms
            for i, (what, scale) in enumerate((("mm", 1000.0), ("yaw_deg", math.degrees(1.0))))}


def drift_figure(rec: Recording, core, tracked: dict[float, np.ndarray], path: Path, title: str) -> Path:
    """Heading and sideways (y) error over time: SLAM's final trajectory, SLAM as tracked, odometry alone."""
    odometry = _odometry_in_map(rec)
    stamps = [k.stamp for k in core.keyframes if round(k.stamp, 3) in rec.truth]
    truth = np.array([rec.truth[round(t, 3)] for t in stamps])
    fig, axes = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True)
    for label, poses in (("SLAM, final", [k.pose for k in core.keyframes if round(k.stamp, 3) in rec.truth]),
                         ("SLAM, when tracked", [tracked[t] for t in stamps]),
                         ("odometry alone", [odometry[t] for t in stamps])):
        error = np.array(poses) - truth
        axes[0].plot(stamps, np.degrees(wrap(error[:, 2])), label=label, lw=0.9)
        axes[1].plot(stamps, 100 * error[:, 1], label=label, lw=0.9)
    axes[0].set_ylabel("heading error (deg)")
    axes[1].set_ylabel("y error (cm)")
    axes[1].set_xlabel("simulated s")
    axes[0].legend(loc="lower left")
    for ax in axes:
        ax.grid(alpha=0.4)
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def picture(rec: Recording, core, out_dir: Path, title: str) -> Path:
    """map_vs_truth.png of a replay, as a live run draws it."""
    truth_map = load_map(map_of(Path(rec.world)))
    true_xy = np.array([rec.truth[k][:2] for k in sorted(rec.truth)]).reshape(-1, 2)
    _, poses = core.trajectory()
    out_dir.mkdir(parents=True, exist_ok=True)
    return draw(MappingResult({}, core.occupancy(), truth_map, poses[:, :2], true_xy), out_dir / "map_vs_truth.png",
                title)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("record", help="run the world once and keep SLAM's input")
    where = r.add_mutually_exclusive_group(required=True)
    where.add_argument("--world", type=Path, help="a simulator world file")
    where.add_argument("--patrol", help="a shipped world mapped as experiments.patrol.built_map does (240 s)")
    where.add_argument("--explore", type=Path, help="a world file explored for the patrol's own map, as "
                                                    "experiments.patrol_map.explored_map does (frontier "
                                                    "exploration, at most 900 s)")
    r.add_argument("--sensor", choices=("laser", "depth"), default="depth")
    r.add_argument("--duration", type=float, default=None, help="simulated s (default 300; 240 with --patrol)")
    r.add_argument("--seed", type=int, default=1)
    r.add_argument("--out", type=Path, required=True, help="the recording (a pickle)")
    p = sub.add_parser("replay", help="feed recordings to the SLAM core and score the result")
    p.add_argument("recordings", type=Path, nargs="+")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="a SlamParams field")
    p.add_argument("--picture", type=Path, help="write DIR/<recording>/map_vs_truth.png")
    p.add_argument("--steps", action="store_true",
                   help="also print the RMS keyframe-to-keyframe motion error of SLAM and of odometry")
    p.add_argument("--drift", type=Path, help="write DIR/<recording>/drift.png: heading and y error over time")
    args = parser.parse_args(argv)
    if args.command == "record":
        folder = args.out.with_suffix("")
        if args.patrol:
            world, start = map_building_world(world_path(args.patrol), folder)
            duration = args.duration or 240.0
        elif args.explore:
            world, start = explore_world(args.explore, folder)
            duration = args.duration or EXPLORE_BOUND
        else:
            world, start = prepare_world(args.world, folder, args.sensor, 0.02)
            duration = args.duration or 300.0
        rec = record(world, start, duration, args.seed, frontier=args.explore is not None)
        save(rec, args.out)
        print(f"{args.out}: {len(rec.inputs)} scans, {rec.sim_time:.0f} s, {rec.collisions} collisions")
        return 0

    known = sorted(f.name for f in fields(SlamParams))
    params = {}
    for item in args.param:
        name, sep, value = item.partition("=")
        if not sep or name not in known:
            parser.error(f"--param {item!r}: expected NAME=VALUE with NAME one of {', '.join(known)}")
        params[name] = yaml.safe_load(value)
    for path in args.recordings:
        rec = load(path)
        metrics, core, tracked = replay(rec, params)
        if args.steps:
            metrics.update(step_errors(rec, core))
        print(f"{path.stem}: " + ", ".join(f"{k} {v}" for k, v in metrics.items()), flush=True)
        if args.drift:
            drift_figure(rec, core, tracked, args.drift / path.stem / "drift.png",
                         f"{path.stem}: ATE {metrics['ate_m'] * 100:.1f} cm, walls {metrics['walls_within_cell']:.1%}")
        if args.picture:
            picture(rec, core, args.picture / path.stem, f"{path.stem} (replay {params or 'defaults'}): ATE "
                    f"{metrics['ate_m'] * 100:.1f} cm, walls {metrics['walls_within_cell']:.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
