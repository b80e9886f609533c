"""navigation/networks/: SLAM, frontier exploration and navigation on a known map as network files, which
`subsumption map --runtime ros` and `subsumption navigate --runtime ros` launch through subsumption.ros.launch
(one launcher for every ROS run). Checked and turned into launch files here, without ROS; the runs themselves
are the commands' (docs/navigation.md, docs/mapping.md)."""
from __future__ import annotations

from pathlib import Path

import pytest

from conftest import remaps_of
from experiments.mapping import NETWORKS, move_base_params, navigation_network
from subsumption.network import check_file
from subsumption.network.wiring import wire
from subsumption.ros.launch import launch_xml


@pytest.mark.parametrize("name", ["slam", "explore", "navigate", "localize"])
def test_each_network_file_checks(name):
    result = check_file(NETWORKS / f"{name}.yaml")
    assert result.errors == [], result.errors


def _nodes(network) -> tuple[dict, dict]:
    """The network's launch file's nodes by name, and each node's remaps as roslaunch resolves them."""
    root = launch_xml(wire(network)).getroot()
    nodes = {node.get("name"): node for node in root.iter("node")}
    return nodes, {name: remaps_of(node, root) for name, node in nodes.items()}


def test_a_runs_own_parameters_are_set_over_the_file_and_reach_the_launch_file(tmp_path: Path):
    world = tmp_path / "world.yaml"
    world.write_text("map: unused.yaml\nrobots:\n  - name: robot0\n    sensors: {laser: {fov_deg: 58, min_range: 0.45}}\n")
    network = navigation_network("explore", {"slam": {"initial_pose": [1.0, 1.5, 0.0], "map_update_interval": 1.0},
                                             "move_base": move_base_params(world), "explore": {"look_around": True}})
    nodes, remaps = _nodes(network)
    assert {"slam", "move_base", "explore"} <= set(nodes)
    slam = nodes["slam"]
    assert slam.find("rosparam[@param='initial_pose']").text == "[1.0, 1.5, 0.0]"
    assert slam.find("param[@name='map_update_interval']").get("value") == "1.0"
    assert remaps["slam"]["~map"] == "map"     # /map, as gmapping's
    move_base = nodes["move_base"]
    assert move_base.find("param[@name='hit_memory']").get("value") == "20.0"          # the narrow scan's memory
    assert move_base.find("param[@name='map_cell_corners']").get("value") == "true"
    assert remaps["move_base"]["~cmd_vel"] == "cmd_vel"
    assert nodes["explore"].find("param[@name='look_around']").get("value") == "true"
    assert navigation_network("explore", {}).module("move_base").params == {}          # the file itself untouched


def test_navigate_wires_amcl_and_move_base_where_ros_users_expect_them():
    nodes, remaps = _nodes(navigation_network("navigate", {"amcl": {"initial_pose_x": 2.0, "seed": 3}}))
    amcl = remaps["amcl"]
    assert amcl["~amcl_pose"] == "amcl_pose" and amcl["map"] == "map" and amcl["initialpose"] == "initialpose"
    assert nodes["amcl"].find("param[@name='seed']").get("value") == "3"
    assert remaps["move_base"]["~cmd_vel"] == "cmd_vel"
