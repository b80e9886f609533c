"""Reading a recorded bag for offline mapping and localization: the scans with the odometry of their instants,
in the order they were recorded, and the laser's mount, with every problem named by file, topic and message.

Odometry comes from a ``nav_msgs/Odometry`` topic or, when none is named and the bag has no ``/odom``, from
``/tf``'s ``odom -> base`` transform (``base`` being the child of the odom frame there). The mount comes from
``/tf_static``, through any chain of static frames down from the base, as tf2 composes it for the live nodes
(:class:`navigation.scan_geometry.Mounts`; a laser in the base frame itself needs none). Problems raised as
:class:`BagError` (one line, naming the file and where in it): not a readable bag, an empty bag, a missing topic
(with the topics it has), a topic of the wrong type, stamps that go back, a scan whose ranges do not match its
angles, no usable scan at all. A scan's NaN, infinite and zero ranges are read per REP 117
(:func:`navigation.scan_geometry.beams_of`): they draw no wall.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from subsumption.planar import from_pose_msg

from .scan_geometry import Mounts

ODOMETRY_TYPE, SCAN_TYPE, TF_TYPE = "nav_msgs/Odometry", "sensor_msgs/LaserScan", "tf2_msgs/TFMessage"
TRUTH_TOPIC = "/ground_truth"


class BagError(ValueError):
    """A bag cannot be used as asked; the message names the file and the place."""


@dataclass
class BagContents:
    path: Path
    scan_topic: str
    odom_topic: str | None  # None: odometry from /tf
    topics: dict[str, str]  # every topic and its type
    start: float
    end: float
    messages: int
    mounts: Mounts = field(default_factory=Mounts)  # /tf_static as tf2 chains it: where each sensor sits


def _open(path: Path):
    import rosbag  # ROS's own bag reader (Debian's python3-rosbag)

    if not path.is_file():
        raise BagError(f"{path}: no such file")
    try:
        return rosbag.Bag(str(path), "r")
    except Exception as error:  # rosbag raises several kinds for a cut or foreign file
        raise BagError(f"{path}: not a readable bag ({type(error).__name__}: {str(error).strip() or 'no detail'})") \
            from None


def inspect(path: str | Path, scan_topic: str = "/scan", odom_topic: str | None = None) -> BagContents:
    """What the bag holds, checked against what mapping needs."""
    path = Path(path)
    with _open(path) as bag:
        info = bag.get_type_and_topic_info()
        topics = {name: t.msg_type for name, t in info.topics.items()}
        messages = bag.get_message_count()
        if messages == 0:
            raise BagError(f"{path}: the bag is empty (no messages)")
        start, end = bag.get_start_time(), bag.get_end_time()
        listed = ", ".join(f"{n} ({t})" for n, t in sorted(topics.items()))
        _require(path, topics, scan_topic, SCAN_TYPE, "--scan", listed)
        if odom_topic is not None:
            _require(path, topics, odom_topic, ODOMETRY_TYPE, "--odom", listed)
        elif topics.get("/odom") == ODOMETRY_TYPE:
            odom_topic = "/odom"
        elif "/tf" not in topics:
            raise BagError(f"{path}: no odometry: no /odom (nav_msgs/Odometry) and no /tf; name one with --odom "
                           f"(topics: {listed})")
        contents = BagContents(path, scan_topic, odom_topic, topics, start, end, messages)
        if "/tf_static" in topics:
            # raw, then as the installed TFMessage: rosbag's own classes (made from the bag's definitions) are not the
            # geometry_msgs types tf2's buffer expects
            for _, raw, _ in bag.read_messages(topics=["/tf_static"], raw=True):
                for t in TFMessage().deserialize(raw[1]).transforms:
                    contents.mounts.add(t)  # one tf2 refuses places nothing: a scan there is named
    return contents


def _require(path: Path, topics: dict[str, str], topic: str, kind: str, option: str, listed: str) -> None:
    if topic not in topics:
        raise BagError(f"{path}: no topic {topic} ({option}); the bag has: {listed}")
    if topics[topic] != kind:
        raise BagError(f"{path}: topic {topic} is {topics[topic]}, not {kind} ({option})")


def _odometry_of_tf(msg, base: list) -> Iterator[Odometry]:
    """odom -> base transforms of a /tf message as Odometry messages (base: the first child of 'odom' seen)."""
    for t in msg.transforms:
        parent = t.header.frame_id.lstrip("/")
        if parent != "odom":
            continue
        if not base:
            base.append(t.child_frame_id)
        if t.child_frame_id != base[0]:
            continue
        odom = Odometry()
        odom.header = t.header
        odom.child_frame_id = t.child_frame_id
        odom.pose.pose.position.x, odom.pose.pose.position.y = t.transform.translation.x, t.transform.translation.y
        odom.pose.pose.orientation = t.transform.rotation
        yield odom


def messages(contents: BagContents) -> Iterator[tuple[str, object]]:
    """('scan', LaserScan) / ('odom', Odometry) in recorded order, checked as they come (/ground_truth, which only
    scores a run, is :func:`truth_track`'s)."""
    topics = [contents.scan_topic, contents.odom_topic or "/tf"]
    last = {"scan": -math.inf, "odom": -math.inf}
    counts = {"scan": 0, "odom": 0}
    base: list = []
    path = contents.path
    with _open(path) as bag:
        try:
            for topic, msg, _ in bag.read_messages(topics=topics):
                if topic == contents.scan_topic:
                    counts["scan"] += 1
                    _check_stamp(path, topic, counts["scan"], msg.header.stamp.to_sec(), last, "scan")
                    _check_scan(path, topic, counts["scan"], msg)
                    yield "scan", msg
                else:
                    for odom in ([msg] if contents.odom_topic else _odometry_of_tf(msg, base)):
                        counts["odom"] += 1
                        _check_stamp(path, topic, counts["odom"], odom.header.stamp.to_sec(), last, "odom")
                        yield "odom", odom
        except BagError:
            raise
        except Exception as error:  # a bag cut in the middle fails while reading
            raise BagError(f"{path}: cannot read on after message {sum(counts.values())} "
                           f"({type(error).__name__}: {str(error).strip() or 'no detail'})") from None
    if counts["scan"] == 0:
        raise BagError(f"{path}: topic {contents.scan_topic} has no messages")
    if counts["odom"] == 0:
        where = contents.odom_topic or "/tf (odom -> base)"
        raise BagError(f"{path}: no odometry on {where}")


def _check_stamp(path: Path, topic: str, index: int, stamp: float, last: dict, kind: str) -> None:
    if stamp < last[kind]:
        raise BagError(f"{path}: {topic} message {index}: stamp {stamp:.6f} goes back from {last[kind]:.6f}")
    last[kind] = stamp


def _check_scan(path: Path, topic: str, index: int, msg: LaserScan) -> None:
    n = len(msg.ranges)
    if n == 0:
        raise BagError(f"{path}: {topic} message {index} (stamp {msg.header.stamp.to_sec():.3f}): no ranges")
    if msg.angle_increment != 0:
        expected = int(round((msg.angle_max - msg.angle_min) / msg.angle_increment)) + 1
        if abs(expected - n) > 1:
            raise BagError(f"{path}: {topic} message {index} (stamp {msg.header.stamp.to_sec():.3f}): {n} ranges "
                           f"but its angles ({msg.angle_min:.4f}..{msg.angle_max:.4f} by {msg.angle_increment:.5f}) "
                           f"make {expected}")
    if not (math.isfinite(msg.angle_min) and math.isfinite(msg.angle_increment) and msg.range_max > 0):
        raise BagError(f"{path}: {topic} message {index} (stamp {msg.header.stamp.to_sec():.3f}): angle_min, "
                       f"angle_increment or range_max is not a usable number")


def usable(msg: LaserScan) -> bool:
    """True if at least one beam returned from something (finite, above zero and range_min, within range_max)."""
    r = np.asarray(msg.ranges, dtype=float)
    with np.errstate(invalid="ignore"):
        return bool(np.any(np.isfinite(r) & (r > 0) & (r >= msg.range_min) & (r <= msg.range_max)))


def truth_track(contents: BagContents) -> list[tuple[float, np.ndarray]]:
    """Every /ground_truth pose of the bag as (stamp in s, pose x y yaw), in recorded order; empty when the bag has
    none. A score's reference, and where localization may start: never an input to mapping."""
    if contents.topics.get(TRUTH_TOPIC) != ODOMETRY_TYPE:
        return []
    with _open(contents.path) as bag:
        return [truth_pose(msg) for _, msg, _ in bag.read_messages(topics=[TRUTH_TOPIC])]


def truth_pose(msg: Odometry) -> tuple[float, np.ndarray]:
    """A /ground_truth Odometry message as (stamp in s, pose x y yaw): used to score a run, never to drive it."""
    return msg.header.stamp.to_sec(), from_pose_msg(msg.pose.pose)
