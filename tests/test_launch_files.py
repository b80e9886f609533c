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
from launch_units import launch_units

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


@pytest.mark.parametrize("level", [0, 1, 2])
def test_roslaunch_loads_the_simulator_and_the_network(monkeypatch, level):
    config = load_sim_launch(monkeypatch, f"level:={level}")
    names = [node.name for node in config.nodes]  # a process per level (the network's group: keys), the monitor
    assert sorted(names) == sorted(["simulator", "wander_monitor", *(f"wander_level{n}" for n in range(level + 1))])
    assert "forward" in {entry["name"] for entry in config.params["/wander_level0/members"].value}
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


PATROL_LAUNCH = ROOT / "launch" / "patrol.launch"
PATROL = ROOT / "robots" / "patrol" / "patrol.yaml"


def load_patrol_launch(monkeypatch, *args: str) -> roslaunch.config.ROSLaunchConfig:
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(PATROL_LAUNCH), config, argv=["patrol.launch", *args], verbose=False)
    return config


@pytest.mark.parametrize("level", range(6))
def test_shipped_patrol_launch_files_are_up_to_date(tmp_path, monkeypatch, level):
    monkeypatch.chdir(ROOT)
    fresh = write_launch(load(PATROL.relative_to(ROOT)), level, tmp_path / "fresh.launch")
    shipped = ROOT / "launch" / f"patrol_level{level}.launch"
    assert shipped.read_text() == fresh.read_text(), (
        f"{shipped} is stale: regenerate with `subsumption launch {PATROL.relative_to(ROOT)} --level {level} "
        f"--xml {shipped.relative_to(ROOT)} --write-only`")


def test_the_per_run_parameters_are_args_of_the_written_launch_file():
    text = (ROOT / "launch" / "patrol_level4.launch").read_text()
    assert '<arg name="map_server_map_file" doc=' in text  # required: no default
    assert '<arg name="patrol_goal_file" default="" doc=' in text
    assert '<param name="map_server/map_file" type="str" value="$(arg map_server_map_file)" />' in text
    assert "amcl_initial_pose_x" in text and "detect_model" in text
    wander = (ROOT / "launch" / "wander_level2.launch").read_text()  # nothing per run in wander: line args only
    assert "<arg" in wander and '<arg name="' not in wander.replace('<arg name="line_', "")


def test_patrol_launch_defaults_are_the_pingpong_room(monkeypatch):
    config = load_patrol_launch(monkeypatch)  # level 4
    params = {name: p.value for name, p in config.params.items()}
    assert params["/simulator/world"] == str(ROOT / "subsim" / "maps" / "pingpong_world.yaml")
    assert params["/map_server/map_file"] == str(ROOT / "subsim" / "maps" / "pingpong.yaml")
    assert params["/patrol/goal_file"] == str(ROOT / "robots" / "patrol" / "goals" / "pingpong.yaml")
    assert params["/detect/model"] == str(ROOT / "robots" / "patrol" / "staff")
    assert (params["/amcl/initial_pose_x"], params["/amcl/initial_pose_y"], params["/amcl/initial_pose_a"]) == (
        1.0, 1.0, 0.0)
    assert params["/simulator/map_to_odom"] is False and params["/simulator/publish_map"] is False
    # the Kinect at the rate level 4 reads it, as `subsumption run patrol` gives it (experiments.patrol.VISION_CAMERA)
    from experiments.patrol import VISION_CAMERA
    assert params["/simulator/camera_rate"] == VISION_CAMERA["rate"]
    units = {unit.name for unit in launch_units(config)}  # nodes of their own and the level processes' members
    assert {"detect", "track", "follow", "amcl", "move_base"} <= units
    assert "terminal" not in units
    from robots.patrol.level3 import load_goals
    from experiments.patrol import corner_goals
    from subsim.mapio import load_map
    goals = load_goals(params["/patrol/goal_file"])
    assert goals == corner_goals(load_map(params["/map_server/map_file"]), (1.0, 1.0, 0.0))


def test_patrol_launch_arguments(monkeypatch, tmp_path):
    config = load_patrol_launch(monkeypatch, "level:=2", "ns:=robot0", "rate:=3", "use_sim_time:=false")
    names = {node.name: node.namespace for node in config.nodes}
    assert names.pop("simulator") == "/" and set(names.values()) == {"/robot0/"} and "amcl" not in names
    params = {name: p.value for name, p in config.params.items()}
    assert params["/simulator/map_to_odom"] is True and params["/simulator/rate"] == 3
    assert params["/use_sim_time"] is False
    config = load_patrol_launch(monkeypatch, "level:=5", f"map_file:={tmp_path}/m.yaml", f"goals:={tmp_path}/g.yaml",
                                "initial_pose:=2 3.5 -1.57", f"staff:={tmp_path}/staff.npz")
    params = {name: p.value for name, p in config.params.items()}
    assert params["/map_server/map_file"] == f"{tmp_path}/m.yaml" and params["/patrol/goal_file"] == f"{tmp_path}/g.yaml"
    assert (params["/amcl/initial_pose_x"], params["/amcl/initial_pose_y"], params["/amcl/initial_pose_a"]) == (
        2.0, 3.5, -1.57)
    assert params["/detect/model"] == f"{tmp_path}/staff.npz" and "terminal" in {n.name for n in config.nodes}


@pytest.mark.parametrize("args,line", [(["level:=6"], "level:=6 is not a level of the patrol robot (it has 0 to 5)"),
                                       (["initial_pose:=1 2"], "initial_pose:=1 2 is not x y yaw")])
def test_a_bad_patrol_argument_is_one_clear_error(args, line):
    env = dict(os.environ, ROS_PACKAGE_PATH=f"{ROOT}:/usr/share")
    done = subprocess.run(["roslaunch", "--nodes", str(PATROL_LAUNCH), *args], env=env,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert line in (done.stdout + done.stderr).strip().splitlines()[0]


def test_patrol_rviz_shows_what_the_robot_does(monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(ROOT))
    config = load_patrol_launch(monkeypatch, "rviz:=true", "ns:=robot0")
    rviz = next(node for node in config.nodes if node.name == "rviz")
    view = Path(rviz.args.split("-d", 1)[1].strip())
    assert rviz.namespace == "/robot0/" and view == ROOT / "launch" / "patrol.rviz"
    helper = next(node for node in config.nodes if node.name == "rviz_view")
    assert helper.namespace == "/robot0/"
    displays = yaml.safe_load(view.read_text())["Visualization Manager"]
    topics = {d.get("Topic") or d.get("Image Topic") or d.get("Marker Topic") for d in displays["Displays"]} - {None}
    assert topics == {"map", "scan", "particlecloud", "amcl_pose", "move_base/global_costmap/costmap",
                      "move_base/local_costmap/costmap", "move_base/plan", "patrol/goals", "target_pose",
                      "rviz/camera", "rviz/alarms"}
    remaps = dict(helper.remap_args)
    assert remaps["~camera"] == "rviz/camera" and remaps["~markers"] == "rviz/alarms"
    network_topics = set(load(PATROL).external) | {"rviz/camera", "rviz/alarms"}
    assert topics <= network_topics  # every display reads a topic the robot has
    assert displays["Global Options"]["Fixed Frame"] == "map"
