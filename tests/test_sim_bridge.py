"""The bridge on the in-process LocalRuntime: topics, frames, stamps, bumpers, determinism, plots."""
from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest
from geometry_msgs.msg import Twist

import subsim
import subsim.local
from subsim.bridge import SimBridge
from subsim.mapio import GridMap
from subsim.maps.generate import walled
from subsim.plot import plot_run
from subsim.world import AgentSpec, RobotSpec, World
from subsumption.local import LocalRuntime


class Recorder:
    """Subscribes to topics on a LocalRuntime and keeps (time, message) pairs."""

    def __init__(self, runtime: LocalRuntime, topics: list[str]) -> None:
        self.runtime = runtime
        self.node = runtime.node("recorder")
        self.got: dict[str, list] = defaultdict(list)
        for topic in topics:
            self.node.subscribe(topic, runtime.topics[topic].msg_type,
                                lambda msg, t=topic: self.got[t].append((runtime.now(), msg)))


def driver(runtime: LocalRuntime, topic: str, v: float, w: float, until: float = math.inf) -> None:
    node = runtime.node(f"driver{len(runtime.nodes)}")
    pub = node.publisher(topic, Twist)

    def tick() -> None:
        if runtime.now() < until:
            msg = Twist()
            msg.linear.x, msg.angular.z = v, w
            pub.publish(msg)

    node.call_every(0.1, tick)


TOPICS = ["/scan", "/sonar", "/odom", "/ground_truth", "/tf", "/tf_static", "/map", "/bumper", "/collisions"]


def test_room_topics_frames_and_stamps():
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, subsim.world_path("room"), seed=1)
    rec = Recorder(runtime, TOPICS)
    driver(runtime, "/cmd_vel", 0.5, 0.0)
    runtime.run_for(2.001)  # a hair over, as the timer's period is summed in floating point
    scans = rec.got["/scan"]
    assert len(scans) == 20  # 10 Hz, from 0.1 s on (the one at 0 s came before the recorder subscribed)
    t, scan = scans[-1]
    assert len(scan.ranges) == 541 and scan.header.frame_id == "laser"
    assert scan.header.stamp.to_sec() == pytest.approx(t, abs=1e-6)  # stamped with simulated time
    assert scan.angle_min == pytest.approx(-math.radians(135)) and scan.range_max == 8.0
    sonar = rec.got["/sonar"]
    assert len(sonar) == 12 * 20
    assert [m.header.frame_id for _, m in sonar[-12:]] == [f"sonar_{i}" for i in range(12)]
    assert all(m.radiation_type == m.ULTRASOUND and m.min_range == 0.3 and m.max_range == 3.0
               for _, m in sonar[-12:])
    odom = [m for _, m in rec.got["/odom"]]
    assert odom[-1].header.frame_id == "odom" and odom[-1].child_frame_id == "base_link"
    assert odom[-1].pose.pose.position.x > odom[0].pose.pose.position.x + 0.5
    truth = rec.got["/ground_truth"][-1][1]
    assert truth.header.frame_id == "map"
    assert truth.pose.pose.position.x == pytest.approx(bridge.sim.robots["robot0"].x)
    tf = rec.got["/tf"][-1][1]
    assert [(x.header.frame_id, x.child_frame_id) for x in tf.transforms] == [("map", "odom"), ("odom", "base_link")]
    statics = rec.got["/tf_static"][0][1].transforms
    assert {x.child_frame_id for x in statics} == {"laser"} | {f"sonar_{i}" for i in range(12)}
    sonar3 = next(x for x in statics if x.child_frame_id == "sonar_3").transform
    assert (sonar3.translation.x, sonar3.translation.y) == pytest.approx((0.0, 0.18), abs=1e-9)
    grid = rec.got["/map"][0][1]
    assert (grid.info.width, grid.info.height, len(grid.data)) == (120, 120, 120 * 120)
    assert [m.data for _, m in rec.got["/collisions"]] == [0]
    assert rec.got["/bumper"] == []


def test_bumper_while_in_contact_then_zero_and_latched_collisions():
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, subsim.world_path("room"), seed=1)
    rec = Recorder(runtime, ["/bumper", "/collisions"])
    driver(runtime, "/cmd_vel", 0.7, 0.0, until=9.0)  # 4.6 m to the east wall, then stop pushing
    runtime.run_for(8.0)
    assert bridge.collisions() == {"robot0": 1}
    assert rec.got["/bumper"] and all(m.data == 2 for _, m in rec.got["/bumper"])
    first_contact = rec.got["/bumper"][0][0]
    driver(runtime, "/cmd_vel", -0.3, 0.0)
    runtime.run_for(2.0)
    values = [m.data for _, m in rec.got["/bumper"]]
    assert values[-1] == 0 and values.count(0) == 1
    assert [m.data for _, m in rec.got["/collisions"]] == [0, 1]
    got = []  # a late subscriber still gets the latched count
    runtime.node("late").subscribe("/collisions", runtime.topics["/collisions"].msg_type, got.append)
    runtime.run_for(0.01)
    assert [m.data for m in got] == [1]
    (x, y), = bridge.collision_points()["robot0"]
    assert x == pytest.approx(5.8 - 0.18, abs=0.01) and first_contact < 8.0


def run_two_robots(seed: int):
    grid = walled(10.0, 10.0)
    world = World(GridMap(grid, 0.05, (0.0, 0.0)),
                  [RobotSpec("robot0", "robot0", start=(2.0, 2.0, 0.0), odom_noise=0.02),
                   RobotSpec("robot1", "robot1", start=(8.0, 8.0, math.pi))],
                  [AgentSpec("walker", waypoints=((5.0, 2.0), (5.0, 8.0))),
                   AgentSpec("rover", kind="robot", motion="wander", start=(2.0, 8.0, 0.0))])
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, world, seed=seed)
    rec = Recorder(runtime, ["/robot0/scan", "/robot1/odom", "/agents", "/tf"])
    driver(runtime, "/robot0/cmd_vel", 0.6, 0.3)
    driver(runtime, "/robot1/cmd_vel", 0.4, -0.2)
    runtime.run_for(30.0)
    return bridge, rec


def test_namespaced_robots_agents_and_determinism():
    bridge, rec = run_two_robots(3)
    scan = rec.got["/robot0/scan"][-1][1]
    assert scan.header.frame_id == "robot0/laser"
    assert rec.got["/robot1/odom"][-1][1].child_frame_id == "robot1/base_link"
    agents = rec.got["/agents"][-1][1]
    assert agents.header.frame_id == "map" and len(agents.poses) == 2
    frames = {(x.header.frame_id, x.child_frame_id) for x in rec.got["/tf"][-1][1].transforms}
    assert ("map", "robot1/odom") in frames and ("robot0/odom", "robot0/base_link") in frames
    again, _ = run_two_robots(3)
    other, _ = run_two_robots(4)
    for name in ("robot0", "robot1", "walker", "rover"):
        assert np.array_equal(bridge.sim.history(name), again.sim.history(name))
    assert not np.array_equal(bridge.sim.history("rover"), other.sim.history("rover"))
    assert bridge.trajectories()["robot0"].shape[1] == 2


def test_map_to_odom_composes_to_the_true_pose_with_odometry_noise():
    bridge, rec = run_two_robots(5)
    robot = bridge.sim.robots["robot0"]
    tf = {x.child_frame_id: x.transform for x in rec.got["/tf"][-1][1].transforms}
    m2o, o2b = tf["robot0/odom"], tf["robot0/base_link"]
    yaw = 2 * math.atan2(m2o.rotation.z, m2o.rotation.w)
    x = m2o.translation.x + math.cos(yaw) * o2b.translation.x - math.sin(yaw) * o2b.translation.y
    y = m2o.translation.y + math.sin(yaw) * o2b.translation.x + math.cos(yaw) * o2b.translation.y
    assert (x, y) == pytest.approx((robot.x, robot.y), abs=1e-9)
    assert abs(robot.odom[0] - (robot.x - robot.start[0])) > 1e-6 or abs(robot.odom[1]) > 1e-6  # noise drifts


def test_plot_run_draws_trajectories_and_collisions(tmp_path):
    bridge, _ = run_two_robots(3)
    out = plot_run(bridge.sim.map, bridge.trajectories(), bridge.collision_points(), tmp_path / "run.png",
                   title="two robots")
    assert out.exists() and out.stat().st_size > 10_000
    image = __import__("matplotlib.image", fromlist=["imread"]).imread(out)
    assert image.shape[0] > 300 and image.shape[1] > 300


def test_shipped_room_with_people_runs_and_agents_keep_their_routes(tmp_path):
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, subsim.MAPS / "room_people_world.yaml", seed=2)
    rec = Recorder(runtime, ["/agents", "/scan"])
    driver(runtime, "/cmd_vel", 0.4, 0.35)
    runtime.run_for(60.0)
    person = bridge.sim.history("person")
    assert np.allclose(person[:, 1], 4.8) and person[:, 2].min() >= 1.0 - 1e-9 and person[:, 2].max() <= 3.2 + 1e-9
    assert np.ptp(person[:, 2]) == pytest.approx(2.2)  # it walked the whole segment
    assert len(rec.got["/agents"][-1][1].poses) == 2
    rover = bridge.sim.history("rover")[:, 1:3]
    assert np.all((rover > 0.2 + 0.18 - 1e-9) & (rover < 5.8 - 0.18 + 1e-9))
    out = plot_run(bridge.sim.map, bridge.trajectories(), bridge.collision_points(), tmp_path / "people.png")
    assert out.stat().st_size > 10_000


def test_a_localizing_robot_gets_neither_map_to_odom_nor_the_map():
    """With map_to_odom and publish_map off (a robot running its own localizer or SLAM), the simulator
    publishes only odom -> base_link; the true pose is still on ground_truth for scoring."""
    runtime = LocalRuntime()
    subsim.local.attach(runtime, subsim.world_path("room"), seed=1, map_to_odom=False, publish_map=False)
    assert "/map" not in runtime.topics or runtime.topics["/map"].latched is None
    rec = Recorder(runtime, ["/tf", "/ground_truth"])
    runtime.run_for(0.5)
    frames = {(x.header.frame_id, x.child_frame_id) for _, m in rec.got["/tf"] for x in m.transforms}
    assert frames == {("odom", "base_link")}
    assert rec.got["/ground_truth"]


def test_clock_at_its_own_rate_on_physics_steps():
    """/clock every round(physics / clock_rate)-th physics step (the ROS node's ~clock_rate), each on a step."""
    runtime = LocalRuntime()
    sim = subsim.Simulation(subsim.world_path("room"), seed=1, record=False)
    node = runtime.node("simulator")
    bridge = SimBridge(node, sim, 50.0, 10.0, start_time=0.0, publish_clock=True, clock_rate=25.0)
    node.call_every(bridge.physics_dt, bridge.step)
    rec = Recorder(runtime, ["/clock"])
    runtime.run_for(1.001)
    stamps = [m.clock.to_sec() for _, m in rec.got["/clock"]]
    assert len(stamps) == 25 and np.allclose(np.diff(stamps), 0.04)
    with pytest.raises(ValueError, match="clock 0"):
        SimBridge(runtime.node("other"), sim, 50.0, 10.0, publish_clock=True, clock_rate=0)


def test_camera_rate_overrides_the_worlds_as_a_drivers_data_skip():
    """`camera_rate` (the ROS node's ~camera_rate, patrol.launch's camera_rate:=10) sets every camera's frame rate
    whatever the world file says (a turtlebot's Kinect: 30 Hz); None keeps the world's."""
    counts = {}
    for rate in (None, 10.0):
        runtime = LocalRuntime()
        sim = subsim.Simulation(subsim.MAPS / "pingpong_world.yaml", seed=1, record=False)
        assert sim.robots["robot0"].spec.camera.rate == 30.0
        node = runtime.node("simulator")
        bridge = SimBridge(node, sim, 50.0, 10.0, start_time=0.0, camera_rate=rate)
        node.call_every(bridge.physics_dt, bridge.step)
        rec = Recorder(runtime, ["/camera/depth/image_raw"])
        runtime.run_for(1.001)
        counts[rate] = len(rec.got["/camera/depth/image_raw"])
    assert counts[10.0] in (10, 11) and counts[None] in (30, 31), counts
    with pytest.raises(ValueError, match="camera 0"):
        SimBridge(LocalRuntime().node("other"), sim, 50.0, 10.0, camera_rate=0)
