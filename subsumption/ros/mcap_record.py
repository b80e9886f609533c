"""Record ROS topics into an MCAP file, as ``rosbag record`` does into a bag: the file Foxglove, Lichtblick and the
``mcap`` tools open directly (MCAP's ``ros1`` profile: each channel's messages in ROS 1 serialisation, each schema
the message definition in ``ros1msg`` text, as the connection header carries it).

    rosrun subsumption mcap_record -O run.mcap            # every topic, new ones as they appear
    rosrun subsumption mcap_record -O run.mcap /scan /odom

Messages are taken as bytes (``rospy.AnyMsg``: nothing is deserialised), stamped with ROS time when they arrive
(simulated time when the graph runs on it, as rosbag stamps them: recording starts once /clock runs), and written
in zstd-compressed chunks; the summary (indexes, statistics) is written when the node stops (Ctrl-C, SIGINT,
SIGTERM). A file of a node that was killed (SIGKILL) lacks the summary: ``mcap recover`` rebuilds it.
"""
from __future__ import annotations

import argparse
import io
import sys
import threading
import time
from pathlib import Path
from typing import Any

import rosgraph
import rospy
from mcap.writer import CompressionType, Writer

PROFILE = "ros1"  # MCAP's well-known profile for ROS 1 data
SCHEMA_ENCODING = "ros1msg"
MESSAGE_ENCODING = "ros1"


class McapRecorder:
    """Subscribes to topics as raw bytes and writes each message to an MCAP writer: one schema per message type,
    one channel per topic (registered when its first message arrives, from the connection header)."""

    def __init__(self, path: Path, topics: list[str] | None = None,
                 compression: CompressionType = CompressionType.ZSTD) -> None:
        self.path = path
        self.wanted = [rospy.resolve_name(t) for t in topics] if topics else None  # None: every topic
        self._file = path.open("wb")
        self.writer = Writer(self._file, compression=compression)
        self.writer.start(profile=PROFILE, library="subsumption mcap_record")
        self.lock = threading.Lock()  # rospy calls back from one thread per connection
        self.schemas: dict[str, int] = {}
        self.channels: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self.subscribers: dict[str, rospy.Subscriber] = {}
        self.closed = False

    def discover(self) -> None:
        """Subscribe to every published topic not yet recorded (all of them, or those asked for)."""
        master = rosgraph.Master(rospy.get_name())
        for topic, _type in master.getPublishedTopics(""):
            if topic in self.subscribers or (self.wanted is not None and topic not in self.wanted):
                continue
            self.subscribers[topic] = rospy.Subscriber(topic, rospy.AnyMsg, self._record, callback_args=topic,
                                                       queue_size=1000, tcp_nodelay=True)

    def _record(self, message: Any, topic: str) -> None:
        stamp = rospy.get_rostime().to_nsec()
        header: dict[str, Any] = getattr(message, "_connection_header", {}) or {}
        if isinstance(message, rospy.AnyMsg):
            data = bytes(message._buff)
        else:  # a topic rospy itself reads typed in this process (/clock): it hands every subscriber that type
            buffer = io.BytesIO()
            message.serialize(buffer)
            data = buffer.getvalue()
        with self.lock:
            if self.closed:
                return
            channel = self.channels.get(topic)
            if channel is None:
                channel = self._register(topic, header, message)
            self.counts[topic] = self.counts.get(topic, 0) + 1
            self.writer.add_message(channel, log_time=stamp, data=data, publish_time=stamp,
                                    sequence=self.counts[topic])

    def _register(self, topic: str, header: dict[str, Any], message: Any) -> int:
        type_name = header.get("type") or message._type
        schema = self.schemas.get(type_name)
        if schema is None:
            definition = header.get("message_definition") or getattr(message, "_full_text", "")
            schema = self.writer.register_schema(type_name, SCHEMA_ENCODING, definition.encode())
            self.schemas[type_name] = schema
        metadata = {"md5sum": header.get("md5sum") or message._md5sum, "callerid": header.get("callerid", "")}
        if header.get("latching") == "1":
            metadata["latching"] = "1"
        channel = self.writer.register_channel(topic, MESSAGE_ENCODING, schema, metadata)
        self.channels[topic] = channel
        return channel

    def close(self) -> None:
        """Stop recording and write the summary (the file is complete from here on)."""
        with self.lock:
            if self.closed:
                return
            self.closed = True
            for subscriber in self.subscribers.values():
                subscriber.unregister()
            self.writer.finish()
            self._file.close()


def main(argv: list[str] | None = None) -> int:
    """The node (`argv` as sys.argv, remappings included): record until shut down; print what was written."""
    rospy.init_node("mcap_record", anonymous=True, argv=sys.argv if argv is None else argv)
    parser = argparse.ArgumentParser(prog="rosrun subsumption mcap_record",
                                     description="record ROS topics into an MCAP file (ros1 profile)")
    parser.add_argument("-O", "--output", type=Path, required=True, help="the MCAP file to write")
    parser.add_argument("--compression", choices=["zstd", "lz4", "none"], default="zstd")
    parser.add_argument("topics", nargs="*", help="topics to record (default: every topic, new ones as they appear)")
    args = parser.parse_args(rospy.myargv(sys.argv if argv is None else argv)[1:])
    try:
        recorder = McapRecorder(args.output, args.topics or None, CompressionType[args.compression.upper()])
    except OSError as error:
        print(f"mcap_record: error: cannot write {args.output}: {error.strerror}", file=sys.stderr, flush=True)
        return 2
    rospy.on_shutdown(recorder.close)
    while rospy.get_rostime().is_zero() and not rospy.is_shutdown():  # simulated time: until /clock runs, as rosbag
        time.sleep(0.05)  # wall clock on purpose: there is no ROS time yet
    while not rospy.is_shutdown():
        recorder.discover()
        time.sleep(1.0)  # wall clock on purpose: topics appear as processes start, simulated time may not run yet
    recorder.close()
    print(f"mcap_record: {args.output}: {sum(recorder.counts.values())} messages on {len(recorder.channels)} topics",
          flush=True)
    return 0
