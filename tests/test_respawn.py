"""`respawn: true` in a network file: the launch file carries roslaunch's respawn, and a killed node comes back.

The recovery times are printed (pytest -s shows them), never asserted: timing goals live in bench/.
"""
from __future__ import annotations

import os
import signal
import subprocess
import time
import xml.etree.ElementTree as ET
import xmlrpc.client
from pathlib import Path

import pytest
import rosgraph
import yaml
from roslaunch.config import load_config_default

from subsumption.network import load
from subsumption.network.spec import NetworkInvalid
from subsumption.ros.launch import launch, write_launch

EXAMPLE = Path(__file__).resolve().parent.parent / "subsumption" / "examples" / "avoid_demo.yaml"
ARBITER = "suppressor_turn_heading"


def respawning(tmp_path: Path, **marks) -> Path:
    """The avoid example with `marks` ({module or arbiter name: extra keys}) merged into its items."""
    data = yaml.safe_load(EXAMPLE.read_text())
    for level in data["levels"]:
        for item in level.get("modules", []) + level.get("arbiters", []):
            name = item.get("name") or f"{item['kind']}_{item['lower'].replace('.', '_')}"
            item.update(marks.get(name, {}))
    path = tmp_path / "respawning.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_launch_file_carries_respawn(tmp_path):
    path = respawning(tmp_path, wander={"respawn": True, "respawn_delay": 0.5}, **{ARBITER: {"respawn": True}})
    xml = write_launch(load(path), 1, tmp_path / "r.launch")
    nodes = {node.get("name"): node for node in ET.parse(xml).getroot().iter("node")}
    assert (nodes["wander"].get("respawn"), nodes["wander"].get("respawn_delay")) == ("true", "0.5")
    assert (nodes[ARBITER].get("respawn"), nodes[ARBITER].get("respawn_delay")) == ("true", "0.0")
    assert nodes["turn"].get("respawn") is None  # not marked: as before
    config = {node.name: node for node in load_config_default([str(xml)], None).nodes}
    assert config["wander"].respawn and config["wander"].respawn_delay == 0.5
    assert config[ARBITER].respawn and not config["turn"].respawn


@pytest.mark.parametrize("marks, expected", [
    ({"wander": {"respawn": "yes"}}, "module wander: respawn: expected true or false, got 'yes'"),
    ({"wander": {"respawn": True, "respawn_delay": -1}}, "respawn_delay must be >= 0 seconds, got -1"),
    ({"wander": {"respawn": True, "respawn_delay": float("nan")}}, "respawn_delay: expected a finite number"),
    ({ARBITER: {"respawn_delay": 2}}, f"arbiter {ARBITER}: respawn_delay without respawn: true"),
])
def test_bad_respawn_is_an_error_naming_the_place(tmp_path, marks, expected):
    with pytest.raises(NetworkInvalid) as raised:
        load(respawning(tmp_path, **marks))
    assert expected in str(raised.value) and "respawning.yaml:" in str(raised.value)


def _pid(master: rosgraph.Master, node: str) -> int | None:
    try:
        code, _, pid = xmlrpc.client.ServerProxy(master.lookupNode(node)).getPid("/test_respawn")
        return pid if code == 1 else None
    except Exception:  # not registered (yet), or its old registration points at a dead process
        return None


def _back(master: rosgraph.Master, node: str, old_pid: int, deadline: float) -> float:
    """Seconds until `node` answers again from a process other than `old_pid`."""
    start = time.monotonic()
    while time.monotonic() - start < deadline:
        pid = _pid(master, node)
        if pid is not None and pid != old_pid:
            return time.monotonic() - start
        time.sleep(0.05)
    raise AssertionError(f"{node} did not come back within {deadline} s")


@pytest.mark.timeout(90)
def test_killed_nodes_come_back(ros_master, tmp_path, monkeypatch):
    """SIGKILL of a module's process, and `rosnode kill` of an arbiter: roslaunch starts both again."""
    for key, value in ros_master.items():
        monkeypatch.setenv(key, value)
    path = respawning(tmp_path, wander={"respawn": True, "respawn_delay": 0.5}, **{ARBITER: {"respawn": True}})
    log = (tmp_path / "roslaunch.log").open("w")
    running = launch(load(path), 1, env=ros_master, stdout=log, stderr=subprocess.STDOUT)
    master = rosgraph.Master("/test_respawn", master_uri=ros_master["ROS_MASTER_URI"])
    try:
        deadline = time.monotonic() + 40
        while time.monotonic() < deadline and not (_pid(master, "/wander") and _pid(master, f"/{ARBITER}")):
            assert running.running(), (tmp_path / "roslaunch.log").read_text()
            time.sleep(0.2)
        wander = _pid(master, "/wander")
        assert wander, (tmp_path / "roslaunch.log").read_text()
        os.kill(wander, signal.SIGKILL)
        after_sigkill = _back(master, "/wander", wander, 30)
        arbiter = _pid(master, f"/{ARBITER}")
        assert arbiter
        subprocess.run(["rosnode", "kill", f"/{ARBITER}"], env=ros_master, capture_output=True, timeout=15)
        after_rosnode_kill = _back(master, f"/{ARBITER}", arbiter, 30)
        print(f"\nrecovered: wander after SIGKILL in {after_sigkill:.2f} s (respawn_delay 0.5), "
              f"{ARBITER} after rosnode kill in {after_rosnode_kill:.2f} s (respawn_delay 0)")
        assert running.running()
    finally:
        running.stop()
        log.close()
