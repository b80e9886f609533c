"""The simulator posing as a TurtleBot 2 and a TurtleBot 3: the drivers' exact topic names, types, rates, frames
and conventions (kobuki events on change, the LDS-01's full circle with 0.0 for no return), in process and on
a real master."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from collections import defaultdict

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

import subsim
import subsim.local
from subsim.world import load_world
from subsumption import kobuki
from subsumption.local import LocalRuntime


def record(runtime: LocalRuntime, topics: dict[str, type]) -> dict[str, list]:
    got: dict[str, list] = defaultdict(list)
    node = runtime.node("recorder")
    for topic, msg_type in topics.items():
        node.subscribe(topic, msg_type, lambda msg, t=topic: got[t].append((runtime.now(), msg)))
    return got


def drive(runtime: LocalRuntime, topic: str, v: float, w: float = 0.0) -> None:
    node = runtime.node("teleop")
    pub = node.publisher(topic, Twist)
    node.call_every(0.1, lambda: pub.publish(Twist(linear=Twist().linear.__class__(v, 0, 0),
                                                   angular=Twist().angular.__class__(0, 0, w))))


def test_turtlebot3_world_defaults_are_the_burger_and_its_lds():
    spec = load_world(subsim.world_path("corridors_turtlebot3")).robots[0]
    assert spec.kind == "turtlebot3" and spec.radius == 0.105 and spec.sonar is None and spec.camera is None
    assert (spec.limits.max_v, spec.limits.max_w, spec.limits.cmd_timeout) == (0.22, 2.84, 0.5)
    assert (spec.laser.beams, spec.laser.min_range, spec.laser.max_range, spec.laser.fov_deg) == (360, 0.12, 3.5, 360)


def test_turtlebot3_topics_rates_frames_and_the_lds_scan():
    runtime = LocalRuntime()
    subsim.local.attach(runtime, subsim.world_path("corridors_turtlebot3"), seed=1)
    got = record(runtime, {"/scan": LaserScan, "/odom": Odometry, "/tf": TFMessage})
    drive(runtime, "/cmd_vel", 0.5)
    runtime.run_for(4.001)
    assert not {"/mobile_base/commands/velocity", "/bumper", "/sonar"} & set(runtime.topics)
    scans = got["/scan"]
    assert len(scans) == pytest.approx(20, abs=1)  # 5 Hz
    _, scan = scans[-1]
    assert scan.header.frame_id == "base_scan" and len(scan.ranges) == 360
    assert (scan.angle_min, scan.angle_max) == (0.0, pytest.approx(2 * math.pi))
    assert scan.angle_increment == pytest.approx(math.radians(1.0)) and scan.scan_time == pytest.approx(0.2)
    ranges = np.array(scan.ranges)
    assert np.all(np.isfinite(ranges)) and (ranges == 0.0).any()  # the long corridor: nothing within 3.5 m
    valid = ranges[ranges > 0]
    assert valid.min() >= 0.12 - 0.05 and valid.max() <= 3.5
    # beam 0 straight ahead, beam 90 to the left: the robot starts at y = 2.25 in a corridor whose wall is y = 1.0
    assert ranges[270] == pytest.approx(1.25, abs=0.06)  # to the right (south): the wall
    assert len(got["/odom"]) == pytest.approx(120, abs=2)  # 30 Hz
    _, odom = got["/odom"][-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    assert odom.pose.pose.position.x == pytest.approx(0.22 * 4.0, abs=0.1)  # the Burger's 0.22 m/s
    pairs = {(t.header.frame_id, t.child_frame_id) for _, m in got["/tf"] for t in m.transforms}
    assert ("odom", "base_footprint") in pairs and ("odom", "base_link") not in pairs
    statics = {(t.header.frame_id, t.child_frame_id): t.transform.translation
               for t in runtime.topics["/tf_static"].latched.transforms}
    assert statics[("base_footprint", "base_link")].z == pytest.approx(0.010)
    assert statics[("base_link", "base_scan")].z == pytest.approx(0.172)


def test_turtlebot2_kobuki_topics_events_and_frames(tmp_path):
    """Driven into the corridor's wall, the base reports one PRESSED event for the bumper hit (not a stream),
    then RELEASED when it backs off; the Kinect's topics and frames are there; odometry at 50 Hz."""
    world = tmp_path / "w.yaml"
    world.write_text(f"map: {subsim.MAPS / 'corridors.yaml'}\nrobots:\n- {{name: robot0, namespace: '', kind: turtlebot2, "
                     "start: [2.0, 1.5, -1.5708], sensors: {camera: {mode: depth_band, compressed: false}}}\n")
    runtime = LocalRuntime()
    subsim.local.attach(runtime, world, seed=1)
    got = record(runtime, {"/mobile_base/events/bumper": kobuki.BumperEvent, "/odom": Odometry})
    node = runtime.node("teleop")
    pub = node.publisher("/mobile_base/commands/velocity", Twist)

    def tick() -> None:
        cmd = Twist()
        cmd.linear.x = 0.3 if runtime.now() < 2.5 else -0.3
        pub.publish(cmd)

    node.call_every(0.1, tick)
    runtime.run_for(3.5)
    events = [(round(t, 2), m.bumper, m.state) for t, m in got["/mobile_base/events/bumper"]]
    assert [e[1:] for e in events] == [(kobuki.BumperEvent.CENTER, kobuki.BumperEvent.PRESSED),
                                       (kobuki.BumperEvent.CENTER, kobuki.BumperEvent.RELEASED)], events
    assert len(got["/odom"]) == pytest.approx(175, abs=2)  # 50 Hz
    _, odom = got["/odom"][-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    for topic in ("/camera/depth/image_raw", "/camera/depth/camera_info", "/mobile_base/events/cliff",
                  "/mobile_base/events/wheel_drop"):
        assert topic in runtime.topics and runtime.topics[topic].msg_type is not None, topic
    assert runtime.topics["/mobile_base/events/cliff"].msg_type._type == "kobuki_msgs/CliffEvent"
    assert "/cmd_vel" not in runtime.topics and "/bumper" not in runtime.topics
    statics = {(t.header.frame_id, t.child_frame_id): t.transform.translation
               for t in runtime.topics["/tf_static"].latched.transforms}
    assert statics[("base_footprint", "base_link")].z == pytest.approx(0.0102)
    assert statics[("base_link", "camera_link")].z == pytest.approx(0.287 - 0.0102)
    assert ("camera_depth_frame", "camera_depth_optical_frame") in statics


def test_a_bad_kind_names_the_field(tmp_path):
    world = tmp_path / "w.yaml"
    world.write_text(f"map: {subsim.MAPS / 'room.yaml'}\nrobots:\n- {{name: r, kind: turtlebot4}}\n")
    with pytest.raises(subsim.WorldError, match=r"robots\[0\]\.kind.*turtlebot2, turtlebot3"):
        load_world(world)


# A rospy node of its own: reads the posing simulator's topics with the types a TurtleBot 2 user's code declares
LISTENER = r"""
import json, time, rospy
from nav_msgs.msg import Odometry
from subsumption import kobuki
seen = {"bumper": [], "odom": 0}
rospy.init_node("kobuki_listener")
rospy.Subscriber("/mobile_base/events/bumper", kobuki.BumperEvent, lambda m: seen["bumper"].append((m.bumper, m.state)))
rospy.Subscriber("/odom", Odometry, lambda m: seen.__setitem__("odom", seen["odom"] + 1))
end = time.monotonic() + 25
while time.monotonic() < end and len(seen["bumper"]) < 1:
    time.sleep(0.05)
print(json.dumps(seen))
"""


def test_turtlebot2_under_ros_bumper_events_cross_the_wire(ros_processes, tmp_path):
    """On a real master, rostopic names the driver's types and a rospy subscriber of kobuki_msgs/BumperEvent
    (md5sum checked by rospy at connection) hears the robot drive into a wall."""
    world = tmp_path / "w.yaml"
    world.write_text(f"map: {subsim.MAPS / 'corridors.yaml'}\nrobots:\n- {{name: robot0, namespace: '', kind: turtlebot2, "
                     "start: [2.0, 1.4, -1.5708], sensors: {camera: false}}\n")
    env = ros_processes.env
    listener = ros_processes.start([sys.executable, "-c", LISTENER], stdout=subprocess.PIPE)
    ros_processes.start([sys.executable, str(subsim.MAPS.parent.parent / "nodes" / "simulator"),
                         f"_world:={world}", "_rate:=2.0"])
    deadline = time.monotonic() + 20
    types = ""
    while time.monotonic() < deadline and "kobuki_msgs/BumperEvent" not in types:
        types = subprocess.run(["rostopic", "type", "/mobile_base/events/bumper"], env=env, capture_output=True,
                               text=True).stdout
        time.sleep(0.3)
    assert types.strip() == "kobuki_msgs/BumperEvent"
    ros_processes.start(["rostopic", "pub", "-r", "10", "/mobile_base/commands/velocity", "geometry_msgs/Twist",
                         "{linear: {x: 0.3}}"])
    out, _ = listener.communicate(timeout=40)
    seen = json.loads(out.strip().splitlines()[-1])
    assert seen["bumper"][:1] == [[kobuki.BumperEvent.CENTER, kobuki.BumperEvent.PRESSED]]
    assert seen["odom"] > 10


def test_turtlebot2_cliff_and_wheel_drop_events_from_the_world(tmp_path):
    """A stair edge across the corridor (the world's ``cliffs``) and the robot held up for 0.5 s (``lifted``):
    driven at it with nothing to stop it, the Kobuki reports DROPPED then RAISED for both wheels (and stands still
    meanwhile), then CLIFF from its front sensor first (0.156 m ahead of its centre), then its side ones, and
    falls when its centre goes over the edge (a collision; it moves no more)."""
    world = tmp_path / "w.yaml"
    world.write_text(f"map: {subsim.MAPS / 'corridors.yaml'}\ncliffs: [[[3.2, 1.5], [3.8, 1.5], [3.8, 3.0], [3.2, 3.0]]]\n"
                     "robots:\n- {name: robot0, namespace: '', kind: turtlebot2, start: [2.0, 2.25, 0.0], "
                     "lifted: [[1.0, 1.5]], sensors: {camera: false}}\n")
    runtime = LocalRuntime()
    sim = subsim.local.attach(runtime, world, seed=1).sim
    got = record(runtime, {"/mobile_base/events/cliff": kobuki.CliffEvent,
                           "/mobile_base/events/wheel_drop": kobuki.WheelDropEvent})
    drive(runtime, "/mobile_base/commands/velocity", 0.3)
    robot = sim.robots["robot0"]
    runtime.run_for(1.2)
    held_at = robot.x
    runtime.run_for(0.2)
    assert robot.lifted and robot.x == held_at  # held up: the wheels spin in the air
    runtime.run_for(5.6)
    drops = [(m.wheel, m.state) for _, m in got["/mobile_base/events/wheel_drop"]]
    D, R = kobuki.WheelDropEvent.DROPPED, kobuki.WheelDropEvent.RAISED
    assert drops == [(0, D), (1, D), (0, R), (1, R)]
    cliffs = [(m.sensor, m.state) for _, m in got["/mobile_base/events/cliff"]]
    C = kobuki.CliffEvent.CLIFF
    assert cliffs[0] == (kobuki.CliffEvent.CENTER, C) and sorted(cliffs[1:3]) == [(0, C), (2, C)], cliffs
    first = got["/mobile_base/events/cliff"][0][0]
    assert robot.fallen and robot.collisions == 1 and 3.2 <= robot.x < 3.3
    assert first < runtime.now() - 0.3  # the front sensor saw the edge well before the centre went over it


@pytest.mark.parametrize("extra, robot, field", [
    ("cliffs: [[[3.0, 1.0], [4.0, 1.0]]]\n", "", r"w\.yaml: field 'cliffs\[0\]': expected a polygon of at least 3 corners"),
    ("cliffs: [[[3.0, 1.0], [4.0, 1.0], [4.0, x]]]\n", "", r"field 'cliffs\[0\]\[2\]\[1\]': expected a finite number"),
    ("", ", lifted: [[5.0, 2.0]]", r"field 'robots\[0\]\.lifted\[0\]': the end 2.0 must come after the start 5.0"),
    ("cliffs: [[[1.5, 1.5], [2.5, 1.5], [2.5, 2.5]]]\n", "", r"field 'robots\[0\]\.start': is over a cliff"),
])
def test_bad_cliffs_and_lifts_name_the_field(tmp_path, extra, robot, field):
    from subsim.sim import Simulation
    world = tmp_path / "w.yaml"
    world.write_text(f"map: {subsim.MAPS / 'corridors.yaml'}\n{extra}robots:\n- {{name: r, kind: turtlebot2, "
                     f"start: [2.2, 1.6, 0.0]{robot}}}\n")
    with pytest.raises(subsim.WorldError, match=field):
        Simulation(world)
