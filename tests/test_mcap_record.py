"""rosrun subsumption mcap_record: topics into an MCAP file that MCAP readers (Foxglove, Lichtblick, the mcap
library) open, in the ros1 profile: each message as ROS 1 bytes that the message class deserialises again."""
from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest
import rosgraph
from conftest import ROOT
from mcap.reader import make_reader
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Range
from std_msgs.msg import String

PUBLISHER = r"""
import time
import rospy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Range
from std_msgs.msg import String
rospy.init_node("talker")
clock = rospy.Publisher("/clock", Clock, queue_size=10)
words = rospy.Publisher("words", String, queue_size=10, latch=True)
ranges = rospy.Publisher("sonar", Range, queue_size=10)
n = 0
while not rospy.is_shutdown():
    n += 1
    clock.publish(Clock(clock=rospy.Time(100 + n)))  # simulated time: 100 s + n
    words.publish(String(data=f"word {n}"))
    ranges.publish(Range(range=0.5 + n, field_of_view=0.3))
    time.sleep(0.1)  # wall clock: this process makes the simulated time
"""


@pytest.mark.timeout(60)
def test_mcap_record_writes_what_was_published(ros_master, tmp_path):
    """Every topic asked for, typed or not in the recorder itself (rospy reads /clock typed on simulated time), in
    order, stamped with simulated time."""
    path = tmp_path / "run.mcap"
    rosgraph.Master("/test_mcap", master_uri=ros_master["ROS_MASTER_URI"]).setParam("/use_sim_time", True)
    talker = subprocess.Popen([sys.executable, "-c", PUBLISHER], env=ros_master, start_new_session=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    recorder = subprocess.Popen([sys.executable, str(ROOT / "nodes" / "mcap_record"), "-O", str(path),
                                 "/words", "/sonar", "/clock"], env=ros_master, start_new_session=True,
                                stdout=(tmp_path / "record.log").open("w"), stderr=subprocess.STDOUT)
    try:
        master = rosgraph.Master("/test_mcap", master_uri=ros_master["ROS_MASTER_URI"])

        def recording() -> bool:
            subscribed = dict(master.getSystemState()[1])
            return all(any(n.startswith("/mcap_record") for n in subscribed.get(t, [])) for t in ("/words", "/sonar", "/clock"))

        deadline = time.monotonic() + 30  # wall clock: processes starting
        while not recording() and time.monotonic() < deadline:
            assert recorder.poll() is None, (tmp_path / "record.log").read_text()
            time.sleep(0.3)
        time.sleep(2.5)  # about 25 messages of each
    finally:
        recorder.send_signal(signal.SIGINT)
        assert recorder.wait(15) == 0, (tmp_path / "record.log").read_text()
        talker.terminate()
        talker.wait(10)
    with path.open("rb") as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == "ros1"
        summary = reader.get_summary()  # written at the end: the file is complete
        assert summary is not None and summary.statistics.message_count >= 20
        messages = {"/words": [], "/sonar": [], "/clock": []}
        stamps = []
        for schema, channel, message in reader.iter_messages():
            assert (schema.encoding, channel.message_encoding) == ("ros1msg", "ros1")
            kind = {"/words": String, "/sonar": Range, "/clock": Clock}[channel.topic]
            assert schema.name == kind._type and channel.metadata["md5sum"] == kind._md5sum
            assert {String: b"string data", Range: b"float32 range", Clock: b"time clock"}[kind] in schema.data
            messages[channel.topic].append(kind().deserialize(message.data))
            stamps.append(message.log_time)
    assert len(messages["/clock"]) >= 10 and messages["/clock"][-1].clock.secs > 100
    assert 100e9 < min(stamps) and max(stamps) <= messages["/clock"][-1].clock.to_nsec()  # simulated time
    numbers = [int(m.data.split()[1]) for m in messages["/words"]]
    assert len(numbers) >= 10 and numbers == list(range(numbers[0], numbers[0] + len(numbers)))  # in order, all
    assert len(messages["/sonar"]) >= 10 and all(abs(m.field_of_view - 0.3) < 1e-6 for m in messages["/sonar"])
    assert "messages on 3 topics" in (tmp_path / "record.log").read_text()


def test_an_unwritable_file_is_one_line(ros_master, tmp_path):
    bad = subprocess.run([sys.executable, str(ROOT / "nodes" / "mcap_record"), "-O", str(tmp_path / "no" / "x.mcap")],
                         env=ros_master, capture_output=True, text=True, timeout=30)
    assert bad.returncode == 2
    assert bad.stderr.strip() == f"mcap_record: error: cannot write {tmp_path / 'no' / 'x.mcap'}: No such file or " \
                                 "directory"
