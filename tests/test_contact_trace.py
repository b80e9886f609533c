"""The run recorder's trace of each contact (metrics.json's ``contacts``): when and where, whose command the motor
line passed to the base (down the arbiters from the base, as their ~status says), and where the nearest person was
for the camera. Fed on the patrol network's real wiring and topics, in-process."""
from __future__ import annotations

import math

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import Pose, PoseArray, Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool, UInt32

from experiments.recorder import CameraView, RunRecorder
from experiments.runner import ROBOTS
from subsim.world import CameraSpec
from subsumption import LocalRuntime
from subsumption.network import load
from subsumption.network.wiring import wire


def test_a_contact_names_who_drove_and_where_the_person_was_for_the_camera():
    wiring = wire(load(ROBOTS["patrol"]), 3)
    runtime = LocalRuntime()
    kinect = CameraSpec()  # the TurtleBot's, as the runner passes it from the world file
    recorder = RunRecorder(runtime.node("recorder"), wiring, agent_names=["grace", "eileen"],
                           agent_radii=[0.25, 0.25],
                           camera=CameraView(kinect.x, kinect.yaw, math.radians(kinect.hfov_deg), kinect.min_range))
    node = runtime.node("scene")
    arbiter = wiring.arbiter("navigation_drives")
    truth = node.publisher("/ground_truth", Odometry)
    agents = node.publisher("/agents", PoseArray)
    status = node.publisher(f"/{arbiter.name}/status", DiagnosticStatus)
    drive = node.publisher(f"/{arbiter.upper}", Twist)
    collisions = node.publisher("/collisions", UInt32)

    def scene(person_x: float, person_y: float, count: int) -> None:
        odom = Odometry()
        odom.pose.pose.position.x, odom.pose.pose.position.y = 1.0, 1.0
        odom.pose.pose.orientation.w = 1.0  # facing +x
        truth.publish(odom)
        near, far = Pose(), Pose()
        near.position.x, near.position.y = person_x, person_y
        far.position.x, far.position.y = 9.0, 9.0
        agents.publish(PoseArray(poses=[far, near]))
        status.publish(DiagnosticStatus(values=[KeyValue("in_control", "upper")]))
        twist = Twist()
        twist.linear.x, twist.angular.z = 0.3, -0.5
        drive.publish(twist)
        collisions.publish(UInt32(count))

    node.call_later(0.5, lambda: scene(1.44, 1.0, 1))   # straight ahead, 0.44 m: too near to see
    node.call_later(1.0, lambda: scene(1.0, 1.44, 2))   # beside, left
    runtime.run_for(1.5)
    first, second = recorder.contacts
    assert first["driver"] == "move_base" and (first["v"], first["w"]) == (0.3, -0.5)
    assert first["nearest"] == "eileen" and first["camera"] == "near" and first["with"] == "agent"
    assert (first["x"], first["y"], first["t"]) == (1.0, 1.0, 0.5)
    assert second["camera"] == "beside" and abs(second["bearing_deg"]) > 28.5


def test_the_recorder_takes_every_level_of_the_patrol_network():
    """Level 4 puts an inhibitor on the motor line whose upper line is pursuit's Bool `stop`: the recorder hears
    only Twist commands (it once subscribed to pursuit/stop as a Twist, and every level-4 run failed at start)."""
    inhibitors = 0
    for level in range(6):
        wiring = wire(load(ROBOTS["patrol"]), level)
        runtime = LocalRuntime()
        RunRecorder(runtime.node("recorder"), wiring)
        node = runtime.node("pursuit")
        for arbiter in wiring.arbiters:
            if arbiter.kind == "inhibitor" and arbiter.line_type == "geometry_msgs/Twist":
                node.publisher(f"/{arbiter.upper}", Bool)  # raises TopicTypeError if the recorder took it for a Twist
                inhibitors += 1
    assert inhibitors >= 2  # levels 4 and 5 have the stop


def test_a_robot_without_a_camera_gets_no_camera_label():
    """The wander robot (sonars and a laser) has no camera: its contacts say where the person was, not where a
    Kinect it does not have would have seen them."""
    wiring = wire(load(ROBOTS["wander"]), 0)
    runtime = LocalRuntime()
    recorder = RunRecorder(runtime.node("recorder"), wiring, agent_names=["p"], agent_radii=[0.25])
    node = runtime.node("scene")
    truth = node.publisher("/ground_truth", Odometry)
    agents = node.publisher("/agents", PoseArray)
    collisions = node.publisher("/collisions", UInt32)

    def scene() -> None:
        odom = Odometry()
        odom.pose.pose.orientation.w = 1.0
        truth.publish(odom)
        person = Pose()
        person.position.y = 0.43  # to the left, touching
        agents.publish(PoseArray(poses=[person]))
        collisions.publish(UInt32(1))

    node.call_later(0.5, scene)
    runtime.run_for(1.0)
    (contact,) = recorder.contacts
    assert "camera" not in contact and contact["nearest"] == "p" and contact["bearing_deg"] == 90.0
