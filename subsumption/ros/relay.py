"""A byte relay: ``rosrun subsumption relay input:=/odom output:=/wander/odom _type:=nav_msgs/Odometry``.

topic_tools' relay does this job, but Debian ships its binary without the package's manifest, so roslaunch
cannot start it (``<node pkg="topic_tools">`` is not found). A robot profile uses this one to bring a driver's
topic (``/odom``) into the namespace where a network reads it. Messages pass as serialized bytes, never decoded;
``~type`` (required) is advertised at once, so subscribers connect before the first message.
"""
from __future__ import annotations

import sys
import warnings

import roslib.message
import rospy


def relay_class(msg_type: str) -> type:
    """A publishable class carrying `msg_type`'s name, md5sum and definition around raw bytes."""
    try:
        real = roslib.message.get_message_class(msg_type)
    except (ValueError, ImportError):
        real = None
    if real is None:
        raise ValueError(f"~type: no message type {msg_type!r} is known here")
    return type("Relayed_" + msg_type.replace("/", "_"), (rospy.AnyMsg,),
                {"_type": msg_type, "_md5sum": real._md5sum, "_full_text": real._full_text})


def main(argv: list[str] | None = None) -> int:
    rospy.init_node("relay", anonymous=True, argv=argv)
    try:
        cls = relay_class(str(rospy.get_param("~type", "")))
    except ValueError as error:
        print(f"{rospy.get_name()}: {error}", file=sys.stderr)
        return 2
    with warnings.catch_warnings():  # queue_size=None: published in the subscriber's thread, as it comes
        warnings.simplefilter("ignore", SyntaxWarning)
        publisher = rospy.Publisher("output", cls, queue_size=None, tcp_nodelay=True)
    rospy.Subscriber("input", rospy.AnyMsg, publisher.publish, tcp_nodelay=True)
    rospy.spin()
    return 0


__all__ = ["relay_class", "main"]
