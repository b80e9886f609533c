"""Reading Carmen laser logs (the format of the Radish data sets) and making odometry for corrected ones.

Lines read (the rest, ``PARAM`` aside, are skipped):

* ``FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp``: a front laser scan
  of ``n`` beams over 180 degrees, counter-clockwise from -90 degrees (``n`` odd: the last beam at +90 degrees,
  increment pi/(n-1); ``n`` even: increment pi/n), with the robot's pose and its odometry at that instant.
* ``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn m e1..em
  laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety side_safety turn_axis
  ipc_timestamp host logger_timestamp``: a scan with its own geometry; the laser's mount is the laser pose seen
  from the robot pose.
* ``ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp``: odometry alone; checked and kept in
  :attr:`CarmenLog.odometry`, not written to the bag: every scan line carries the pose (and FLASER the odometry)
  the bag needs. In the Radish corrected logs they are no robot's odometry either: zeros, or the corrected poses
  again, jittered (Intel, ACES, Freiburg 079 and 101, at the scans' stamps: a step's turn a few degrees off the
  scans' poses, Intel's median 2.4, yet no drift: chained, 1.5 m RMS from the corrected poses over Intel's 500 m,
  0.05 m over Freiburg 079's 422 m; measured by hand).
* ``PARAM robot_frontlaser_offset X``: the front laser's distance ahead of the robot's centre.

A *corrected* log (every scan's pose equals its odometry field: the Radish corrected logs) carries no odometry of
its own; its poses are the reference, and odometry is made from them by :func:`drifted`. A *raw* log's own odometry
(FLASER's odometry fields) is used as it is. A ROBOTLASER1 line has one robot pose, so a log of them reads as
corrected: convert a raw one with ``--raw`` (:func:`navigation.carmen_bag.write_bag`'s ``raw``).

Any line that cannot be read raises :class:`CarmenError` naming ``LOG:LINE``.
"""
from __future__ import annotations

import gzip
import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from subsumption.planar import between, compose, wrap

NO_RETURN = 80.0  # m: SICK lasers in these logs write 81.91 (or 80) for "no return"


class CarmenError(ValueError):
    """A log cannot be read; the message names the file and line."""


@dataclass
class CarmenScan:
    line: int  # line number in the log (1-based)
    stamp: float  # s, the log's ipc timestamp
    ranges: np.ndarray  # (n,) m
    angle_min: float  # rad, laser frame
    angle_increment: float  # rad
    pose: np.ndarray  # (3,) robot pose the log gives (corrected logs: the reference)
    odom: np.ndarray  # (3,) robot odometry the log gives
    mount: np.ndarray  # (3,) laser pose in the robot frame


@dataclass
class CarmenLog:
    path: Path
    scans: list[CarmenScan] = field(default_factory=list)
    odometry: list[tuple[float, np.ndarray]] = field(default_factory=list)  # ODOM lines (stamp, pose)
    params: dict[str, str] = field(default_factory=dict)

    @property
    def corrected(self) -> bool:
        """True when every scan's pose equals its odometry (the log carries no odometry of its own)."""
        return all(np.allclose(s.pose, s.odom, atol=1e-9) for s in self.scans)


def _open_lines(path: Path):
    if path.suffix == ".gz":
        return gzip.open(path, "rt", encoding="ascii", errors="replace")
    return open(path, "rt", encoding="ascii", errors="replace")


def read_log(path: str | Path) -> CarmenLog:
    """Every scan (and ODOM line) of a Carmen log, plain or gzipped."""
    path = Path(path)
    if not path.is_file():
        raise CarmenError(f"{path}: no such file")
    log = CarmenLog(path)
    number = 0
    try:
        with _open_lines(path) as lines:
            for number, text in enumerate(lines, start=1):
                _read_line(log, path, number, text)
    except (EOFError, zlib.error, gzip.BadGzipFile, OSError) as error:
        raise CarmenError(f"{path}:{number + 1}: the file is truncated or not valid gzip ({error})") from None
    if not log.scans:
        raise CarmenError(f"{path}:{number}: no FLASER or ROBOTLASER1 line in the log")
    offset = float(log.params.get("robot_frontlaser_offset", "0") or 0)
    for scan in log.scans:
        if scan.mount is None:
            scan.mount = np.array([offset, 0.0, 0.0])
    return log


def _numbers(path: Path, number: int, words: list[str], what: str) -> list[float]:
    try:
        values = [float(w) for w in words]
    except ValueError:
        bad = next(w for w in words if not _is_float(w))
        raise CarmenError(f"{path}:{number}: {what}: '{bad}' is not a number") from None
    if not all(math.isfinite(v) for v in values):
        raise CarmenError(f"{path}:{number}: {what}: NaN or infinite value")
    return values


def _is_float(word: str) -> bool:
    try:
        float(word)
        return True
    except ValueError:
        return False


def _read_line(log: CarmenLog, path: Path, number: int, text: str) -> None:
    words = text.split()
    if not words or words[0].startswith("#"):
        return
    kind = words[0]
    if kind == "PARAM" and len(words) >= 3:
        log.params[words[1]] = words[2]
    elif kind == "FLASER":
        log.scans.append(_flaser(path, number, words))
    elif kind == "ROBOTLASER1":
        log.scans.append(_robotlaser(path, number, words))
    elif kind == "ODOM":
        if len(words) < 8:
            raise CarmenError(f"{path}:{number}: ODOM line has {len(words) - 1} fields, needs at least 7")
        v = _numbers(path, number, words[1:4] + [words[7]], "ODOM")
        log.odometry.append((v[3], np.array(v[:3])))


def _flaser(path: Path, number: int, words: list[str]) -> CarmenScan:
    if len(words) < 2 or not words[1].isdigit():
        raise CarmenError(f"{path}:{number}: FLASER: the beam count '{words[1] if len(words) > 1 else ''}' is not a "
                          f"whole number")
    n = int(words[1])
    if n < 2 or len(words) < 2 + n + 7:
        raise CarmenError(f"{path}:{number}: FLASER with {n} beams needs {n + 9} fields after FLASER, has "
                          f"{len(words) - 1} (a cut line?)")
    ranges = np.array(_numbers(path, number, words[2:2 + n], "FLASER ranges"))
    rest = _numbers(path, number, words[2 + n:2 + n + 7], "FLASER pose, odometry or timestamp")
    increment = math.pi / (n - 1) if n % 2 else math.pi / n
    return CarmenScan(number, rest[6], ranges, -math.pi / 2, increment, np.array(rest[0:3]), np.array(rest[3:6]),
                      None)


def _robotlaser(path: Path, number: int, words: list[str]) -> CarmenScan:
    head = _numbers(path, number, words[2:9], "ROBOTLASER1 header")
    n = int(head[6])
    if n < 2 or len(words) < 10 + n:
        raise CarmenError(f"{path}:{number}: ROBOTLASER1: {n} beams but the line is shorter (a cut line?)")
    ranges = np.array(_numbers(path, number, words[9:9 + n], "ROBOTLASER1 ranges"))
    k = 9 + n
    remissions = int(float(words[k]))
    k += 1 + remissions
    if len(words) < k + 12:
        raise CarmenError(f"{path}:{number}: ROBOTLASER1: the line ends before its poses and timestamp")
    tail = _numbers(path, number, words[k:k + 6] + [words[k + 11]], "ROBOTLASER1 poses or timestamp")
    laser, robot = np.array(tail[0:3]), np.array(tail[3:6])
    start, fov = head[0], head[1]
    increment = fov / (n - 1) if n > 1 else head[2]
    return CarmenScan(number, tail[6], ranges, start, increment, robot, robot.copy(), between(robot, laser))


# Odometry --------------------------------------------------------------------------------------------------------
DRIFT_SEED_BASE = 28  # the generator is numpy's default_rng([DRIFT_SEED_BASE, seed]): a seed gives the same drift


def drifted(poses: np.ndarray, percent: float, seed: int) -> np.ndarray:
    """Odometry made from reference poses (n, 3), starting where they start, with errors in proportion to the
    distance driven and the angle turned between consecutive poses. Per step of d metres and a radians, with
    p = percent / 100, all zero-mean Gaussian and independent:

    * along the motion N(0, (p d)^2), across it N(0, (p d / 2)^2);
    * in heading N(0, (p a)^2 + (p d / 10)^2) rad (the last term: a heading that wanders as the robot drives).

    No systematic (scale) error: with one, the figures would depend mostly on which way a log happens to turn.
    With p = 0 the odometry is the reference itself. The same (poses, percent, seed) always give the same odometry
    (numpy's default_rng([DRIFT_SEED_BASE, seed]))."""
    poses = np.asarray(poses, dtype=float)
    p = percent / 100.0
    out = poses.copy()
    if len(poses) < 2 or p == 0:
        return out
    rng = np.random.default_rng([DRIFT_SEED_BASE, int(seed)])
    current = poses[0].copy()
    for i in range(1, len(poses)):
        step = between(poses[i - 1], poses[i])
        d, a = math.hypot(step[0], step[1]), float(wrap(step[2]))
        along = step[:2] / d if d > 1e-9 else np.array([1.0, 0.0])
        across = np.array([-along[1], along[0]])
        xy = along * (d + rng.normal(0.0, p * d)) + across * rng.normal(0.0, p * d / 2)
        turn = a + rng.normal(0.0, math.sqrt((p * a) ** 2 + (p * d / 10) ** 2))
        current = compose(current, np.array([xy[0], xy[1], turn]))
        out[i] = current
    return out


def make_stamps(log: CarmenLog) -> tuple[np.ndarray, str]:
    """(stamps of the scans, a note on what was changed, "" if nothing). The log's own stamps if they increase.

    * A stamp that goes back by less than MAX_BACK_STEP s (Intel's corrected log has four, up to 0.86 s: its scans
      were merged from two lasers' streams) is moved to 1 ms after the scan before, and the note says so; going
      back further is an error naming the line.
    * Some logs (CSAIL, Orebro) print their stamps with too few digits to tell scans apart (most repeat): then
      stamps are made from the motion, each scan MADE_STEP s after the last, longer if driving at MADE_SPEED or
      turning at MADE_TURN_RATE needs it."""
    stamps = np.array([s.stamp for s in log.scans])
    steps = np.diff(stamps)
    if len(stamps) < 2 or np.count_nonzero(steps > 0) >= 0.9 * len(steps):
        moved, first, largest = 0, None, 0.0
        for k in range(1, len(stamps)):
            if stamps[k] > stamps[k - 1]:
                continue
            back = stamps[k - 1] - stamps[k]
            if back > MAX_BACK_STEP:
                scan = log.scans[k]
                raise CarmenError(f"{log.path}:{scan.line}: the timestamp {scan.stamp} goes back from "
                                  f"{log.scans[k - 1].stamp} on line {log.scans[k - 1].line}")
            first = first or log.scans[k].line
            moved += 1
            largest = max(largest, back)
            stamps[k] = stamps[k - 1] + 1e-3
        note = (f"{moved} stamps did not increase (going back by up to {largest:.3g} s, under the "
                f"{MAX_BACK_STEP:g} s allowed; the first on line {first}): each put 1 ms after the scan before"
                if moved else "")
        return stamps, note
    made = [0.0]
    for a, b in zip(log.scans[:-1], log.scans[1:]):
        step = between(a.pose, b.pose)
        made.append(made[-1] + max(MADE_STEP, math.hypot(step[0], step[1]) / MADE_SPEED,
                                   abs(float(wrap(step[2]))) / MADE_TURN_RATE))
    return np.array(made), (f"its stamps repeat ({len(np.unique(stamps))} different in {len(stamps)} scans): made "
                            f"from the motion")


MAX_BACK_STEP = 1.0  # s
MADE_STEP = 0.2  # s
MADE_SPEED = 0.3  # m/s
MADE_TURN_RATE = 0.5  # rad/s
