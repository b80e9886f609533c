"""The network launch file's external lines as <arg>s: written by `subsumption launch`, each ``line_NAME``
defaults to the line's own name (a file run without them is the graph it always was), and a passed one moves every
node's remapping of that line (a node of its own, or a member of a group node), as roslaunch's own loader hands it
to the process. The profile launch files pass the drivers' topics that way and start no relay. No master, no run:
roslaunch's XML loader only."""
from __future__ import annotations

from pathlib import Path

import xml.etree.ElementTree as ET

import pytest
import roslaunch.config
import roslaunch.xmlloader
from launch_units import launch_units

from subsumption.network import load
from subsumption.network.spec import NetworkInvalid
from subsumption.network.wiring import wire
from subsumption.ros.launch import line_arg, write_launch

ROOT = Path(__file__).resolve().parent.parent
PATROL = ROOT / "robots" / "patrol" / "patrol.yaml"
WANDER = ROOT / "robots" / "wander" / "wander.yaml"


def loaded(monkeypatch, path: Path, *args: str) -> roslaunch.config.ROSLaunchConfig:
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(path), config, argv=[path.name, *args], verbose=False)
    return config


def wired(config: roslaunch.config.ROSLaunchConfig) -> dict[str, dict[str, str]]:
    """Each module's and arbiter's remappings as roslaunch loaded them (a node's own or a group member's)."""
    return {unit.name: dict(unit.remap_args) for unit in launch_units(config)}


@pytest.mark.parametrize("network,level", [(PATROL, 4), (WANDER, 2)])
def test_line_args_default_to_each_lines_own_name(tmp_path, monkeypatch, network, level):
    monkeypatch.chdir(ROOT)
    wiring = wire(load(network.relative_to(ROOT)), level)
    path = write_launch(wiring.network, level, tmp_path / "net.launch")
    args = {e.get("name"): e.get("default") for e in ET.parse(path).getroot().findall("arg")}
    lines = {name: default for name, default in args.items() if name.startswith("line_")}
    assert lines and all(lines[line_arg(topic)] == topic for topic in wiring.network.external
                         if line_arg(topic) in lines)
    assert {"line_odom", "line_cmd_vel"} <= set(lines)
    config = loaded(monkeypatch, path, *(["map_server_map_file:=m.yaml"] if network == PATROL else []))
    seen = wired(config)
    for module in wiring.modules:  # run without the args: every remapping is the wiring's own name, as before
        assert seen[module.name] == dict(module.remaps), module.name
    for arbiter in wiring.arbiters:
        assert seen[arbiter.name] == {"upper": arbiter.upper, "lower": arbiter.lower,
                                      "output": arbiter.output}, arbiter.name


@pytest.mark.parametrize("groups", ["file", "level"])
def test_a_passed_line_arg_remaps_every_reader_of_the_line(tmp_path, monkeypatch, groups):
    monkeypatch.chdir(ROOT)
    wiring = wire(load(PATROL.relative_to(ROOT)), 4)
    path = write_launch(wiring.network, 4, tmp_path / "net.launch", groups=groups)
    config = loaded(monkeypatch, path, "map_server_map_file:=m.yaml", "line_odom:=/base/odom",
                    "line_camera_rgb_image_raw:=/cam/rgb/image_raw", "line_cmd_vel:=/guarded/cmd_vel")
    readers = {m.name: {port: topic for port, topic in m.remaps.items() if topic in ("odom", "camera/rgb/image_raw")}
               for m in wiring.modules}
    readers = {name: wires for name, wires in readers.items() if wires}
    assert {"blindspot", "amcl", "detect", "track"} <= set(readers)
    moved = {"odom": "/base/odom", "camera/rgb/image_raw": "/cam/rgb/image_raw"}
    seen = wired(config)
    for name, wires in readers.items():
        got = seen[name]
        assert got == {**got, **{port: moved[topic] for port, topic in wires.items()}}, (groups, name, got)
    last = next(a for a in wiring.arbiters if a.output == "cmd_vel")  # the motor line's last arbiter
    assert seen[last.name]["output"] == "/guarded/cmd_vel"


def test_two_lines_sharing_an_arg_name_are_refused_naming_both(tmp_path):
    network = tmp_path / "net.yaml"
    network.write_text("name: net\nexternal: {a/b: std_msgs/Empty, a_b: std_msgs/Empty}\nlevels:\n  - name: zero\n"
                       "    modules:\n      - {name: t, node: subsumption/terminal, outputs: {stop: {type: "
                       "std_msgs/Empty, to: a/b}, go: {type: std_msgs/Empty, to: a_b}}}\n")
    with pytest.raises(NetworkInvalid) as refused:
        write_launch(load(network), 0, tmp_path / "net.launch")
    assert f"{network}:2: external line a_b: its launch argument line_a_b is also external line a/b's" in str(
        refused.value)


@pytest.mark.parametrize("robot,args,reads", [
    ("turtlebot2", ["level:=5"], {"odom": "/odom", "camera/depth/image_raw": "/camera/depth/image_raw",
                                  "camera/depth/camera_info": "/camera/depth/camera_info",
                                  "camera/rgb/image_raw": "/camera/rgb/image_raw",
                                  "camera/rgb/image_raw/compressed": "/camera/rgb/image_raw/compressed"}),
    ("generic", ["level:=4", "odom:=/base/odom", "scan:=/laser", "camera:=/cam", "depth:=depth_registered"],
     {"odom": "/base/odom", "camera/depth/image_raw": "/cam/depth_registered/image_raw",
      "camera/depth/camera_info": "camera/depth/camera_info",  # beside a laser: none, depth_scan stays idle
      "camera/rgb/image_raw": "/cam/rgb/image_raw", "camera/rgb/camera_info": "/cam/rgb/camera_info"}),
])
def test_patrol_on_a_profile_reads_the_drivers_topics_without_relays(monkeypatch, robot, args, reads):
    config = loaded(monkeypatch, ROOT / "launch" / "patrol.launch", f"robot:={robot}", *args, "rviz:=true")
    assert not [n.name for n in config.nodes if n.type == "relay"]
    level = int(args[0].partition(":=")[2])
    wiring = wire(load(PATROL), level)
    nodes = wired(config)
    for module in wiring.modules:
        for port, topic in module.remaps.items():
            if topic in reads:
                assert nodes[module.name][port] == reads[topic], (module.name, port)
    assert nodes["rviz_view"]["image"] == reads["camera/rgb/image_raw"]  # rviz's camera picture too


@pytest.mark.parametrize("robot,odom", [("turtlebot2", "/odom"), ("turtlebot3", "/odom"), ("generic", "/base/odom"),
                                        ("sim", "odom")])
def test_wander_on_a_profile_reads_the_odometry_without_a_relay(monkeypatch, robot, odom):
    config = loaded(monkeypatch, ROOT / "launch" / "wander.launch", f"robot:={robot}", "level:=2",
                    *(["odom:=/base/odom"] if robot == "generic" else []))
    assert not [n.name for n in config.nodes if n.type == "relay"]
    readers = {name: remaps["odom"] for name, remaps in wired(config).items() if remaps.get("odom") is not None}
    assert {"integrate", "wander"} <= set(readers)
    assert set(readers.values()) == {odom}
