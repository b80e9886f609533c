"""``subsumption tf SOURCE TARGET``: tf_echo for Debian 12, which packages neither tf's ``tf_echo`` nor tf2_tools.

Prints, once a second (or ``--once``), the transform from frame SOURCE to frame TARGET as tf_echo does: the pose
of TARGET in SOURCE, its translation, its rotation as a quaternion and as roll, pitch, yaw (radians and degrees),
at the newest time both are known. tf2_ros's buffer listens to ``/tf`` and ``/tf_static``; ROS time is used, so
under ``/use_sim_time`` it waits for ``/clock``.
"""
from __future__ import annotations

import math
import sys

import rospy
import tf2_ros
from scipy.spatial.transform import Rotation


def describe(transform, source: str, target: str) -> str:
    """tf_echo's text for a geometry_msgs/TransformStamped."""
    t, q = transform.transform.translation, transform.transform.rotation
    roll, pitch, yaw = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_euler("xyz")  # fixed axes, as tf's RPY
    return (f"At time {transform.header.stamp.to_sec():.3f} ({source} -> {target})\n"
            f"- Translation: [{t.x:.3f}, {t.y:.3f}, {t.z:.3f}]\n"
            f"- Rotation: in Quaternion [{q.x:.3f}, {q.y:.3f}, {q.z:.3f}, {q.w:.3f}]\n"
            f"            in RPY (radian) [{roll:.3f}, {pitch:.3f}, {yaw:.3f}]\n"
            f"            in RPY (degree) [{math.degrees(roll):.3f}, {math.degrees(pitch):.3f}, "
            f"{math.degrees(yaw):.3f}]")


def main_tf(source: str, target: str, once: bool, period: float, timeout: float) -> int:
    """Echo until Ctrl-C (or once). Status 1 when no master answers or, with --once, when the transform is not
    known within `timeout` seconds of ROS time; the line says which."""
    import rosgraph

    if not rosgraph.is_master_online():
        print(f"subsumption tf: no ROS master at {rosgraph.get_master_uri()}", file=sys.stderr)
        return 1
    rospy.init_node("tf_echo", anonymous=True, disable_signals=False)
    buffer = tf2_ros.Buffer()
    keep = tf2_ros.TransformListener(buffer)
    source, target = source.lstrip("/"), target.lstrip("/")
    while not rospy.is_shutdown():
        try:
            found = buffer.lookup_transform(source, target, rospy.Time(0), rospy.Duration(timeout))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as error:
            if once:
                print(f"subsumption tf: no transform {source} -> {target} within {timeout:g} s: {error}",
                      file=sys.stderr)
                return 1
            print(f"waiting for {source} -> {target}: {error}", file=sys.stderr, flush=True)
            continue
        except rospy.ROSInterruptException:
            break
        print(describe(found, source, target), flush=True)
        if once:
            return 0
        try:
            rospy.sleep(period)
        except rospy.ROSInterruptException:
            break
    del keep
    return 0
