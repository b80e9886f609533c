"""How far a corrected log's own poses are from agreeing with its own scans: what no mapper can beat.

    .venv/bin/python -m bench.reference_consistency [--logs intel aces csail freiburg-079] [--first 8]
    .venv/bin/python -m bench.reference_consistency --ceiling 0.25 0.5 [--jitter-m 0.01]

A corrected Radish log's poses are the reference that ATE and the wall score compare with, and the reference map
is its scans drawn at those poses. Both are the output of somebody's SLAM, not survey truth. Two questions, each
answered by our point-to-line ICP (:func:`navigation.slam_match.match`, no prior) on the log's own scans:

* **The anchor.** A mapper starts at the log's first pose and builds its map from the scans; so where the first
  scans sit on the reference's map decides how its whole map is turned against the reference's. Each of the
  first ``--first`` keyframes is matched against the map the log draws from its keyframes 30 onwards (the places
  seen again later), starting at its reference pose: the turn and shift it needs. A first pose 1 degree off its
  own map turns a scan-consistent map by 1 degree about the start, and moves a wall 30 m away by 0.5 m: an error
  the unaligned scores charge to the mapper, and the aligned scores (the rigid fit first, as the TUM benchmark's
  ATE and ``evo_ape --align``) do not.
* **Everywhere.** Every 4th keyframe matched against all keyframes but its 15 neighbours either side (within 25 m):
  how far the reference moves to fit its own scans seen from elsewhere (median, 90th and 99th percentile). This is
  the floor of a few cm under any ATE.
* **Step by step.** Every keyframe matched against the ``BEHIND`` keyframes before it, all at their reference
  poses: where the reference jumps between two scans (a turn its own scans do not make), every pose after the
  jump is off by it, against a mapper that follows the scans. Keyframes needing more than ``JUMP_DEG`` are listed
  with their scan number and how much of the log comes after them, and how the turns correlate (:func:`whiteness`).
* **Half against half.** The wall score (:func:`navigation.real_metrics.walls_within`, 0.1 m) of the map the
  reference draws from every other scan against the map it draws from the rest, both at the reference poses and
  as the scorer draws them: how far the reference agrees with itself on the measure issue 28's wall target uses.
  Each half sees less than the whole (a wall seen only by one half counts as missed), so this is no ceiling: the
  logs re-simulated with exact truth score 95.6-99.7% (``--ceiling``'s "exact" rows).
* **A perfect map's ceiling** (``--ceiling DEG [DEG ...]``, on the log re-simulated with exact truth,
  :mod:`bench.resimulate`): how much a reference whose poses are off by white noise (DEG degrees and ``--jitter-m``
  m per pose, independent from scan to scan, as the step-by-step turns are) costs a map drawn at the exact poses on
  the wall score. Each row also gives the step-by-step median and the halves' score of the jittered poses, to set
  beside the real log's: the DEG whose median matches the log's is the jitter its reference behaves like.

Keyframes: the log's scans every 0.5 m or 0.3 rad along the reference (0.3 m / 0.2 rad for the anchor). Why a
bench: it reads whole logs (a minute or two each) and prints figures for docs/real_data.md; nothing in it is
timed.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

from bench.resimulate import resimulated
from navigation.carmen import CarmenScan, read_log
from navigation.carmen_bag import scan_message
from navigation.real_metrics import half_against_half as real_half_against_half
from navigation.real_metrics import reference_map, walls_within
from navigation.scan_geometry import Beams, beams_of
from navigation.slam_core import SlamParams
from navigation.slam_match import Cloud, match, scan_normals
from subsumption.planar import transform_points, wrap

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data" / "carmen"
LOGS = ("intel", "aces", "csail", "freiburg-079", "freiburg-101", "orebro")
NEIGHBOURS = 15   # keyframes either side left out of a keyframe's map in the "everywhere" check
REACH = 25.0      # m: target points farther than this from the keyframe are left out (speed)
BEHIND = 10       # keyframes before it that form a keyframe's map in the step-by-step check
JUMP_DEG = 4.0    # a keyframe that needs more turn than this to fit the keyframes before it is listed
JITTER_SEED = 7   # the white noise of --ceiling's jittered references


def beams(scan: CarmenScan) -> Beams:
    """The scan as the bag carries it (:func:`navigation.carmen_bag.scan_message`) and the mapper reads it
    (:func:`navigation.scan_geometry.beams_of`, the laser's mount applied)."""
    return beams_of(scan_message(scan.stamp, scan), (scan.mount, False))


def robot_points(scan: CarmenScan) -> tuple[np.ndarray, np.ndarray]:
    """The scan's hits that have a normal, and the normals, in the robot frame: the hits as the bag carries them
    (:func:`navigation.carmen_bag.scan_message`) and the mapper reads them (:func:`navigation.scan_geometry.beams_of`,
    the laser's mount applied), the normals as tracking fits them."""
    hits = beams(scan).hits()
    normals = scan_normals(hits, 3, 0.15)
    has = np.all(np.isfinite(normals), axis=1)
    return hits[has], normals[has]


def keyframes(scans: list[CarmenScan], step: float, turn: float) -> list[int]:
    """Indices of the scans every `step` m or `turn` rad along the reference poses."""
    keys = [0]
    for i, scan in enumerate(scans):
        d = scan.pose - scans[keys[-1]].pose
        if math.hypot(d[0], d[1]) > step or abs(wrap(d[2])) > turn:
            keys.append(i)
    return keys


def placed(scans: list[CarmenScan], keys: list[int]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each keyframe's points and normals at its reference pose (map frame)."""
    out = []
    for k in keys:
        points, normals = robot_points(scans[k])
        pose = scans[k].pose
        out.append((transform_points(pose, points), transform_points(np.array([0.0, 0.0, pose[2]]), normals)))
    return out


def fit(scan: CarmenScan, target: Cloud) -> tuple[float, float, float]:
    """(turn deg, shift cm, share of the scan's points on the target's walls) that fit `scan` onto `target` from
    its reference pose."""
    points, normals = robot_points(scan)
    m = match(points, target, scan.pose, max_distance=0.3, final_distance=0.1, normals=normals)
    d = m.pose - scan.pose
    return math.degrees(float(wrap(d[2]))), 100 * math.hypot(d[0], d[1]), m.inliers


def anchor(scans: list[CarmenScan], first: int) -> list[tuple[int, float, float, float]]:
    """(scan index, turn deg, shift cm, inliers) of each of the first `first` keyframes against the map of
    keyframes 30 onwards."""
    keys = keyframes(scans, 0.3, 0.2)
    later = placed(scans, keys[min(30, len(keys) // 2):])  # a short log: its second half
    target = Cloud.of(np.vstack([p for p, _ in later]), np.vstack([n for _, n in later]))
    return [(k, *fit(scans[k], target)) for k in keys[:first]]


def everywhere(scans: list[CarmenScan]) -> np.ndarray:
    """(n, 2): shift cm and |turn| deg of every 4th keyframe against all but its neighbours (well-fitting only:
    at least 60% of its points on the target's walls)."""
    keys = keyframes(scans, 0.5, 0.3)
    world = placed(scans, keys)
    rows = []
    for j in range(0, len(keys), 4):
        others = [i for i in range(len(keys)) if abs(i - j) > NEIGHBOURS]
        if not others:
            continue
        points = np.vstack([world[i][0] for i in others])
        normals = np.vstack([world[i][1] for i in others])
        centre = scans[keys[j]].pose[:2]
        near = np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1]) < REACH
        if near.sum() < 200:  # nothing else saw this place
            continue
        turn, shift, inliers = fit(scans[keys[j]], Cloud.of(points[near], normals[near]))
        if inliers >= 0.6:
            rows.append((shift, abs(turn)))
    return np.array(rows).reshape(-1, 2)


def step_by_step(scans: list[CarmenScan]) -> list[tuple[int, float, float, float]]:
    """(scan index, turn deg, shift cm, inliers) of every keyframe after the first against the map of the
    ``BEHIND`` keyframes before it, all at their reference poses (well-fitting only: at least 60% of its points on
    the target's walls)."""
    keys = keyframes(scans, 0.5, 0.3)
    world = placed(scans, keys)
    rows = []
    for j in range(1, len(keys)):
        before = world[max(0, j - BEHIND):j]
        target = Cloud.of(np.vstack([p for p, _ in before]), np.vstack([n for _, n in before]))
        if len(target) < 50:
            continue
        turn, shift, inliers = fit(scans[keys[j]], target)
        if inliers >= 0.6:
            rows.append((keys[j], turn, shift, inliers))
    return rows


def whiteness(rows: list[tuple[int, float, float, float]], scans: list[CarmenScan]) -> tuple[float, float]:
    """(correlation of neighbouring keyframes' step-by-step turns, correlation of each turn with the reference's own
    turn a scan there): near 0 and 0 for a reference off its scans by white noise; a slow drift correlates the first,
    a laser's skew or a late stamp the second."""
    index = np.array([k for k, _, _, _ in rows])
    turns = np.array([turn for _, turn, _, _ in rows])
    yaw = np.unwrap([scan.pose[2] for scan in scans])
    rate = (yaw[np.minimum(index + 1, len(scans) - 1)] - yaw[np.maximum(index - 1, 0)]) / 2
    return float(np.corrcoef(turns[:-1], turns[1:])[0, 1]), float(np.corrcoef(rate, turns)[0, 1])


def jumps(rows: list[tuple[int, float, float, float]], count: int) -> str:
    """The step-by-step rows needing more than ``JUMP_DEG``, as "scan N (the last P% of the log): turn deg"."""
    big = [(k, turn) for k, turn, _, _ in rows if abs(turn) > JUMP_DEG]
    return "; ".join(f"scan {k} (the last {100 * (count - k) / count:.0f}%): {turn:+.1f}" for k, turn in big) or "none"


def half_against_half(scans: list[CarmenScan]) -> float:
    """:func:`navigation.real_metrics.half_against_half` of the log's scans at the reference poses, at the mapper's
    default cell and threshold."""
    defaults = SlamParams()
    return real_half_against_half([(scan.pose, beams(scan)) for scan in scans], defaults.delta, defaults.occ_thresh)


def jittered(scans: list[CarmenScan], heading_deg: float, shift_m: float,
             seed: int = JITTER_SEED) -> list[CarmenScan]:
    """Copies of `scans` whose poses are moved by white noise: N(0, shift_m) in x and y, N(0, heading_deg) in heading,
    drawn independently for every scan."""
    rng = np.random.default_rng(seed)
    noise = np.column_stack((rng.normal(0.0, shift_m, (len(scans), 2)),
                             rng.normal(0.0, math.radians(heading_deg), len(scans))))
    return [dataclasses.replace(scan, pose=scan.pose + moved) for scan, moved in zip(scans, noise)]


def ceiling_rows(scans: list[CarmenScan], headings_deg: list[float], shift_m: float) -> list[tuple[float, ...]]:
    """(jitter deg, step-by-step median turn deg, halves' score, a perfect map's wall score) of exact `scans` (jitter
    0) and of each jittered reference. The perfect map is what the mapper's keyframes (its ``linearUpdate`` /
    ``angularUpdate``) draw at the exact poses; each reference, what every scan draws at its poses, as the scorer
    draws one."""
    defaults = SlamParams()
    drawn = [beams(scan) for scan in scans]
    keys = keyframes(scans, defaults.linearUpdate, defaults.angularUpdate)
    perfect = reference_map([(scans[k].pose, drawn[k]) for k in keys], defaults.delta, defaults.occ_thresh)
    rows = []
    for heading in [0.0, *headings_deg]:
        reference = jittered(scans, heading, shift_m) if heading > 0 else scans
        turns = np.abs([turn for _, turn, _, _ in step_by_step(reference)])
        drawn_there = reference_map([(scan.pose, b) for scan, b in zip(reference, drawn)], defaults.delta,
                                    defaults.occ_thresh)
        rows.append((heading, float(np.median(turns)), half_against_half(reference),
                     walls_within(perfect, drawn_there, 0.1)))
    return rows


def print_ceiling(names: list[str], headings_deg: list[float], shift_m: float) -> None:
    """The ceiling table: each log re-simulated with exact truth, its reference exact and jittered."""
    print(f"| log (re-simulated) | reference's jitter, deg (and {shift_m:g} m) | step by step: turn deg, median | "
          "walls, half against half | a perfect map's walls within 0.1 m |")
    print("|---|---|---|---|---|")
    for name in names:
        exact = resimulated(read_log(DATA / f"{name}-corrected.log.gz")).scans
        for heading, median, halves, perfect in ceiling_rows(exact, headings_deg, shift_m):
            print(f"| {name} | {'exact' if heading == 0 else f'{heading:g}'} | {median:.2f} | {100 * halves:.1f}% | "
                  f"{100 * perfect:.1f}% |", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--logs", nargs="+", default=list(LOGS[:4]), choices=LOGS)
    parser.add_argument("--first", type=int, default=8, help="how many of the first keyframes to check")
    parser.add_argument("--ceiling", type=float, nargs="+", metavar="DEG",
                        help="instead: on each log re-simulated with exact truth, a perfect map's wall score against "
                             "the reference jittered by DEG degrees a pose (white noise), for each DEG given")
    parser.add_argument("--jitter-m", type=float, default=0.01,
                        help="m: with --ceiling, the jitter's standard deviation in x and y")
    args = parser.parse_args(argv)
    if args.ceiling and min(args.ceiling) <= 0:
        parser.error(f"--ceiling: each DEG must be above 0 (the exact reference is always the first row), got "
                     f"{min(args.ceiling):g}")
    if args.jitter_m < 0:
        parser.error(f"--jitter-m: a standard deviation cannot be negative, got {args.jitter_m:g}")
    if args.ceiling:
        print_ceiling(args.logs, args.ceiling, args.jitter_m)
        return 0
    print("| log | first keyframes against the reference map: turn deg / shift cm (share fitted) | keyframes "
          "checked | everywhere: shift cm, median / 90% / 99% | turn deg, median / 90% / 99% | step by step: "
          f"keyframes checked, turn deg median / 99% | needing over {JUMP_DEG:g} deg: turn deg | walls, half against "
          "half | step turns' correlation: neighbours / with the turn |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.logs:
        scans = read_log(DATA / f"{name}-corrected.log.gz").scans
        first = "; ".join(f"{turn:+.2f} / {shift:.1f} ({inliers:.2f})" for _, turn, shift, inliers in
                          anchor(scans, args.first))
        rows = everywhere(scans)
        pct = lambda column: " / ".join(f"{v:.1f}" for v in np.percentile(column, [50, 90, 99]))  # noqa: E731
        steps = step_by_step(scans)
        turns = np.abs([turn for _, turn, _, _ in steps])
        print(f"| {name} | {first} | {len(rows)} | {pct(rows[:, 0])} | {pct(rows[:, 1])} | {len(steps)}, "
              f"{np.median(turns):.2f} / {np.percentile(turns, 99):.2f} | {jumps(steps, len(scans))} | "
              f"{100 * half_against_half(scans):.1f}% | {' / '.join(f'{c:+.2f}' for c in whiteness(steps, scans))} |",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
