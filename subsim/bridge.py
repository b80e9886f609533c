"""Connects a :class:`~subsim.sim.Simulation` to topics through the core's NodeHandle, and nothing else.

Because it only uses the NodeHandle API, the same bridge runs in the in-process LocalRuntime (lockstep with
the modules, reproducible) and under ROS (see :mod:`subsim.ros_node`). Whoever owns the clock calls
:meth:`SimBridge.step` once per physics period; the bridge advances the physics and publishes each sensor
when it is due, stamped with simulated time.

Topics, for a robot whose namespace is ``ns`` (``""`` puts them at the root):

=====================  ==========================  ===========================================
``/ns/cmd_vel``        geometry_msgs/Twist (in)    linear.x, angular.z; none for 0.5 s -> stop
``/ns/odom``           nav_msgs/Odometry           ns/odom -> ns/base_link, sensor rate
``/ns/ground_truth``   nav_msgs/Odometry           true pose in frame map, sensor rate
``/ns/scan``           sensor_msgs/LaserScan       frame ns/laser, sensor rate
``/ns/sonar``          sensor_msgs/Range           12 messages a sweep, frames ns/sonar_<i>
``/ns/bumper``         std_msgs/UInt8              1 left, 2 centre, 4 right; every physics step
                                                   while in contact, then one 0 when it ends
``/ns/collisions``     std_msgs/UInt32 (latched)   count of new contacts, on change
``/tf``                tf2_msgs/TFMessage          map -> ns/odom (unless ``map_to_odom`` is off) and
                                                   ns/odom -> ns/base_link
``/tf_static``         tf2_msgs/TFMessage (latch)  ns/base_link -> ns/laser, ns/sonar_<i>
``/map``               nav_msgs/OccupancyGrid      latched, frame map (unless ``publish_map`` is off)
``/agents``            geometry_msgs/PoseArray     agents' poses, frame map (empty if none)
``/clock``             rosgraph_msgs/Clock         only when publish_clock (the ROS node), every
                                                   physics step or at ``clock_rate``
=====================  ==========================  ===========================================

A robot whose ``kind`` is ``turtlebot2`` or ``turtlebot3`` poses as that robot's driver instead: its topic names,
message types (kobuki_msgs events), rates and frames are those of :mod:`subsim.drivers`, and it advertises only the
sensors it has (``ground_truth`` and ``collisions`` stay, for scoring).

A robot with a camera (a TurtleBot's Kinect) also has, like an openni driver, at the camera's rate:

======================================  ========================  =========================================
``/ns/camera/rgb/image_raw``            sensor_msgs/Image         rgb8, frame ns/camera_rgb_optical_frame
``/ns/camera/rgb/image_raw/compressed`` sensor_msgs/CompressedImage  JPEG (unless the spec turns it off)
``/ns/camera/rgb/camera_info``          sensor_msgs/CameraInfo    K, P of the pinhole
``/ns/camera/depth/image_raw``          sensor_msgs/Image         16UC1 mm (0: no reading; OpenNI's) or
                                                                  32FC1 m (NaN), the spec's depth_encoding;
                                                                  registered to rgb; depth_band: the band only
``/ns/camera/depth/camera_info``        sensor_msgs/CameraInfo    the same pinhole (cropped to the band)
======================================  ========================  =========================================

and in ``/tf_static`` ns/base_link -> ns/camera_link -> ns/camera_{rgb,depth}_frame -> ..._optical_frame.
Frames are due every 1/rate s of simulated time and fall on physics steps (30 Hz at 50 Hz physics: 20 or 40 ms
apart, 30 a second on average).
A robot that localizes itself (a particle filter publishing ``map -> odom``) or builds its own map (SLAM
publishing ``/map``) runs with ``map_to_odom=False`` and ``publish_map=False``: the simulator then tells it
nothing it could not sense, and its true pose stays on ``ground_truth``, for scoring only.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import cv2
import numpy as np
from geometry_msgs.msg import PoseArray, Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, LaserScan, Range
from std_msgs.msg import UInt8, UInt32
from tf2_msgs.msg import TFMessage

from subsumption import kobuki
from subsumption.images import compressed_jpeg, from_array
from subsumption.runtime import NodeHandle, Publisher

from . import messages as msgs
from .bodies import Robot
from .camera import depth_pixels
from .drivers import KOBUKI, Driver, driver
from .sim import Simulation


@dataclass
class _RobotTopics:
    robot: Robot
    frames: msgs.Frames
    odom: Publisher
    ground_truth: Publisher
    scan: Publisher | None
    sonar: Publisher | None
    bumper: Publisher | None
    collisions: Publisher
    named: Driver
    touching: bool = False
    last_collisions: int = 0
    camera: "_CameraTopics | None" = None
    cliff: Publisher | None = None  # a Kobuki's events: the world's cliffs under its cliff sensors ...
    wheel_drop: Publisher | None = None  # ... and its wheels dropping while it is lifted
    bumper_bits: int = 0  # the bitmask last reported as events (a Kobuki)
    cliff_bits: int = 0  # the cliff sensors last reported over a cliff (bit i: sensor i)
    dropped: bool = False  # the wheels last reported dropped
    odom_due: float = 0.0  # simulated time the next odometry and laser are due (a posing kind's own rates)
    scan_due: float = 0.0


@dataclass
class _CameraTopics:
    rgb: Publisher
    compressed: Publisher
    rgb_info: Publisher
    depth: Publisher
    depth_info: Publisher
    period: float
    next_due: float = 0.0
    frames: int = 0


def topic_prefix(namespace: str) -> str:
    """'/robot0/' for namespace 'robot0', '/' for the root namespace ''."""
    return f"/{namespace}/" if namespace else "/"


class SimBridge:
    """Publishes a Simulation's sensors and takes its commands over a NodeHandle's topics."""

    def __init__(self, node: NodeHandle, sim: Simulation, physics_rate: float = 50.0, sensor_rate: float = 10.0,
                 start_time: float | None = None, publish_clock: bool = False, map_to_odom: bool = True,
                 publish_map: bool = True, clock_rate: float | None = None,
                 camera_rate: float | None = None) -> None:
        if not (physics_rate > 0 and sensor_rate > 0) or any(
                rate is not None and not rate > 0 for rate in (clock_rate, camera_rate)):
            raise ValueError(f"rates must be > 0, got physics {physics_rate!r}, sensors {sensor_rate!r}, "
                             f"clock {clock_rate!r}, camera {camera_rate!r}")
        self.node, self.sim = node, sim
        # every camera's frame rate, as a driver's own setting gives it (openni's data_skip); None: each camera's
        # rate in the world file
        self.camera_rate = camera_rate
        self.physics_dt = 1.0 / physics_rate
        # sensors every n-th physics step, so their times fall exactly on physics steps
        self.sensor_every = max(1, round(physics_rate / sensor_rate))
        # /clock every n-th step (None: every step). Every node of a graph on simulated time reads /clock and
        # wakes each of its timer threads for it: at 50 Hz to ~36 nodes that was about half a core of a 2-core
        # machine (bench/clock_cost); Gazebo and stage publish it at a rate of their own too.
        self.clock_every = 1 if clock_rate is None else max(1, round(physics_rate / clock_rate))
        self.sensor_period = self.sensor_every * self.physics_dt
        self.start_time = node.now() if start_time is None else float(start_time)
        self.ticks = 0
        self.map_to_odom = map_to_odom
        self._pending: dict[str, tuple[float, float]] = {}  # commands received since the last step
        self._lock = threading.Lock()  # under ROS, commands arrive on subscriber threads
        self._clock = node.publisher("/clock", Clock) if publish_clock else None
        self._tf = node.publisher("/tf", TFMessage)
        self._agents = node.publisher("/agents", PoseArray)
        self.robots = [self._connect(robot) for robot in sim.robots.values()]
        statics = [t for rt in self.robots for t in
                   msgs.static_tf(rt.robot, rt.frames, sim.geometry[rt.robot.name].sonar_mounts)
                   + msgs.camera_static_tf(rt.robot, rt.frames)]
        node.publisher("/tf_static", TFMessage, latch=True).publish(msgs.tf_message(statics))
        if publish_map:
            node.publisher("/map", OccupancyGrid, latch=True).publish(msgs.occupancy_grid(self.time, sim.map))
        for rt in self.robots:
            rt.collisions.publish(msgs.collisions(rt.robot.collisions))
        self._publish_sensors()
        self._publish_cameras()

    def _connect(self, robot: Robot) -> _RobotTopics:
        ns = topic_prefix(robot.spec.namespace)
        node = self.node
        node.subscribe(ns + driver(robot.spec.kind).cmd_vel, Twist,
                       lambda msg, name=robot.name: self._command(name, msg))
        camera = None
        if robot.spec.camera is not None:
            cam = ns + "camera/"
            camera = _CameraTopics(
                # raw images: only the newest waits for a slow connection (a backlog of old frames helps nobody)
                rgb=node.publisher(cam + "rgb/image_raw", Image, latest=True),
                compressed=node.publisher(cam + "rgb/image_raw/compressed", CompressedImage),
                rgb_info=node.publisher(cam + "rgb/camera_info", CameraInfo),
                depth=node.publisher(cam + "depth/image_raw", Image, latest=True),
                depth_info=node.publisher(cam + "depth/camera_info", CameraInfo),
                period=1.0 / (self.camera_rate or robot.spec.camera.rate), next_due=self.sim.time)
        named = driver(robot.spec.kind)
        bumper_type = kobuki.BumperEvent if named.bumper_style == KOBUKI else UInt8
        return _RobotTopics(
            robot, msgs.Frames.of(robot.spec),
            odom=node.publisher(ns + named.odom, Odometry),
            ground_truth=node.publisher(ns + "ground_truth", Odometry),
            # a real robot's driver advertises only the sensors it has (the project's own kinds: all, as always)
            scan=node.publisher(ns + named.scan, LaserScan) if robot.spec.laser or named.own_names else None,
            sonar=node.publisher(ns + named.sonar, Range) if robot.spec.sonar or named.own_names else None,
            bumper=node.publisher(ns + named.bumper, bumper_type) if named.bumper else None,
            collisions=node.publisher(ns + "collisions", UInt32, latch=True), camera=camera, named=named,
            cliff=node.publisher(ns + named.cliff, kobuki.CliffEvent) if named.cliff else None,
            wheel_drop=node.publisher(ns + named.wheel_drop, kobuki.WheelDropEvent) if named.wheel_drop else None,
            odom_due=self.sim.time, scan_due=self.sim.time)

    def _command(self, robot: str, msg: Twist) -> None:
        # Applied at the next step, so that physics and commands never interleave (under ROS this runs on a
        # subscriber thread).
        with self._lock:
            self._pending[robot] = (msg.linear.x, msg.angular.z)

    @property
    def time(self) -> float:
        """The simulated time the published messages carry (start_time + time simulated so far)."""
        return self.start_time + self.sim.time

    def step(self) -> None:
        """Advance the physics by one period, then publish what is due at the new time."""
        with self._lock:
            pending, self._pending = self._pending, {}
        for robot, (v, w) in pending.items():
            self.sim.set_command(robot, v, w)
        self.sim.step(self.physics_dt)
        self.ticks += 1
        t = self.time
        if self._clock is not None and self.ticks % self.clock_every == 0:
            self._clock.publish(msgs.clock(t))
        for rt in self.robots:
            self._publish_bumper(rt)
            self._publish_floor(rt)
            if rt.robot.collisions != rt.last_collisions:
                rt.last_collisions = rt.robot.collisions
                rt.collisions.publish(msgs.collisions(rt.robot.collisions))
        self._publish_sensors(sensor_tick=self.ticks % self.sensor_every == 0)
        self._publish_cameras()

    @staticmethod
    def _publish_bumper(rt: _RobotTopics) -> None:
        """A bitmask every physics step while in contact and one 0 when it ends; or, as a Kobuki does, one
        BumperEvent per bumper whose state changed."""
        if rt.bumper is None:
            return
        bits = rt.robot.bumper if rt.robot.in_contact else 0
        if rt.named.bumper_style == KOBUKI:
            for event in kobuki.bumper_events(rt.bumper_bits, bits):
                rt.bumper.publish(event)
            rt.bumper_bits = bits
        elif rt.robot.in_contact:
            rt.bumper.publish(msgs.bumper(rt.robot.bumper))
            rt.touching = True
        elif rt.touching:  # contact just ended
            rt.bumper.publish(msgs.bumper(0))
            rt.touching = False

    def _publish_floor(self, rt: _RobotTopics) -> None:
        """A Kobuki's cliff and wheel-drop events, one per sensor that changed, as its driver sends them: a cliff
        sensor over one of the world's cliffs reports CLIFF (``bottom``, the sensor's raw reading, is not modelled:
        0), and both wheels report DROPPED while the robot is lifted."""
        if rt.cliff is not None and rt.named.cliff_sensors:
            robot = rt.robot
            c, s = math.cos(robot.theta), math.sin(robot.theta)
            bits = 0
            if not robot.lifted:  # held up, every sensor sees far floor; the driver's wheel drops say why
                for i, (x, y) in enumerate(rt.named.cliff_sensors):
                    if self.sim.over_cliff(robot.x + c * x - s * y, robot.y + s * x + c * y):
                        bits |= 1 << i
            for i in range(len(rt.named.cliff_sensors)):
                if (bits ^ rt.cliff_bits) & (1 << i):
                    rt.cliff.publish(kobuki.CliffEvent(
                        sensor=i, state=kobuki.CliffEvent.CLIFF if bits & (1 << i) else kobuki.CliffEvent.FLOOR,
                        bottom=0))
            rt.cliff_bits = bits
        if rt.wheel_drop is not None and rt.robot.lifted != rt.dropped:
            rt.dropped = rt.robot.lifted
            state = kobuki.WheelDropEvent.DROPPED if rt.dropped else kobuki.WheelDropEvent.RAISED
            for wheel in (kobuki.WheelDropEvent.LEFT, kobuki.WheelDropEvent.RIGHT):
                rt.wheel_drop.publish(kobuki.WheelDropEvent(wheel=wheel, state=state))

    def _publish_cameras(self) -> None:
        """Render and publish each camera whose frame is due (same world state as the other sensors now).

        Only what someone reads is made: the colour image is rendered only while the RGB image or its JPEG has
        a subscriber, the JPEG encoded only while it has one, the depth image converted only while it has one
        (a camera driver's lazy publishing, as openni's). Depth is always rendered: colour is shaded from it,
        and its noise draws from the simulation's generator, which must not depend on who watches."""
        now = self.sim.time
        for rt in self.robots:
            cam = rt.camera
            if cam is None or now < cam.next_due - 1e-9:
                continue
            cam.next_due = max(cam.next_due + cam.period, now + 0.5 * cam.period)  # never a burst after a stall
            cam.frames += 1
            want_jpeg = rt.robot.spec.camera.compressed and cam.compressed.has_subscribers()
            want_rgb = want_jpeg or cam.rgb.has_subscribers()
            frame = self.sim.render(rt.robot.name, rgb=want_rgb)
            camera = self.sim.camera(rt.robot.name)
            when = msgs.stamp(self.time)
            rgb_header = msgs.header(when, rt.frames.rgb_optical)
            depth_header = msgs.header(when, rt.frames.depth_optical)
            pinhole = camera.pinhole
            if frame.rgb is not None:
                cam.rgb_info.publish(msgs.camera_info(when, rt.frames.rgb_optical, pinhole))  # info first: a
                cam.rgb.publish(from_array(frame.rgb, "rgb8", rgb_header))  # reader of the image has it already
                if want_jpeg:
                    # handed as the RGB view of a BGR copy, so that the encoder's own flip to BGR costs nothing
                    bgr = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR)
                    cam.compressed.publish(compressed_jpeg(bgr[:, :, ::-1], rgb_header))
            depth_pinhole = pinhole.cropped(frame.row0, frame.row0 + frame.depth.shape[0])
            cam.depth_info.publish(msgs.camera_info(when, rt.frames.depth_optical, depth_pinhole))
            encoding = rt.robot.spec.camera.depth_encoding
            if cam.depth.has_subscribers():
                cam.depth.publish(from_array(depth_pixels(frame.depth, encoding), encoding, depth_header))

    def _publish_sensors(self, sensor_tick: bool = True) -> None:
        """Each robot's ranges, odometry and tf: the project's own kinds on sensor ticks, a kind posing as a real
        robot at its driver's own rates (odometry and laser each when due)."""
        t, now = self.time, self.sim.time
        transforms = []
        for rt in self.robots:
            robot, spec, named = rt.robot, rt.robot.spec, rt.named
            if named.own_names:
                odom_due = scan_due = sensor_tick
                scan_period = self.sensor_period
            else:
                odom_due, rt.odom_due = self._due(rt.odom_due, named.odom_rate, sensor_tick, now)
                scan_due, rt.scan_due = self._due(rt.scan_due, named.scan_rate, sensor_tick, now)
                scan_period = 1.0 / named.scan_rate if named.scan_rate else self.sensor_period
            if scan_due and (spec.laser is not None or spec.sonar is not None):
                reading = self.sim.sense(robot.name)
                if spec.laser is not None:
                    rt.scan.publish(msgs.laser_scan(t, rt.frames, spec.laser, reading.laser, scan_period,
                                                    named.zero_no_return))
                if spec.sonar is not None:
                    for msg in msgs.sonar_ranges(t, rt.frames, spec.sonar, reading.sonar):
                        rt.sonar.publish(msg)
            if odom_due:
                rt.odom.publish(msgs.robot_odometry(t, robot, rt.frames))
                rt.ground_truth.publish(msgs.ground_truth(t, robot, rt.frames))
                transforms += msgs.robot_tf(t, robot, rt.frames, self.map_to_odom)
        if transforms:
            self._tf.publish(msgs.tf_message(transforms))
        if sensor_tick:
            self._agents.publish(msgs.agents(t, list(self.sim.agents.values())))

    def _due(self, due: float, rate: float | None, sensor_tick: bool, now: float) -> tuple[bool, float]:
        """(whether a stream at `rate` Hz is due now, its next due time); None: on sensor ticks."""
        if rate is None:
            return sensor_tick, due
        if now < due - 1e-9:
            return False, due
        period = 1.0 / rate
        return True, max(due + period, now + 0.5 * period)  # never a burst after a stall

    # What experiments read afterwards ----------------------------------------------------------------
    def trajectories(self) -> dict[str, np.ndarray]:
        return self.sim.trajectories()

    def collisions(self) -> dict[str, int]:
        return self.sim.collisions()

    def collision_points(self) -> dict[str, list[tuple[float, float]]]:
        return self.sim.collision_points()
