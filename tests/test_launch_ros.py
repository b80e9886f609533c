"""The roslaunch file a network becomes, read back by roslaunch itself, and the example network on a real master."""
from __future__ import annotations

import signal
import subprocess
import time
import xml.etree.ElementTree as ET

import pytest
import yaml
from conftest import VENV_BIN, output_of, remaps_of
from test_network_files import EXAMPLE, LEVEL0, write
from roslaunch.config import load_config_default

from subsumption.network import load
from subsumption.ros.launch import write_launch

NODES = {"feelforce", "runaway", "turn", "wander", "avoid", "suppressor_turn_heading", "avoid_demo_monitor"}


def test_xml_has_modules_arbiters_remaps_and_params(tmp_path):
    path = write_launch(load(EXAMPLE), 1, tmp_path / "avoid.launch", namespace="robot1")
    root = ET.parse(path).getroot()
    [group] = root.findall("group")
    assert group.get("ns") == "robot1"
    nodes = {node.get("name"): node for node in group.findall("node")}
    assert set(nodes) == NODES
    turn = nodes["turn"]
    assert (turn.get("pkg"), turn.get("type")) == ("subsumption", "module")
    assert remaps_of(turn, root) == {"heading": "suppressor_turn_heading/output", "~cmd_vel": "cmd_vel"}
    assert {r.get("to") for r in turn.findall("remap")} >= {"$(arg line_cmd_vel)"}  # an external line: an <arg>
    assert {p.get("name"): p.get("value") for p in turn.findall("param")} == {
        "class": "subsumption.examples.avoid_demo:Turn"}
    suppressor = nodes["suppressor_turn_heading"]
    assert (suppressor.get("pkg"), suppressor.get("type")) == ("subsumption", "suppressor")
    assert {r.get("from"): r.get("to") for r in suppressor.findall("remap")} == {
        "upper": "avoid/heading", "lower": "runaway/heading", "output": "suppressor_turn_heading/output"}
    time_constant, msg_type = suppressor.findall("param")
    assert (time_constant.get("name"), time_constant.get("type"), time_constant.get("value")) == (
        "time_constant", "double", "2.0")
    assert (msg_type.get("name"), msg_type.get("value")) == ("type", "std_msgs/Float64")
    monitor = nodes["avoid_demo_monitor"]
    assert (monitor.get("pkg"), monitor.get("type")) == ("subsumption", "monitor")
    assert yaml.safe_load(monitor.find("rosparam").text) == [
        {"name": "suppressor_turn_heading", "kind": "suppressor", "upper": "avoid.heading", "lower": "turn.heading"}]


def test_roslaunch_reads_it_as_meant(tmp_path):
    """roslaunch's own loader: namespaced nodes, remaps and typed private parameters."""
    config = load_config_default([str(write_launch(load(EXAMPLE), 1, tmp_path / "a.launch", "robot1"))], None)
    nodes = {node.name: node for node in config.nodes}
    assert set(nodes) == NODES and {node.namespace for node in config.nodes} == {"/robot1/"}
    assert ["heading", "wander/heading"] in nodes["avoid"].remap_args
    params = {name: p.value for name, p in config.params.items()}
    assert params["/robot1/suppressor_turn_heading/time_constant"] == 2.0
    assert params["/robot1/feelforce/period"] == 0.5
    assert params["/robot1/wander/class"] == "subsumption.examples.avoid_demo:Wander"


def test_existing_node_and_structured_params(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{EXAMPLE.parents[2]}:/usr/share")
    network = load(write(tmp_path, LEVEL0 + """\
      - name: echo
        node: rostopic/rostopic
        args: echo heading
        inputs: {heading: {from: runaway.heading, type: std_msgs/Float64}}
        params: {gains: [1, 2], name: "7", flag: true}
"""))
    config = load_config_default([str(write_launch(network, 0, tmp_path / "e.launch"))], None)
    echo = next(node for node in config.nodes if node.name == "echo")
    assert (echo.package, echo.type, echo.args) == ("rostopic", "rostopic", "echo heading")
    assert echo.remap_args == [["heading", "runaway/heading"]]
    params = {name: p.value for name, p in config.params.items()}
    assert (params["/echo/gains"], params["/echo/name"], params["/echo/flag"]) == ([1, 2], "7", True)


def _lines(env, *args: str) -> list[str]:
    done = subprocess.run(list(args), env=env, capture_output=True, text=True, timeout=15)
    return done.stdout.split()


@pytest.mark.timeout(60)
def test_launch_on_a_real_master(ros_processes, tmp_path):
    env = ros_processes.env
    xml = tmp_path / "avoid.launch"
    process = ros_processes.start([str(VENV_BIN / "subsumption"), "launch", str(EXAMPLE), "--level", "1",
                                   "--xml", str(xml)])
    expected = {f"/{name}" for name in NODES}
    deadline, running = time.monotonic() + 25, set()
    while time.monotonic() < deadline and not expected <= running:
        assert process.poll() is None, output_of(process)
        running = set(_lines(env, "rosnode", "list"))
        time.sleep(0.5)
    assert expected <= running, running
    assert xml.exists()
    topics = set(_lines(env, "rostopic", "list"))
    assert {"/feelforce/force", "/runaway/heading", "/avoid/heading", "/wander/heading",
            "/suppressor_turn_heading/output", "/cmd_vel"} <= topics
    assert _lines(env, "rostopic", "type", "/suppressor_turn_heading/output") == ["std_msgs/Float64"]
    assert _lines(env, "rostopic", "type", "/cmd_vel") == ["geometry_msgs/Twist"]
    # Stop it by pid, as Ctrl-C would: the CLI interrupts roslaunch, which stops its nodes.
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=25) == 0
    assert not expected & set(_lines(env, "rosnode", "list"))
