"""The patrol robot on each robot profile: `roslaunch subsumption patrol.launch robot:=...` builds the graph that
brings the driver's topics (as the profile's YAML names them) onto the patrol network's external lines, in its
namespace, and puts the motor guard between the network's motor line and the base. Loaded with roslaunch's own
XML loader (what `roslaunch` runs), no master: each node's remappings and parameters are read as roslaunch would
hand them to the process. Then a run as a user would start it, against the simulator posing as a TurtleBot 2: the
patrol robot's levels 0-1 on a landing between two stairwells (the cliff path end to end). bench/profile_patrol.py
runs levels 0-4 in the ping-pong room (a goal reached, then the intruder alarm on the stranger, scored as the patrol
experiment scores it; it exits 1 when the stranger is missed), level 3 on a TurtleBot 3 and level 5."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import roslaunch.config
import roslaunch.core
import roslaunch.xmlloader
import rosgraph.names

import subsim
from conftest import launch_against_simulator
from launch_units import launch_units
from subsumption.network import load as load_network
from subsumption.network.wiring import wire
from subsumption.profile import load_profile

ROOT = Path(__file__).resolve().parent.parent
PATROL_LAUNCH = ROOT / "launch" / "patrol.launch"
# the external lines the network reads from the base's sensors (the rest are its own outputs, or rviz's)
SENSOR_LINES = {"odom", "scan", "bumper", "camera/depth/image_raw", "camera/depth/camera_info",
                "camera/rgb/image_raw", "camera/rgb/camera_info"}
ADAPTERS = {"scan_lines", "kobuki_bumper", "base_guard"}
PATROL_NETWORK = load_network(ROOT / "robots" / "patrol" / "patrol.yaml")


def load(monkeypatch, *args: str) -> roslaunch.config.ROSLaunchConfig:
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(PATROL_LAUNCH), config, argv=["patrol.launch", *args], verbose=False)
    return config


def remaps(node: roslaunch.core.Node) -> dict[str, str]:
    """The node's remappings with both sides resolved as rospy resolves them in the node (~ is the node's own)."""
    ns = node.namespace
    full = rosgraph.names.ns_join(ns, node.name)

    def resolve(name: str) -> str:
        if name.startswith("~"):
            return rosgraph.names.ns_join(full, name[1:])
        return name if name.startswith("/") else rosgraph.names.ns_join(ns, name)
    return {resolve(src): resolve(dst) for src, dst in node.remap_args}


def sensor_lines_read(level: int) -> dict[tuple[str, str], str]:
    """(node, remapped name as the network file writes it) -> the sensor line it reads, from the wiring itself."""
    wiring = wire(PATROL_NETWORK, level)
    return {(module.name, source): target for module in wiring.modules for source, target in module.remaps.items()
            if target in SENSOR_LINES and not source.startswith("~")}


def graph(config: roslaunch.config.ROSLaunchConfig, level: int, ns: str = "/patrol"):
    """(feeds, network reads, guard): feeds maps each sensor line in `ns` to the driver topics it comes from,
    through an adapter (which writes the line in ns) or read by the network's nodes in its place (the line's arg);
    network reads is the set of sensor lines the network's own nodes read and none of them writes; guard is the
    guard's node. Every node reading a line reads the same topic for it."""
    feeds: dict[str, set[str]] = {}
    read_as: dict[str, set[str]] = {}  # line in ns -> the topics the network's nodes read for it
    writes: set[str] = set()  # what the network's own nodes write (depth_scan's scan)
    guard = None
    lines = sensor_lines_read(level)
    for node in launch_units(config):
        wires = remaps(node)
        full = rosgraph.names.ns_join(node.namespace, node.name)
        assert node.type != "relay", (node.name, "copies a topic the network can read itself")
        if node.name == "base_guard":
            guard = node
        elif node.name == "scan_lines":
            assert node.namespace == ns + "/adapters/"  # not beside the line it writes (rospy remaps twice)
            feeds.setdefault(wires[f"{full}/clean"], set()).add(wires[f"{node.namespace}scan"])
        elif node.name == "kobuki_bumper":
            feeds.setdefault(wires[f"{full}/bumper"], set()).update(
                {wires[f"{node.namespace}events"], wires[f"{node.namespace}cliff"]})
        else:
            assert node.namespace == ns + "/", (node.name, node.namespace)  # the network runs in ns
            for source, target in node.remap_args:
                line = lines.get((node.name, source))
                if line is not None:
                    read_as.setdefault(f"{ns}/{line}", set()).add(remaps(node)[rosgraph.names.ns_join(ns, source)])
            writes |= {dst for src, dst in wires.items() if src.startswith(full + "/")}
    for line, topics in read_as.items():
        assert len(topics) == 1, (line, topics)  # all readers agree
        if topics != {line}:  # read from the driver directly
            feeds.setdefault(line, set()).update(topics)
    return feeds, set(read_as) - writes, guard


def param(config, node, name: str):
    value = config.params.get(rosgraph.names.ns_join(rosgraph.names.ns_join(node.namespace, node.name), name))
    return None if value is None else value.value


def driver_topics(profile: str) -> set[str]:
    """Every topic the profile's YAML says the robot's drivers publish (sensors and events)."""
    loaded = load_profile(profile)
    return {t.topic for t in loaded.topics.values()} | {e.topic for e in loaded.events.values()}


# (launch arguments, lines fed from which driver topics, sensor lines deliberately left unfed, guard's output and
# its ~needs)
CASES = {
    "turtlebot2 level 3": (
        ["robot:=turtlebot2", "level:=3"],
        {"/patrol/odom": {"/odom"}, "/patrol/camera/depth/image_raw": {"/camera/depth/image_raw"},
         "/patrol/camera/depth/camera_info": {"/camera/depth/camera_info"},
         "/patrol/bumper": {"/mobile_base/events/bumper", "/mobile_base/events/cliff"}},
        set(), (None, "patrol:3")),
    "turtlebot2 level 4": (
        ["robot:=turtlebot2", "level:=4"],
        {"/patrol/odom": {"/odom"}, "/patrol/camera/depth/image_raw": {"/camera/depth/image_raw"},
         "/patrol/camera/depth/camera_info": {"/camera/depth/camera_info"},
         "/patrol/camera/rgb/image_raw": {"/camera/rgb/image_raw"},
         "/patrol/camera/rgb/camera_info": {"/camera/rgb/camera_info"},
         "/patrol/bumper": {"/mobile_base/events/bumper", "/mobile_base/events/cliff"}},
        set(), (None, "patrol:4")),
    "turtlebot3 level 3 (the LDS)": (
        ["robot:=turtlebot3", "level:=3"],
        {"/patrol/odom": {"/odom"}, "/patrol/scan": {"/scan"}},
        # no bumpers on a Burger; no depth camera: the network's depth_scan stays idle and the laser is its scan
        {"/patrol/bumper", "/patrol/camera/depth/image_raw", "/patrol/camera/depth/camera_info"},
        (None, "patrol:3")),
    "turtlebot3 level 4 with a camera": (
        ["robot:=turtlebot3", "level:=4", "camera:=/astra"],
        {"/patrol/odom": {"/odom"}, "/patrol/scan": {"/scan"},
         "/patrol/camera/depth/image_raw": {"/astra/depth/image_raw"},
         "/patrol/camera/rgb/image_raw": {"/astra/rgb/image_raw"},
         "/patrol/camera/rgb/camera_info": {"/astra/rgb/camera_info"}},
        # the depth camera_info is not brought: depth_scan would otherwise make a second scan beside the laser's
        {"/patrol/bumper", "/patrol/camera/depth/camera_info"},
        (None, "patrol:4")),
    "generic level 3 on a laser": (
        ["robot:=generic", "level:=3", "cmd_vel:=/base/cmd", "odom:=/base/odom", "scan:=/front_laser"],
        {"/patrol/odom": {"/base/odom"}, "/patrol/scan": {"/front_laser"}},
        {"/patrol/bumper", "/patrol/camera/depth/image_raw", "/patrol/camera/depth/camera_info"},
        ("/base/cmd", "")),  # other names than generic.yaml's: the guard cannot know what to wait for
    "generic level 3 on a depth camera": (
        ["robot:=generic", "level:=3", "scan:=none", "camera:=/cam", "depth:=depth_registered"],
        {"/patrol/odom": {"/odom"}, "/patrol/camera/depth/image_raw": {"/cam/depth_registered/image_raw"},
         "/patrol/camera/depth/camera_info": {"/cam/depth_registered/camera_info"}},
        {"/patrol/bumper"}, ("/cmd_vel", "")),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_patrol_launch_on_a_profile_feeds_every_line_from_the_driver(monkeypatch, case):
    args, expected, unfed, (output, needs) = CASES[case]
    config = load(monkeypatch, *args)
    names = {n.name for n in config.nodes}
    assert "simulator" not in names  # a profile runs against a robot that is already up
    feeds, reads, guard = graph(config, int(args[1].partition(":=")[2]))
    assert feeds == expected
    # every sensor line the network reads at this level is fed, except those the robot does not have
    assert reads - set(feeds) == unfed, reads
    assert set(feeds) <= reads | {"/patrol/scan"}  # nothing fed that nobody reads (the scan: also depth_scan's)
    robot = args[0].partition(":=")[2]
    if robot != "generic":  # the driver topics are the profile's own (and so the posing simulator's)
        assert set().union(*feeds.values()) <= driver_topics(robot) | {"/astra/depth/image_raw",
                                                                       "/astra/rgb/image_raw",
                                                                       "/astra/rgb/camera_info"}
    # the guard: the network's motor line (the last arbiter writes /patrol/cmd_vel) to the base, on the profile
    assert remaps(guard)["/patrol/cmd_vel"] == "/patrol/cmd_vel" and guard.required
    assert any(remaps(n).get("/patrol/output") == "/patrol/cmd_vel" for n in launch_units(config)
               if n.type in ("suppressor", "inhibitor"))
    assert param(config, guard, "profile") == robot
    assert param(config, guard, "output") == output  # None: the profile's base.cmd_vel
    assert param(config, guard, "needs") == needs


def test_generic_caps_reach_the_guard(monkeypatch):
    config = load(monkeypatch, "robot:=generic", "level:=2", "max_v:=0.4")
    guard = next(n for n in config.nodes if n.name == "base_guard")
    assert param(config, guard, "max_v") == 0.4 and param(config, guard, "acc_w") == 4.0


def test_sim_keeps_its_graph_and_a_profile_without_the_camera_it_needs_is_refused(monkeypatch):
    config = load(monkeypatch, "level:=3")
    names = {n.name for n in config.nodes}
    assert "simulator" in names and not names & ADAPTERS
    assert all(n.namespace == "/" for n in config.nodes)
    env = dict(os.environ, ROS_PACKAGE_PATH=f"{ROOT}:/usr/share")
    for args, line in ((["robot:=turtlebot3", "level:=4"], "level:=4 on robot:=turtlebot3 needs an RGB-D camera"),
                       (["robot:=generic", "level:=1", "scan:=none"],
                        "level:=1 on robot:=generic needs an RGB-D camera (scan:=none: its depth image makes the scan)")):
        done = subprocess.run(["roslaunch", "--nodes", str(PATROL_LAUNCH), *args], env=env, capture_output=True,
                              text=True, timeout=60)
        assert done.returncode != 0 and line in done.stdout + done.stderr, done.stdout + done.stderr


# Listens to the simulator's scoring topics (never given to the robot), the Kobuki's cliff events and the guard's
# status until simulated time `until`.
WATCHER = r"""
import json, math, sys, time, rospy
from diagnostic_msgs.msg import DiagnosticStatus
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32
from subsumption import kobuki
until = float(sys.argv[1])
seen = {"collisions": 0, "poses": [], "cliffs": [], "t": 0.0, "status": {}}
def on_truth(m):
    p, q = m.pose.pose.position, m.pose.pose.orientation
    seen["t"] = m.header.stamp.to_sec()
    yaw = 2 * math.atan2(q.z, q.w)
    seen["poses"].append((round(seen["t"], 2), round(p.x, 3), round(p.y, 3), round(yaw, 3)))
rospy.init_node("watcher")
rospy.Subscriber("/ground_truth", Odometry, on_truth)
rospy.Subscriber("/collisions", UInt32, lambda m: seen.__setitem__("collisions", m.data))
rospy.Subscriber("/mobile_base/events/cliff", kobuki.CliffEvent,
                 lambda m: seen["cliffs"].append((round(seen["t"], 2), m.sensor, m.state)))
rospy.Subscriber("/patrol/base_guard/status", DiagnosticStatus,
                 lambda m: seen.__setitem__("status", {kv.key: kv.value for kv in m.values}))
deadline = time.monotonic() + 150
while seen["t"] < until and time.monotonic() < deadline:
    time.sleep(0.1)
print(json.dumps(seen))
"""


def test_patrol_on_a_turtlebot2_stops_and_backs_off_at_a_stair_edge(ros_processes):
    """`roslaunch subsumption patrol.launch robot:=turtlebot2 level:=1` against the simulator posing as a TurtleBot
    2 on a landing between two stairwells (every way out leads over an edge): the wandering robot reaches an edge,
    the Kobuki's cliff event stops it (the guard counts a cliff stop), the same event, as a contact on level 0/1's
    bumper line, turns it away, and it never falls (0 collisions)."""
    duration, rate = 12.0, 2.0
    args = ["subsumption", "patrol.launch", "robot:=turtlebot2", "level:=1", "use_sim_time:=true"]
    seen, logs = launch_against_simulator(ros_processes, args, WATCHER, duration,
                                          subsim.world_path("corridors_turtlebot2_stairs"), rate)
    assert "Traceback" not in logs, logs
    assert seen["t"] >= duration, logs
    assert seen["collisions"] == 0, (seen["collisions"], seen["poses"][-1], logs)  # never over an edge
    cliffs = [c for c in seen["cliffs"] if c[2] == 1]
    assert cliffs, (seen["poses"][::25], logs)  # it did reach an edge
    assert int(seen["status"].get("stops_cliff", 0)) >= 1, seen["status"]
    # then level 0/1 take it away from the edge, as from a bump: bumpturn backs off as far as blindspot knows the
    # room behind (nothing, this early: the Kinect has seen only ahead) and turns away from the side that was hit
    t0 = cliffs[0][0]
    at = min(seen["poses"], key=lambda p: abs(p[0] - t0))
    later = [p for p in seen["poses"] if t0 < p[0] <= t0 + 4.0]
    turned = max(abs(math.remainder(p[3] - at[3], math.tau)) for p in later)
    assert turned >= 0.5, (at, later[::10])
    travelled = sum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(seen["poses"], seen["poses"][1:]))
    assert travelled >= 0.5, travelled



@pytest.mark.parametrize("robot", ["turtlebot2", "turtlebot3", "generic"])
def test_no_profile_node_remaps_a_name_onto_another_of_its_remapped_names(monkeypatch, robot):
    """rospy looks a remapped name up again among the node's remappings: an adapter whose output was remapped to
    ns/scan beside its input `scan` (ns/scan -> the laser) published onto the laser's own topic and read its own
    output again and again (the TurtleBot 3 patrol robot stood still, its scan never came). No node of either
    robot's launch on a profile may remap to a name that is itself remapped."""
    for launch, args in ((PATROL_LAUNCH, ["robot:=" + robot, "level:=3"]),
                         (ROOT / "launch" / "wander.launch", ["robot:=" + robot])):
        monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
        config = roslaunch.config.ROSLaunchConfig()
        roslaunch.xmlloader.XmlLoader().load(str(launch), config, argv=[launch.name, *args], verbose=False)
        for node in config.nodes:
            wires = remaps(node)
            looped = {src: dst for src, dst in wires.items() if dst in wires and wires[dst] != dst}
            assert not looped, (launch.name, node.namespace + node.name, looped)
