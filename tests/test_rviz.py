"""launch/patrol.rviz in a real rviz (Debian's rviz 1.14) under Xvfb, against the simulator running the ping-pong
world on a private master: rviz loads the configuration without an error, subscribes to exactly the topics its
displays name, connects to the publishers of those the simulator publishes (/map, /tf) and receives the map. The whole patrol graph,
with the screenshot to look at, is bench/rviz.py's (`python -m bench.rviz`)."""
from __future__ import annotations

import shutil
import signal
import subprocess
import sys

import pytest
from conftest import ROOT

from bench.rviz import (CONFIG, VirtualDisplay, config_topics, connected_inputs, log_errors, publishers,
                        received_bytes, start_rviz, subscriptions, wait_until)
from subsumption.ros.master import stop_process

pytestmark = pytest.mark.skipif(shutil.which("rviz") is None or shutil.which("Xvfb") is None,
                                reason="rviz and Xvfb are installed by make setup (ROS_DEBS)")


def test_config_topics_are_the_displays_topics():
    topics = config_topics(CONFIG, "/robot0")
    assert {"/robot0/map", "/robot0/map_updates", "/robot0/scan", "/robot0/rviz/camera", "/robot0/rviz/alarms",
            "/robot0/move_base/global_costmap/costmap_updates", "/tf", "/tf_static"} <= topics
    assert log_errors("[ERROR] [1.0]: PluginlibFactory: The plugin for class 'rviz/Nope' failed to load.\n"
                      "[rospack] Error: no such package media_export\n[ INFO] [2.0]: fine") == [
        "[ERROR] [1.0]: PluginlibFactory: The plugin for class 'rviz/Nope' failed to load."]


@pytest.mark.timeout(150)
def test_rviz_loads_patrol_rviz_and_its_displays_get_their_topics(ros_master, tmp_path):
    env = dict(ros_master, ROS_LOG_DIR=str(tmp_path / "ros_logs"))
    master = env["ROS_MASTER_URI"]
    simulator = subprocess.Popen([sys.executable, str(ROOT / "nodes" / "simulator"),
                                  f"_world:={ROOT / 'subsim' / 'maps' / 'pingpong_world.yaml'}", "_connect_wait:=0"],
                                 env=env, stdout=(tmp_path / "simulator.log").open("w"), stderr=subprocess.STDOUT,
                                 start_new_session=True)
    display = VirtualDisplay()
    rviz = None
    try:
        assert wait_until(lambda: "/map" in publishers(master) or simulator.poll() is not None, 60), \
            (tmp_path / "simulator.log").read_text()
        assert simulator.poll() is None, (tmp_path / "simulator.log").read_text()
        rviz = start_rviz(CONFIG, display, env, tmp_path / "rviz.log")
        expected = config_topics(CONFIG)
        assert wait_until(lambda: subscriptions(master, "/rviz") >= expected or rviz.poll() is not None, 90), \
            (tmp_path / "rviz.log").read_text()
        assert subscriptions(master, "/rviz") == expected  # nothing a display names is missed, nothing else taken
        # the displays whose topics the simulator publishes are connected to it: /map (Map), /tf (every display)
        assert wait_until(lambda: {"/map", "/tf"} <= connected_inputs(master, "/rviz"), 30), \
            connected_inputs(master, "/rviz")
        assert wait_until(lambda: received_bytes(master, "/rviz").get("/map", 0) > 0, 30)  # the map reached rviz
        assert rviz.poll() is None, (tmp_path / "rviz.log").read_text()
    finally:
        if rviz is not None:
            stop_process(rviz, signal.SIGTERM)
        stop_process(simulator, signal.SIGTERM)
        display.stop()
    output = (tmp_path / "rviz.log").read_text(errors="replace")
    assert "rviz version" in output  # rviz's output was read (and is not empty)
    assert log_errors(output) == [], output

