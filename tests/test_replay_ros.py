"""A real ROS recording replayed into the real graph: `subsumption run --runtime ros --join --bag` records the
wander robot's level 0 on a master that is already running (which it leaves running), then `subsumption
replay --runtime ros` plays the recording's sonars with rosbag play --clock into fresh nodes on a private
master, and the lines the sonars drive come out as recorded."""
from __future__ import annotations

import json
import subprocess

import pytest
import rosgraph
from conftest import ROOT, VENV_BIN

CLI = str(VENV_BIN / "subsumption")


@pytest.mark.timeout(200)
def test_record_on_a_joined_master_and_replay_on_ros_time(ros_master, tmp_path):
    uri = ros_master["ROS_MASTER_URI"]
    bag = tmp_path / "run.bag"
    run = subprocess.run([CLI, "run", "wander", "--level", "0", "--world",
                          str(ROOT / "subsim" / "maps" / "room_people_world.yaml"), "--duration", "8", "--rate", "2",
                          "--runtime", "ros", "--join", "--bag", str(bag), "--out", str(tmp_path / "out")],
                         env=ros_master, capture_output=True, text=True, timeout=150)
    assert run.returncode == 0, run.stdout + run.stderr
    assert f"ROS master {uri}" in run.stderr  # it joined the running master...
    master = rosgraph.Master("/test_join", master_uri=uri)
    assert master.getPid() > 0 and master.getParam("/use_sim_time") is True  # ...and left it running
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["sim_time_s"] >= 5.0

    done = subprocess.run([CLI, "replay", str(bag), "--level", "0", "--runtime", "ros", "--rate", "4"],
                          env=ros_master, capture_output=True, text=True, timeout=150)
    table = {line.split()[0]: line.split() for line in done.stdout.splitlines() if line.startswith("/")}
    assert {"/sonar/map", "/feelforce/force", "/cmd_vel"} <= set(table), done.stdout + done.stderr
    # driven by the sonars alone, stamped with the sweep they answer: message for message, however loaded the
    # machine was when it recorded (its answers late) or replays
    for topic in ["/sonar/map", "/feelforce/force"]:
        recorded, replayed, matched = (int(x) for x in table[topic][1:4])
        assert recorded > 30 and matched >= 0.95 * recorded, table[topic]
