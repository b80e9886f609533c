"""Module groups without a master: the ``group:`` keys of a network file, how ``--groups`` places every module and
arbiter, the launch file roslaunch reads back, and the fault boundary of the reference robots grouped by level."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from roslaunch.config import load_config_default

from subsumption.network import load, wire
from subsumption.network.check import check_file
from subsumption.network.groups import group_wiring
from subsumption.network.spec import NetworkInvalid, split_ref
from subsumption.ros.launch import network_nodes, watched_nodes, write_launch

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "subsumption" / "examples" / "avoid_demo.yaml"
PATROL = ROOT / "robots" / "patrol" / "patrol.yaml"
WANDER = ROOT / "robots" / "wander" / "wander.yaml"


def edited(tmp_path: Path, edit) -> Path:
    """The avoid example with `edit(data)` applied, written to a file of its own."""
    data = yaml.safe_load(EXAMPLE.read_text())
    edit(data)
    path = tmp_path / "grouped.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_groups_from_the_file_and_by_level(tmp_path):
    def edit(data):
        data["levels"][0]["group"] = "reflexes"
        data["levels"][1]["modules"][0]["group"] = "reflexes"  # wander joins level 0's process
    wiring = wire(load(edited(tmp_path, edit)), 1)
    by_file = group_wiring(wiring, "file")
    assert by_file.members == {"reflexes": ["feelforce", "runaway", "turn", "wander", "suppressor_turn_heading"]}
    assert by_file.group_of("avoid") is None  # named nowhere: a process of its own, as without groups
    by_level = group_wiring(wiring, "level")
    assert by_level.members == {"avoid_demo_level0": ["feelforce", "runaway", "turn", "suppressor_turn_heading"],
                                "avoid_demo_level1": ["wander", "avoid"]}
    assert set(group_wiring(wiring, "none").of.values()) == {None}


def test_an_arbiter_runs_with_the_line_it_sits_on_unless_it_names_a_group(tmp_path):
    """Level 1's suppressor sits on level 0's turn.heading: it belongs to level 0's process, so that level 1's
    death leaves level 0's line whole."""
    wiring = wire(load(EXAMPLE), 1)
    assert group_wiring(wiring, "level").group_of("suppressor_turn_heading") == "avoid_demo_level0"

    def edit(data):
        data["levels"][0]["group"] = "low"
        data["levels"][1]["group"] = "high"
        data["levels"][1]["arbiters"][0]["group"] = "high"
    assert group_wiring(wire(load(edited(tmp_path, edit)), 1), "file").group_of("suppressor_turn_heading") == "high"


@pytest.mark.parametrize("edit, expected", [
    (lambda d: d["levels"][0].update(group="level 0"), "level avoid objects: group must be a ROS node name"),
    (lambda d: d["levels"][0]["modules"][0].update(group=3), "module feelforce: group: expected a non-empty string"),
    (lambda d: d["levels"][1]["arbiters"][0].update(group=""), "group: expected a non-empty string"),
    (lambda d: d["levels"][0]["modules"].append({"name": "echo", "node": "rostopic/rostopic", "group": "g"}),
     "module echo: an existing ROS node (node: rostopic/rostopic) runs in a process of its own and cannot join"),
])
def test_a_bad_group_is_an_error_naming_the_place(tmp_path, edit, expected):
    with pytest.raises(NetworkInvalid) as raised:
        load(edited(tmp_path, edit))
    assert expected in str(raised.value) and "grouped.yaml:" in str(raised.value)


def test_a_group_named_like_a_module_is_an_error_of_check(tmp_path):
    result = check_file(edited(tmp_path, lambda d: d["levels"][0].update(group="wander")), 1)
    assert [e.message for e in result.errors] == [
        "module wander: a group has the same name; a group is a ROS node, so its name must be its own"]


def test_the_launch_file_roslaunch_reads(tmp_path):
    path = write_launch(load(EXAMPLE), 1, tmp_path / "g.launch", namespace="robot1", groups="level")
    config = load_config_default([str(path)], None)
    nodes = {node.name: node for node in config.nodes}
    assert set(nodes) == {"avoid_demo_level0", "avoid_demo_level1", "avoid_demo_monitor"}
    assert (nodes["avoid_demo_level0"].package, nodes["avoid_demo_level0"].type) == ("subsumption", "group")
    params = {name: p.value for name, p in config.params.items()}
    # each module's parameters under its own name, as a node of its own would have them
    assert params["/robot1/feelforce/period"] == 0.5 and params["/robot1/wander/direction"] == 0.0
    members = {m["name"]: m for m in params["/robot1/avoid_demo_level0/members"]}
    assert members["turn"] == {"name": "turn", "class": "subsumption.examples.avoid_demo:Turn",
                               "remap": {"heading": "suppressor_turn_heading/output", "~cmd_vel": "cmd_vel"}}
    assert members["suppressor_turn_heading"] == {
        "name": "suppressor_turn_heading", "arbiter": "suppressor", "upper": "avoid/heading",
        "lower": "runaway/heading", "output": "suppressor_turn_heading/output", "time_constant": 2.0,
        "type": "std_msgs/Float64", "upper_type": "std_msgs/Float64"}
    # readiness waits for the groups (and the nodes of their own), not for members that are no nodes
    names, built = network_nodes(wire(load(EXAMPLE), 1), "level")
    assert sorted(names) == sorted(built) == ["avoid_demo_level0", "avoid_demo_level1"]


def test_a_group_respawns_as_one_when_a_member_asks(tmp_path):
    def edit(data):
        data["levels"][1]["modules"][1].update(respawn=True, respawn_delay=2.0)
    path = write_launch(load(edited(tmp_path, edit)), 1, tmp_path / "r.launch", groups="level")
    nodes = {n.get("name"): n for n in ET.parse(path).getroot().iter("node")}
    assert (nodes["avoid_demo_level1"].get("respawn"), nodes["avoid_demo_level1"].get("respawn_delay")) == (
        "true", "2.0")
    assert nodes["avoid_demo_level0"].get("respawn") is None


@pytest.mark.parametrize("file, level", [(PATROL, 5), (WANDER, 2)])
def test_grouped_by_level_a_dead_level_cuts_no_line_of_the_levels_below(file, level):
    """The fault boundary, on the reference robots: follow every wire that carries a level's output towards
    what it drives; none passes through a process of a higher level. So killing level N's process silences
    level N's lines only (its arbiters' upper lines), and levels 0..N-1 keep driving."""
    wiring = wire(load(file), level)
    groups = group_wiring(wiring, "level")
    module_level = {m.name: m.spec.level for m in wiring.modules}
    process_level = {}
    for name, group in groups.of.items():
        if group is not None:
            process_level[name] = int(group.rsplit("_level", 1)[1])
    for arbiter in wiring.arbiters:
        lower = split_ref(arbiter.spec.lower)
        assert lower is not None
        line_level = module_level[lower[0]]
        if arbiter.name in process_level:  # an existing node's line keeps its arbiter in a process of its own
            assert process_level[arbiter.name] <= line_level, (arbiter.name, process_level[arbiter.name])
    for wire_ in wiring.wires:
        if wire_.source.kind == "module" and wire_.target.kind == "arbiter" and wire_.target.port == "lower":
            source_level = module_level[wire_.source.name]
            assert process_level.get(wire_.target.name, source_level) <= source_level, wire_


def test_liveness_watches_each_group_with_its_members():
    """The monitor's ~nodes: a group is one node whose death takes all its members; it is critical for what any
    of them is."""
    wiring = wire(load(PATROL), 4)
    nodes = {n["name"]: n for n in watched_nodes(wiring, group_wiring(wiring, "level"))}
    assert set(nodes) == {f"patrol_level{n}" for n in range(5)}
    assert nodes["patrol_level3"]["modules"][:3] == ["map_server", "amcl", "move_base"]
    assert "navigation_drives" in nodes["patrol_level0"]["modules"]  # level 3's arbiter, on level 0's line
    assert nodes["patrol_level3"]["critical"] == "navigation" and nodes["patrol_level3"]["reports"]
    ungrouped = {n["name"] for n in watched_nodes(wiring, "none")}
    assert {"amcl", "move_base", "navigation_drives"} <= ungrouped


@pytest.mark.parametrize("path", [WANDER, PATROL], ids=["wander", "patrol"])
def test_the_reference_robots_ship_a_process_per_level(path):
    """The network files' own group: keys place every module and arbiter as --groups level does: what `roslaunch
    subsumption patrol.launch` and `subsumption run` start by default is a process per level (existing ROS nodes,
    the operator terminal, in processes of their own)."""
    network = load(path)
    wiring = wire(network, len(network.levels) - 1)
    shipped, by_level = group_wiring(wiring, "file"), group_wiring(wiring, "level")
    assert shipped.of == by_level.of
    ours = {module.spec.level for module in wiring.modules if not module.spec.is_node}  # level 5: the terminal only
    assert set(shipped.members) == {f"{network.name}_level{n}" for n in ours} and len(ours) >= 3
