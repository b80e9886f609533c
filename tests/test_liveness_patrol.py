"""`critical:` in a network file, and the patrol robot's reaction to the death of a critical node (issue 31).

Before: with move_base dead the goal under way was neither failed nor alarmed, and the patrol stood silent; the
network file had no way to say which nodes the robot cannot do without. Now the file says it (`critical:
navigation`), the launch file hands it to the monitor, and the patrol module fails the goal under way, raises the
spoken "navigation lost" alarm, holds while navigation is down and goes on when the node is respawned.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from robots.patrol.level3 import Patrol
from subsumption.network import load
from subsumption.network.spec import NetworkInvalid
from subsumption.network.wiring import wire
from subsumption.ros.launch import watched_nodes, write_launch
from subsumption.testing import Harness
from test_patrol_levels import GOALS, ScriptedBase

ROOT = Path(__file__).resolve().parent.parent
PATROL = ROOT / "robots" / "patrol" / "patrol.yaml"
EXAMPLE = ROOT / "subsumption" / "examples" / "avoid_demo.yaml"


def with_marks(tmp_path: Path, **marks) -> Path:
    data = yaml.safe_load(EXAMPLE.read_text())
    for level in data["levels"]:
        for item in level.get("modules", []):
            item.update(marks.get(item["name"], {}))
    path = tmp_path / "marked.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_critical_is_read_and_handed_to_the_monitor(tmp_path):
    network = load(with_marks(tmp_path, wander={"critical": True}, turn={"critical": "steering"}))
    assert (network.module("wander").critical, network.module("turn").critical) == ("wander", "steering")
    assert network.module("runaway").critical == ""
    xml = write_launch(network, 1, tmp_path / "m.launch")
    monitor = next(n for n in ET.parse(xml).getroot().iter("node") if n.get("type") == "monitor")
    nodes = yaml.safe_load(next(p for p in monitor.iter("rosparam") if p.get("param") == "nodes").text)
    by_name = {n["name"]: n for n in nodes}
    assert by_name["turn"] == {"name": "turn", "modules": ["turn"], "critical": "steering", "respawn": False,
                               "reports": True}
    assert {"wander", "turn", "runaway", "suppressor_turn_heading"} <= set(by_name)  # every node, arbiters too


@pytest.mark.parametrize("value, expected", [(3, "critical: expected true (its death stops the motors), false or "
                                                 "what the robot loses"),
                                             ("", "critical: expected"), ("a\nb", "critical: expected")])
def test_a_bad_critical_is_an_error_naming_the_line(tmp_path, value, expected):
    with pytest.raises(NetworkInvalid) as raised:
        load(with_marks(tmp_path, wander={"critical": value}))
    assert "module wander: " + expected in str(raised.value) and "marked.yaml:" in str(raised.value)


def hold_params(path: Path) -> dict[str, dict]:
    """~motor_hold of each node of a launch file, by node name, as roslaunch hands it over (the motor line's
    $(arg line_cmd_vel) substituted: its default)."""
    import roslaunch.config
    import roslaunch.xmlloader

    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(path), config, verbose=False)
    found: dict[str, dict] = {}
    for name, param in config.params.items():  # a dict parameter is set key by key: /NODE/motor_hold/KEY
        node, _, key = name.partition("/motor_hold/")
        if key:
            found.setdefault(node.rsplit("/", 1)[-1], {})[key] = param.value
    return found


@pytest.mark.parametrize("groups, writer", [("file", "turn"), ("level", "avoid_demo_level0")])
def test_critical_true_gives_the_motor_line_s_publisher_its_hold_and_the_monitor_stops_motors(tmp_path, groups,
                                                                                               writer):
    """critical: true, unlike a named critical, makes the launch file hold the motor line: the node that publishes
    cmd_vel (turn itself, no arbiter on the line; its level's group with --groups level) gets ~motor_hold, and the
    monitor's ~nodes marks the critical node stops_motors."""
    network = load(with_marks(tmp_path, wander={"critical": True}, turn={"critical": "steering"}))
    assert (network.module("wander").stops_motors, network.module("turn").stops_motors) == (True, False)
    path = write_launch(network, 1, tmp_path / "m.launch", groups=groups)
    assert hold_params(path) == {writer: {"monitor": "avoid_demo_monitor/motors", "lines": ["cmd_vel"]}}
    nodes = {n["name"]: n for n in watched_nodes(wire(network, 1), groups)}
    stopping = {name for name, node in nodes.items() if node.get("stops_motors")}
    assert stopping == ({"wander"} if groups == "file" else {"avoid_demo_level1"})
    # a named critical alone holds nothing: the launch file is as before
    named = load(with_marks(tmp_path, turn={"critical": "steering"}))
    assert hold_params(write_launch(named, 1, tmp_path / "n.launch", groups=groups)) == {}


def test_critical_true_that_cannot_stop_the_motors_is_an_error_naming_the_module(tmp_path):
    """No motor line to hold (no geometry_msgs/Twist delivered outside) or one an existing node publishes itself:
    the file's promise could not be kept, so check (and launch) say so."""
    from subsumption.network.check import check_file

    data = yaml.safe_load(with_marks(tmp_path, wander={"critical": True}).read_text())
    data["external"]["cmd_vel"] = "std_msgs/Float64"  # not a motor line
    path = tmp_path / "nomotor.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    errors = [str(e) for e in check_file(path).errors]
    assert any("nomotor.yaml:" in e and "module wander: critical: true stops the motors, but network avoid_demo "
               "delivers no geometry_msgs/Twist" in e for e in errors), errors
    driver = tmp_path / "driver.yaml"
    driver.write_text("name: bare\nexternal: {cmd_vel: geometry_msgs/Twist}\nlevels:\n  - modules:\n"
                      "      - {name: base_driver, node: some_pkg/driver,\n"
                      "         outputs: {cmd_vel: {to: cmd_vel, type: geometry_msgs/Twist}}}\n"
                      "      - {name: wander, class: subsumption.examples.avoid_demo:Wander, critical: true,\n"
                      "         outputs: {heading: {to: heading}}}\n")
    data = yaml.safe_load(driver.read_text())
    data["external"]["heading"] = "std_msgs/Float64"
    driver.write_text(yaml.safe_dump(data, sort_keys=False))
    errors = [str(e) for e in check_file(driver).errors]
    assert any("driver.yaml:" in e and "module base_driver: existing node some_pkg/driver publishes motor line "
               "cmd_vel itself" in e for e in errors), errors


def test_the_patrol_declares_navigation_and_the_camera_critical():
    wiring = wire(load(PATROL), 5)
    nodes = {n["name"]: n for n in watched_nodes(wiring, "none")}  # each module as the file declares it
    assert nodes["move_base"]["critical"] == nodes["amcl"]["critical"] == "navigation"
    assert nodes["detect"]["critical"] == nodes["track"]["critical"] == nodes["depth_scan"]["critical"] == "camera"
    assert nodes["move_base"]["respawn"] and nodes["detect"]["respawn"] and nodes["amcl"]["respawn"]
    assert nodes["terminal"]["reports"] is False and nodes["wander"]["critical"] == ""
    # as shipped, a process per level: each is critical for what its members are, and respawns as one
    shipped = {n["name"]: n for n in watched_nodes(wiring)}
    assert shipped["patrol_level3"]["critical"] == "navigation" and shipped["patrol_level3"]["respawn"]
    assert "camera" in shipped["patrol_level4"]["critical"] and shipped["patrol_level4"]["respawn"]
    assert shipped["patrol_level1"]["critical"] == "" and shipped["terminal"]["reports"] is False


def event(node: str, kind: str, critical: str, how: str = "killed (its process is gone)") -> DiagnosticStatus:
    level = DiagnosticStatus.ERROR if kind == "death" else DiagnosticStatus.OK
    return DiagnosticStatus(level, f"/{node}", f"/{node} {kind}", "subsumption",
                            [KeyValue("event", kind), KeyValue("how", how), KeyValue("critical", critical),
                             KeyValue("modules", node), KeyValue("at", "1.0"), KeyValue("pid", "7")])


def test_navigation_lost_fails_the_goal_under_way_alarms_holds_and_resumes_on_respawn():
    h = Harness(Patrol, params={"goal_list": GOALS, "action": "/move_base", "start_delay": 0.5})
    base = ScriptedBase(h, [], delay=100.0)  # the first goal stays under way
    h.run_for(2.0)
    assert base.goals == [(1, 1)]
    h.feed("liveness", event("move_base", "death", "navigation"))
    alarm = h.sent("alarm")[-1]
    assert alarm.name == "navigation lost" and alarm.level == DiagnosticStatus.ERROR
    assert alarm.message.startswith("Navigation lost: move_base killed")
    assert {kv.key: kv.value for kv in alarm.values}["goal"] == "0" and h.module.failed == [0]
    h.run_for(12.0)
    assert base.goals == [(1, 1)]  # nothing sent to a dead move_base
    assert h.sent("alarm")[-1].name == "navigation lost"  # kept raised while lost
    h.feed("liveness", event("move_base", "respawn", "navigation"))
    assert h.sent("alarm")[-1].level == DiagnosticStatus.OK  # cleared
    h.run_for(1.5)
    assert base.goals == [(1, 1), (4, 1)]  # the next goal: the failed one was skipped


def test_camera_lost_raises_its_alarm_and_the_patrol_goes_on():
    h = Harness(Patrol, params={"goal_list": GOALS, "action": "/move_base", "start_delay": 0.5})
    base = ScriptedBase(h, [GoalStatus.SUCCEEDED] * 5)
    h.run_for(0.7)
    h.feed("liveness", event("detect", "death", "camera"))
    h.feed("liveness", event("wander", "death", ""))  # not critical: the patrol does not react
    alarms = h.sent("alarm")
    assert [a.name for a in alarms] == ["camera lost"] and h.module.failed == []
    h.run_for(3.0)
    assert len(base.goals) >= 3  # the patrol goes on


def test_a_group_node_reports_the_modules_it_hosts_and_what_they_take_with_them():
    """With modules sharing a process (issue 33's groups), the monitor watches the group node: its death takes
    every member, so the event names them all and every function they provide."""
    nodes = {n["name"]: n for n in watched_nodes(wire(load(PATROL), 4), "level")}
    level3 = nodes["patrol_level3"]
    assert {"move_base", "amcl", "patrol"} <= set(level3["modules"]) and level3["critical"] == "navigation"
    assert nodes["patrol_level0"]["critical"] == "camera" and "move_base" not in nodes


def test_a_group_death_loses_every_function_it_hosted():
    h = Harness(Patrol, params={"goal_list": GOALS, "action": "/move_base", "start_delay": 0.5})
    ScriptedBase(h, [], delay=100.0)
    h.run_for(2.0)
    h.feed("liveness", event("patrol_level3", "death", "navigation,camera"))
    assert {a.name for a in h.sent("alarm")} == {"navigation lost", "camera lost"} and h.module.failed == [0]


def test_the_record_says_whether_a_death_stopped_the_motors():
    """metrics.json's deaths: `motors_stopped` is true for a critical: true node's death, false for a named one."""
    from experiments.recorder import RunRecorder
    from subsumption import LocalRuntime

    runtime = LocalRuntime()
    recorder = RunRecorder(runtime.node("recorder"), wire(load(PATROL), 3))
    monitor = runtime.node("monitor").publisher("/patrol_monitor/liveness", DiagnosticStatus)
    stopping = event("wander", "death", "wander")
    stopping.values.append(KeyValue("stops_motors", "true"))
    monitor.publish(stopping)
    monitor.publish(event("move_base", "death", "navigation"))
    runtime.run_for(0.1)  # messages are delivered as the runtime runs
    assert [(d["node"], d["critical"], d["motors_stopped"]) for d in recorder.deaths] == [
        ("wander", "wander", True), ("move_base", "navigation", False)]
