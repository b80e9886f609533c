"""A run starts its simulation only when the network is ready: every node registered and every module built.

A module node registers with the master at once, but its module's setup can take seconds more on a loaded
machine (move_base warms its numba kernels, amcl reads its map); a run that started the simulation on
registration alone had the robot driving before move_base answered. Here a module whose setup takes 8 s:
the wait names it as not built while it sets up, and returns once it is."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest
import rosgraph
from conftest import ROOT, ProcessGroup, ros_env

from subsumption.ros.launch import Launched, NetworkNotReady, wait_for_nodes
from subsumption.ros.master import start_master


def _diagnostics_publishers(uri: str) -> set[str]:
    publishers, _, _ = rosgraph.Master("/test_ready", master_uri=uri).getSystemState()
    return next((set(nodes) for topic, nodes in publishers if topic == "/diagnostics"), set())


@pytest.mark.timeout(90)
def test_the_wait_names_a_module_still_setting_up_and_returns_once_it_is_built(tmp_path, monkeypatch):
    master = start_master()
    group = ProcessGroup(dict(ros_env(master.uri), PYTHONPATH=str(ROOT / "tests")), tmp_path)
    try:
        monkeypatch.setitem(os.environ, "ROS_MASTER_URI", master.uri)  # the wait asks this master
        slow = Launched(group.start([str(ROOT / "nodes" / "module"), "__name:=slow",
                                     "_class:=faulty_modules:SlowSetup", "_seconds:=8.0"]), tmp_path / "none")
        started = time.monotonic()
        wait_for_nodes(["slow"], slow, timeout=60.0)  # registered (what the wait used to take for ready) ...
        with pytest.raises(NetworkNotReady, match=r"/slow \(module not built yet\)"):  # ... but still setting up
            wait_for_nodes(["slow"], slow, timeout=1.0, built=["slow"])
        assert "/slow" not in _diagnostics_publishers(master.uri)
        wait_for_nodes(["slow"], slow, timeout=60.0, built=["slow"])
        assert "/slow" in _diagnostics_publishers(master.uri) and time.monotonic() - started >= 8.0
    finally:
        group.stop_all()
        master.stop()


# Publishes 1..30 on /newest and /every quickly and prints what the reader took from each, as JSON. A process of
# its own: rospy.init_node may be called once per process, and the test process may have a node already.
PUBLISH_AND_LISTEN = """
import json, time, rospy
from std_msgs.msg import Float64
rospy.init_node("latest_test", anonymous=True)
took = {"newest": [], "every": []}
for kind in took:
    rospy.Subscriber("/reader/took_" + kind, Float64, lambda msg, k=kind: took[k].append(msg.data))
publishers = {kind: rospy.Publisher("/" + kind, Float64, queue_size=100) for kind in took}  # inputs: relative
deadline = time.monotonic() + 20  # wall clock: connections forming
while time.monotonic() < deadline and any(p.get_num_connections() == 0 for p in publishers.values()):
    time.sleep(0.1)
time.sleep(0.5)
for value in range(1, 31):  # 30 messages in 0.3 s; the reader needs 3 s to take them all
    for publisher in publishers.values():
        publisher.publish(Float64(value))
    time.sleep(0.01)
deadline = time.monotonic() + 20
while time.monotonic() < deadline and len(took["every"]) < 30:
    time.sleep(0.1)
time.sleep(0.3)
print(json.dumps(took))
"""


@pytest.mark.timeout(90)
def test_a_latest_input_skips_to_the_newest_message_while_an_ordinary_one_works_through_the_backlog(tmp_path,
                                                                                                     monkeypatch):
    """Camera inputs are `latest`: a callback slower than the camera must take the newest frame, not the oldest
    queued one (on ROS at 1x level 4's tracker ran 0.46 s behind the camera and follow barely moved)."""
    master = start_master()
    env = ros_env(master.uri)
    group = ProcessGroup(dict(env, PYTHONPATH=str(ROOT / "tests")), tmp_path)
    try:
        monkeypatch.setitem(os.environ, "ROS_MASTER_URI", master.uri)
        reader = Launched(group.start([str(ROOT / "nodes" / "module"), "__name:=reader",
                                       "_class:=faulty_modules:SlowReader", "_seconds:=0.1"]), tmp_path / "none")
        wait_for_nodes(["reader"], reader, timeout=60.0, built=["reader"])
        done = subprocess.run([sys.executable, "-c", PUBLISH_AND_LISTEN], env=env, capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 0, done.stderr
        took = json.loads(done.stdout.strip().splitlines()[-1])
        assert took["every"] == [float(v) for v in range(1, 31)]  # an ordinary input: every message, in order
        newest = took["newest"]
        assert newest and newest[-1] == 30.0 and len(newest) <= 10, newest  # latest: old ones skipped
    finally:
        group.stop_all()
        master.stop()
