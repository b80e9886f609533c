"""The shipped launch files: generated ones are what `subsumption launch` writes today, roslaunch loads them, and
wander_sim.launch's arguments (level, ns, use_sim_time, world, rviz) do what docs/ros.md says."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
import roslaunch.config
import roslaunch.xmlloader
import yaml

from subsumption.network import load
from subsumption.ros.launch import write_launch

ROOT = Path(__file__).resolve().parent.parent
NETWORK = ROOT / "robots" / "wander" / "wander.yaml"
SIM_LAUNCH = ROOT / "launch" / "wander_sim.launch"


def load_sim_launch(monkeypatch, *args: str) -> roslaunch.config.ROSLaunchConfig:
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(SIM_LAUNCH), config, argv=["wander_sim.launch", *args], verbose=False)
    return config


@pytest.mark.parametrize("level", [0, 1, 2])
def test_shipped_level_launch_files_are_up_to_date(tmp_path, monkeypatch, level):
    monkeypatch.chdir(ROOT)  # the XML names the network file as it was given: relative to the package
    fresh = write_launch(load(NETWORK.relative_to(ROOT)), level, tmp_path / "fresh.launch")
    shipped = ROOT / "launch" / f"wander_level{level}.launch"
    assert shipped.read_text() == fresh.read_text(), (
        f"{shipped} is stale: regenerate with `subsumption launch {NETWORK.relative_to(ROOT)} --level {level} "
        f"--xml {shipped.relative_to(ROOT)} --write-only`")


def test_the_level_check_knows_every_level_of_the_network():
    levels = len(load(NETWORK).levels)
    assert f"('{', '.join(repr(str(i)) for i in range(levels))[1:-1]}')" in SIM_LAUNCH.read_text()
    assert {p.name for p in (ROOT / "launch").glob("wander_level*.launch")} == {
        f"wander_level{i}.launch" for i in range(levels)}


@pytest.mark.parametrize("level,nodes", [(0, 8), (1, 11), (2, 17)])  # modules, arbiters, monitor, simulator
def test_roslaunch_loads_the_simulator_and_the_network(monkeypatch, level, nodes):
    config = load_sim_launch(monkeypatch, f"level:={level}")
    names = {node.name for node in config.nodes}
    assert len(config.nodes) == nodes and {"simulator", "forward", "wander_monitor"} <= names
    assert config.params["/use_sim_time"].value is True
    simulator = next(n for n in config.nodes if n.name == "simulator")
    assert simulator.package == "subsumption" and simulator.type == "simulator"
    assert os.path.exists(config.params["/simulator/world"].value)


def test_ns_use_sim_time_and_world_arguments(monkeypatch, tmp_path):
    world = tmp_path / "world.yaml"
    config = load_sim_launch(monkeypatch, "ns:=robot0", "use_sim_time:=false", f"world:={world}", "level:=1")
    namespaces = {node.name: node.namespace for node in config.nodes}
    assert namespaces.pop("simulator") == "/"  # the simulator owns the world (and /clock)
    assert set(namespaces.values()) == {"/robot0/"}
    assert config.params["/use_sim_time"].value is False
    assert config.params["/simulator/set_use_sim_time"].value is False
    assert config.params["/simulator/world"].value == str(world)
    assert config.params["/robot0/wander_monitor/network"].value == "wander"


@pytest.mark.parametrize("level", ["5", "x"])
def test_a_level_the_robot_lacks_is_one_clear_error(level):
    env = dict(os.environ, ROS_PACKAGE_PATH=f"{ROOT}:/usr/share")
    done = subprocess.run(["roslaunch", "--nodes", str(SIM_LAUNCH), f"level:={level}"], env=env,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    first = (done.stdout + done.stderr).strip().splitlines()[0]
    assert f"level:={level} is not a level of the wander robot (it has 0, 1 and 2)" in first
    assert "Traceback" not in done.stdout + done.stderr and "No such file" not in done.stdout + done.stderr


def test_rviz_shows_the_robot_of_its_namespace(monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(ROOT))  # rviz itself need not be installed
    config = load_sim_launch(monkeypatch, "rviz:=true", "ns:=robot0")
    rviz = next(node for node in config.nodes if node.name == "rviz")
    view = Path(rviz.args.split("-d", 1)[1].strip())
    assert rviz.package == "rviz" and rviz.namespace == "/robot0/" and view == ROOT / "launch" / "wander.rviz"
    displays = yaml.safe_load(view.read_text())["Visualization Manager"]
    topics = {display.get("Topic") for display in displays["Displays"]} - {None}
    assert topics == {"/map", "scan", "sonar", "odom", "/agents"}  # the robot's relative, the world's global
    assert displays["Global Options"]["Fixed Frame"] == "map"
