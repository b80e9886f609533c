"""The ROS side of the terminal: subscribers that feed the hub, the command publishers, the dead-man switch.

Every subscriber callback runs on rospy's thread for its topic and hands the message to
:meth:`terminal.hub.Hub.offer`, which encodes it there (off the web server's loop). Commands are published
from the loop with rospy publishers (thread-safe, queued). Two threads of our own, both on the wall clock:

- the dead-man watchdog, polling every 10 ms: when motor commands stop coming for ``~deadman_timeout``
  while the robot is being driven, it publishes a zero Twist on the command topic. It does not depend on the
  web server's loop, so even a stuck loop cannot keep the robot moving;
- the pose publisher: ``terminal/robot_pose`` from tf (``~map_frame`` -> ``~base_frame``) when tf has it,
  else from ``amcl_pose``, at ``~pose_rate``;
- with ``~expose``, the graph poll: the master's published topics once a second, so rosapi's answers and
  subscriptions to exposed topics know what the graph offers. An exposed topic is subscribed here only while a
  client watches it (:meth:`RosSide.sync_topic`).
"""
from __future__ import annotations

import threading
import time
from typing import Any

import rospy
import roslib.message
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist
from sensor_msgs.msg import CompressedImage, Image

from subsumption import images

from .config import Config
from .control import DeadMan
from .convert import dumps, to_json
from .hub import Channel, Encoded, Hub, is_motion

JPEG_MAGIC = b"\xff\xd8"
IMAGE_BUFFER = 1 << 24  # rospy's receive buffer for big messages (frames, maps)


def camera_encoder(quality: int):
    """Encodes a camera message for clients: always a JPEG CompressedImage, whatever came in."""

    def encode(msg: Any) -> Encoded:
        if isinstance(msg, Image):
            compressed = images.compressed_jpeg(images.to_rgb(msg), msg.header, quality)
        elif bytes(msg.data[:2]) != JPEG_MAGIC:  # PNG and other formats: MJPEG and the page want JPEG
            compressed = images.compressed_jpeg(images.from_compressed(msg), msg.header, quality)
        else:
            compressed = msg
        return Encoded(dumps(to_json(compressed)), jpeg=bytes(compressed.data),
                       stamp=msg.header.stamp.to_sec(), source=msg)

    return encode


class RosSide:
    """Subscriptions into the hub, publishers out of it; implements the hub's CommandSink."""

    def __init__(self, config: Config, hub: Hub, commands: dict[str, str]) -> None:
        self.config = config
        self.hub = hub
        self.name = rospy.get_name()
        self.deadman = DeadMan(config.deadman_timeout)
        self._publishers = {role: rospy.Publisher(topic, roslib.message.get_message_class(hub.commands[
            rospy.resolve_name(topic)].type), queue_size=10) for role, topic in commands.items()}
        self._status = rospy.Publisher(config.topic("status"), DiagnosticStatus, queue_size=10, latch=True)
        self._robot_pose = rospy.Publisher(config.topic("robot_pose"), PoseStamped, queue_size=10)
        self._keep: list[Any] = []
        self._camera_type_reported: set[str] = set()
        self._amcl: PoseWithCovarianceStamped | None = None
        self._amcl_used: PoseWithCovarianceStamped | None = None
        self._stopping = threading.Event()
        self._exposed: dict[str, rospy.Subscriber] = {}  # exposed topic -> its subscriber while watched
        self._exposed_lock = threading.Lock()
        # the operator's record, kept here whoever the client is (a browser, roslibpy, a script): every command
        # published, and the time under manual control in ROS time (from the command that takes control to the
        # release or disconnect that hands it back); on ~status as operator_commands and manual_control_s
        self.operator_commands = 0
        self._manual_since: float | None = None
        self._manual_before = 0.0
        self._status_at = 0.0  # wall clock of the last status a command published (at most one a second)
        for channel in hub.channels.values():
            self._subscribe(channel)

    def _subscribe(self, channel: Channel) -> None:
        role = channel.role.role
        if role in ("robot_pose", "status") or role in self._publishers:
            return  # the terminal's own topics: delivered to the hub directly
        if role == "camera":
            channel.encode = camera_encoder(self.config.jpeg_quality)
            self._keep.append(rospy.Subscriber(channel.name, rospy.AnyMsg, self._on_camera, callback_args=channel,
                                               queue_size=1, buff_size=IMAGE_BUFFER, tcp_nodelay=True))
            return
        msg_class = roslib.message.get_message_class(channel.type)
        callback = self._on_amcl if role == "pose" else self.hub.offer
        self._keep.append(rospy.Subscriber(
            channel.name, msg_class, lambda msg, ch=channel: callback(ch, msg),
            queue_size=max(1, channel.role.keep), buff_size=IMAGE_BUFFER, tcp_nodelay=True))

    def _on_camera(self, raw: rospy.AnyMsg, channel: Channel) -> None:
        msg_type = raw._connection_header.get("type", "")
        if msg_type == "sensor_msgs/CompressedImage":
            msg: Any = CompressedImage()
        elif msg_type == "sensor_msgs/Image":
            msg = Image()
        else:
            if msg_type not in self._camera_type_reported:
                self._camera_type_reported.add(msg_type)
                rospy.logerr("%s: camera topic %s carries %s; wanted sensor_msgs/CompressedImage or "
                             "sensor_msgs/Image: not shown", self.name, channel.name, msg_type)
            return
        self.hub.offer(channel, msg.deserialize(raw._buff))

    def _on_amcl(self, channel: Channel, msg: PoseWithCovarianceStamped) -> None:
        self._amcl = msg
        self.hub.offer(channel, msg)

    # Threads ---------------------------------------------------------------------------------------------
    def start(self) -> None:
        """Start the dead-man watchdog and the pose thread."""
        threading.Thread(target=self._watchdog, name="terminal-deadman", daemon=True).start()
        threading.Thread(target=self._pose_loop, name="terminal-pose", daemon=True).start()
        if self.hub.exposure:
            threading.Thread(target=self._graph_loop, name="terminal-graph", daemon=True).start()

    def stop(self) -> None:
        """Ask the side's threads to end."""
        self._stopping.set()

    GRAPH_PERIOD = 1.0  # wall seconds between polls of the master's topics (a new topic is listed that soon)

    def _graph_loop(self) -> None:
        """The master's published topics, for exposure; a master that does not answer keeps the last list."""
        while not rospy.is_shutdown():
            try:
                self.hub.graph_topics = dict(rospy.get_published_topics())  # replaced whole: readers see one list
            except Exception as error:  # socket errors, a master restarting: try again next period
                rospy.logdebug("%s: cannot list the graph's topics: %s", self.name, error)
            if self._stopping.wait(self.GRAPH_PERIOD):
                return

    def sync_topic(self, channel: Channel) -> None:
        """Subscribe an exposed topic while a client wants it, unsubscribe it when none does (a worker thread)."""
        with self._exposed_lock:
            subscriber = self._exposed.get(channel.name)
            if channel.wanted and subscriber is None:
                msg_class = roslib.message.get_message_class(channel.type)
                self._exposed[channel.name] = rospy.Subscriber(
                    channel.name, msg_class, lambda msg, ch=channel: self.hub.offer(ch, msg),
                    queue_size=max(1, channel.role.keep), buff_size=IMAGE_BUFFER, tcp_nodelay=True)
                rospy.loginfo("%s: serving %s (%s) read-only", self.name, channel.name, channel.type)
            elif not channel.wanted and subscriber is not None:
                subscriber.unregister()
                del self._exposed[channel.name]
                rospy.loginfo("%s: nobody watches %s: unsubscribed", self.name, channel.name)

    def _watchdog(self) -> None:
        while not self._stopping.wait(0.01):
            if self.deadman.due(time.monotonic()):
                self._publishers["cmd_vel"].publish(Twist())
                rospy.logwarn("%s: no motor command for %.2f s while driving: stopped the robot (dead-man switch)",
                              self.name, self.config.deadman_timeout)
                if self.hub.loop is not None:
                    self.hub.loop.call_soon_threadsafe(self.hub.deadman_fired)

    def _pose_loop(self) -> None:
        """terminal/robot_pose from tf when it has the robot, else from the newest amcl_pose."""
        buffer = None
        if self.config.use_tf:
            import tf2_ros
            buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10))
            self._keep.append(tf2_ros.TransformListener(buffer))
        channel = self.hub.by_role.get("robot_pose")
        last_stamp = None
        period = 1.0 / self.config.pose_rate
        while not self._stopping.wait(period) and not rospy.is_shutdown():
            pose = None
            if buffer is not None:
                try:
                    transform = buffer.lookup_transform(self.config.map_frame, self.config.base_frame, rospy.Time(0))
                except Exception:  # tf2 raises several kinds; all mean "not known yet"
                    transform = None
                if transform is not None and transform.header.stamp != last_stamp:
                    last_stamp = transform.header.stamp
                    pose = PoseStamped(header=transform.header)
                    pose.pose.position.x = transform.transform.translation.x
                    pose.pose.position.y = transform.transform.translation.y
                    pose.pose.position.z = transform.transform.translation.z
                    pose.pose.orientation = transform.transform.rotation
            if pose is None and last_stamp is None and self._amcl is not None and self._amcl is not self._amcl_used:
                self._amcl_used = self._amcl
                pose = PoseStamped(header=self._amcl.header, pose=self._amcl.pose.pose)
            if pose is not None:
                self._robot_pose.publish(pose)
                if channel is not None:
                    self.hub.offer(channel, pose)

    # CommandSink ----------------------------------------------------------------------------------------
    def publish_command(self, role: str, msg: Any) -> None:
        """Publish an operator's command on the robot's topic for `role`; a cmd_vel also feeds the dead-man switch."""
        if role == "cmd_vel":
            self.deadman.command(is_motion(msg), time.monotonic())
        self._publishers[role].publish(msg)
        self.operator_commands += 1
        if self._manual_since is None:
            self._manual_since = rospy.get_time()
        if time.monotonic() - self._status_at >= 1.0:  # wall clock: paces the status, not the robot
            self._status_at = time.monotonic()
            self.hub.status_changed()  # the record stays current on the latched ~status

    def manual_control_s(self) -> float:
        """ROS seconds under manual control so far, the stretch under way included."""
        held = self._manual_before
        if self._manual_since is not None:
            held += max(0.0, rospy.get_time() - self._manual_since)
        return held

    def halt(self, reason: str) -> bool:
        """Stop the robot if it is being driven (connection lost, control released); True if it was."""
        if not self.deadman.cut():
            return False
        self._publishers["cmd_vel"].publish(Twist())
        rospy.logwarn("%s: %s while driving: stopped the robot", self.name, reason)
        return True

    def publish_status(self, summary: dict[str, Any]) -> None:
        """Publish the terminal's summary on /diagnostics, with the operator's commands and manual control time."""
        if not summary["operator"] and self._manual_since is not None:  # control handed back: the stretch ends
            self._manual_before, self._manual_since = self.manual_control_s(), None
        summary = dict(summary, deadman_stops=self.deadman.stops, operator_commands=self.operator_commands,
                       manual_control_s=round(self.manual_control_s(), 3))
        operator = summary["operator"]
        status = DiagnosticStatus(
            level=DiagnosticStatus.OK, name=self.name, hardware_id="",
            message=f"operator: {operator}" if operator else "no operator: the robot's own levels drive",
            values=[KeyValue(key, str(value)) for key, value in summary.items()])
        self._status.publish(status)
        if self.hub.loop is not None:
            channel = self.hub.by_role.get("status")
            if channel is not None:
                self.hub.deliver_local(channel, status)
