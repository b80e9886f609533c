"""The shipped launch files: generated ones are what `subsumption launch` writes today, and roslaunch loads them."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
import roslaunch.config
import roslaunch.xmlloader
import yaml

from subsumption.network import load
from subsumption.ros.launch import write_launch

ROOT = Path(__file__).resolve().parent.parent
NETWORK = ROOT / "robots" / "wander" / "wander.yaml"


@pytest.mark.parametrize("level", [0, 1, 2])
def test_shipped_level_launch_files_are_up_to_date(tmp_path, monkeypatch, level):
    monkeypatch.chdir(ROOT)  # the XML names the network file as it was given: relative to the package
    fresh = write_launch(load(NETWORK.relative_to(ROOT)), level, tmp_path / "fresh.launch")
    shipped = ROOT / "launch" / f"wander_level{level}.launch"
    assert shipped.read_text() == fresh.read_text(), (
        f"{shipped} is stale: regenerate with `subsumption launch {NETWORK.relative_to(ROOT)} --level {level} "
        f"--xml {shipped.relative_to(ROOT)} --write-only`")


@pytest.mark.parametrize("level,nodes", [(0, 7), (1, 10), (2, 16)])
def test_roslaunch_loads_the_simulator_and_the_network(monkeypatch, level, nodes):
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(ROOT / "launch" / "wander_sim.launch"), config,
                                         argv=["wander_sim.launch", f"level:={level}"], verbose=False)
    names = {node.name for node in config.nodes}
    assert len(config.nodes) == nodes and "simulator" in names and "forward" in names
    assert config.params["/use_sim_time"].value is True
    simulator = next(n for n in config.nodes if n.name == "simulator")
    assert simulator.package == "subsumption" and simulator.type == "simulator"
    assert os.path.exists(config.params["/simulator/world"].value)


def test_rviz_option_opens_the_shipped_view_of_every_simulator_topic(monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(ROOT))  # rviz itself need not be installed
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(ROOT / "launch" / "wander_sim.launch"), config,
                                         argv=["wander_sim.launch", "rviz:=true"], verbose=False)
    rviz = next(node for node in config.nodes if node.name == "rviz")
    view = Path(rviz.args.split("-d", 1)[1].strip())
    assert rviz.package == "rviz" and view == ROOT / "launch" / "wander.rviz"
    displays = yaml.safe_load(view.read_text())["Visualization Manager"]
    topics = {display.get("Topic") for display in displays["Displays"]}
    assert {"/map", "/scan", "/sonar", "/odom", "/agents"} <= topics
    assert displays["Global Options"]["Fixed Frame"] == "map"
