"""A Carmen log as a ROS bag, as a robot of today would have recorded it.

Topics written (frames as REP 105 names them):

* ``/scan`` (sensor_msgs/LaserScan, frame ``laser``): every scan; returns of ``NO_RETURN`` m or more (the SICK's
  "nothing seen") and beyond ``max_range`` are written as ``+inf`` (REP 117: nothing within range_max);
* ``/odom`` (nav_msgs/Odometry, ``odom`` -> ``base_link``) and the same on ``/tf``, at every scan's instant
  (recorded just before the scan, so a player has the pose when the scan arrives);
* ``/tf_static``: ``base_link`` -> ``laser``, latched (the log's laser offset);
* ``/ground_truth`` (nav_msgs/Odometry, frame ``map``): corrected logs only, the log's corrected pose, for scoring
  (a map builder never reads it).

The bag is written to a temporary file beside ``out`` and renamed when complete: an error leaves nothing behind.
"""
from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import genpy
import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

from subsumption.planar import pose_msg, transform_msg

from .carmen import NO_RETURN, CarmenLog, drifted, make_stamps

SCAN_TOPIC, ODOM_TOPIC, TRUTH_TOPIC = "/scan", "/odom", "/ground_truth"
BASE_FRAME, ODOM_FRAME, LASER_FRAME, MAP_FRAME = "base_link", "odom", "laser", "map"
DEFAULT_MAX_RANGE = 30.0  # m: the range_max written; longer returns of a SICK are few and poor indoors
SCAN_AFTER_ODOM = 1e-4  # s: a scan is recorded this long after the odometry of its instant


@dataclass
class Converted:
    scans: int
    duration_s: float
    corrected: bool
    stamps_note: str  # what was changed about the log's stamps ("": nothing)
    odometry_ate_m: float  # RMS distance of the odometry from the reference (corrected logs; else nan)


def _odometry_msg(stamp: float, pose: np.ndarray, frame: str, child: str) -> Odometry:
    msg = Odometry()
    msg.header = Header(0, genpy.Time.from_sec(stamp), frame)
    msg.child_frame_id = child
    msg.pose.pose = pose_msg(pose)
    return msg


def scan_message(stamp: float, scan, max_range: float = DEFAULT_MAX_RANGE) -> LaserScan:
    """A Carmen scan as the bag carries it: no return (and anything beyond `max_range`) as +inf (REP 117)."""
    ranges = np.where(scan.ranges >= min(NO_RETURN, max_range), math.inf, scan.ranges)
    n = len(ranges)
    return LaserScan(header=Header(0, genpy.Time.from_sec(stamp), LASER_FRAME), angle_min=scan.angle_min,
                     angle_max=scan.angle_min + scan.angle_increment * (n - 1), angle_increment=scan.angle_increment,
                     time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=max_range,
                     ranges=ranges.astype(np.float32).tolist(), intensities=[])


def write_bag(log: CarmenLog, out: str | Path, drift_percent: float = 0.0, seed: int = 1,
              max_range: float = DEFAULT_MAX_RANGE, raw: bool = False) -> Converted:
    """Write `log` as a bag at `out` (see the module's docstring); odometry drifted as :func:`carmen.drifted` says
    for corrected logs (raw logs: their own odometry, drifted further if asked). `raw`: take the log as raw even
    when its poses and odometry agree (a raw ROBOTLASER1 log, whose lines carry one pose): no /ground_truth."""
    import rosbag  # ROS's own bag writer (Debian's python3-rosbag)

    out = Path(out)
    corrected = log.corrected and not raw
    stamps, note = make_stamps(log)
    reference = np.array([s.pose for s in log.scans])
    base = reference if corrected else np.array([s.odom for s in log.scans])
    odometry = drifted(base, drift_percent, seed)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent)
    os.close(fd)
    try:
        with rosbag.Bag(tmp, "w") as bag:
            t0 = genpy.Time.from_sec(stamps[0])
            mount = log.scans[0].mount
            static = TFMessage([transform_msg(mount, stamps[0], BASE_FRAME, LASER_FRAME)])
            latched = {"topic": "/tf_static", "type": TFMessage._type, "md5sum": TFMessage._md5sum,
                       "message_definition": TFMessage._full_text, "callerid": "/subsumption_convert",
                       "latching": "1"}
            bag.write("/tf_static", static, t0, connection_header=latched)
            for scan, stamp, odom, ref in zip(log.scans, stamps, odometry, reference):
                t = genpy.Time.from_sec(stamp)
                bag.write(ODOM_TOPIC, _odometry_msg(stamp, odom, ODOM_FRAME, BASE_FRAME), t)
                bag.write("/tf", TFMessage([transform_msg(odom, stamp, ODOM_FRAME, BASE_FRAME)]), t)
                if corrected:
                    bag.write(TRUTH_TOPIC, _odometry_msg(stamp, ref, MAP_FRAME, BASE_FRAME), t)
                bag.write(SCAN_TOPIC, scan_message(stamp, scan, max_range),
                          genpy.Time.from_sec(stamp + SCAN_AFTER_ODOM))
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    ate = (float(np.sqrt(np.mean(np.sum((odometry[:, :2] - reference[:, :2]) ** 2, axis=1))))
           if corrected else math.nan)
    return Converted(len(log.scans), float(stamps[-1] - stamps[0]), corrected, note, ate)

