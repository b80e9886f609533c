"""A synthetic scene for the terminal: real ROS messages on a real graph, for tests, screenshots and benchmarks.

Not a robot and not a simulator: it publishes what a patrol robot's levels would, on the terminal's default
topics, so the terminal can be seen and measured without one. A camera (a room with a person walking across
it, the frame number and time drawn in), the tracked box round the person, a map of a ping-pong room, the
robot going round four patrol goals (tf ``map -> base_link`` and ``amcl_pose``), the plan to the next goal,
the target in the map, an alarm raised and cleared every few seconds, and optionally a constant motor command
standing for the robot's own levels (``--drive TOPIC``). Header stamps are ROS time (the wall clock unless
``/use_sim_time``), which is what the page's frame latency is measured against.

With ``--record FILE`` it also writes every message of the given topics as a JSON line
(``{"topic", "t": wall time, "msg"}``): how tests and benchmarks see what the terminal published.

    python -m terminal.scene --rate 15 --size 640x480 --drive patrol_cmd_vel --record out.jsonl
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import threading
import time
from typing import Any

import cv2
import numpy as np
import rospy
import roslib.message
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (Point, PointStamped, Pose, PoseArray, PoseStamped, PoseWithCovarianceStamped,
                               TransformStamped, Twist)
from nav_msgs.msg import MapMetaData, OccupancyGrid, Path
from sensor_msgs.msg import RegionOfInterest
from std_msgs.msg import Header

from subsumption import images
from subsumption.planar import quaternion

from .convert import dumps, to_json

ROOM = (10.0, 7.0)           # metres, the ping-pong room
TABLE = (4.0, 2.8, 6.0, 4.2)  # x0, y0, x1, y1
GOALS = [(1.5, 1.5), (8.5, 1.5), (8.5, 5.5), (1.5, 5.5)]
RECORD_DEFAULT = ("terminal/cmd_vel:geometry_msgs/Twist,terminal/target:sensor_msgs/RegionOfInterest,"
                  "terminal/stop:std_msgs/Empty,terminal/release:std_msgs/Empty,cmd_vel:geometry_msgs/Twist")


def room_map(resolution: float = 0.05) -> OccupancyGrid:
    """The room as an occupancy grid: walls, the table, a little unknown outside."""
    margin = 0.5
    cols, rows = int((ROOM[0] + 2 * margin) / resolution), int((ROOM[1] + 2 * margin) / resolution)
    grid = np.full((rows, cols), -1, dtype=np.int8)
    cell = lambda x, y: (int((y + margin) / resolution), int((x + margin) / resolution))  # noqa: E731
    (r0, c0), (r1, c1) = cell(0, 0), cell(*ROOM)
    grid[r0:r1, c0:c1] = 0
    wall = max(2, int(0.1 / resolution))
    grid[r0:r0 + wall, c0:c1] = grid[r1 - wall:r1, c0:c1] = 100
    grid[r0:r1, c0:c0 + wall] = grid[r0:r1, c1 - wall:c1] = 100
    (t0, u0), (t1, u1) = cell(TABLE[0], TABLE[1]), cell(TABLE[2], TABLE[3])
    grid[t0:t1, u0:u1] = 100
    msg = OccupancyGrid()
    msg.header.frame_id = "map"
    msg.info = MapMetaData(resolution=resolution, width=cols, height=rows)
    msg.info.origin.position = Point(-margin, -margin, 0.0)
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.ravel().tolist()
    return msg


def robot_at(t: float, speed: float = 0.4) -> tuple[float, float, float, int]:
    """The robot's (x, y, yaw, next goal) going round the goals at `speed` m/s."""
    legs = [(GOALS[i], GOALS[(i + 1) % len(GOALS)]) for i in range(len(GOALS))]
    lengths = [math.dist(a, b) for a, b in legs]
    s = (t * speed) % sum(lengths)
    for i, ((a, b), length) in enumerate(zip(legs, lengths)):
        if s <= length:
            f = s / length
            return a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), math.atan2(b[1] - a[1], b[0] - a[0]), \
                (i + 1) % len(GOALS)
        s -= length
    return (*GOALS[0], 0.0, 1)


class Camera:
    """Frames of a room with a person walking to and fro; the person's box is what a tracker would report."""

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = width, height
        background = np.zeros((height, width, 3), np.uint8)
        horizon = int(height * 0.45)
        background[:horizon] = (70, 78, 92)        # wall (BGR)
        background[horizon:] = (52, 86, 110)       # floor
        for x in range(0, width, max(8, width // 12)):
            cv2.line(background, (x, horizon), (int(width / 2 + (x - width / 2) * 3), height), (44, 72, 94), 1)
        cv2.rectangle(background, (int(width * .08), int(height * .12)), (int(width * .3), int(height * .38)),
                      (120, 140, 150), -1)  # a window
        self.background = background

    def frame(self, index: int, t: float) -> tuple[np.ndarray, RegionOfInterest]:
        """Frame `index` of the synthetic camera at time `t`: the image and the box of the person in it."""
        w, h = self.width, self.height
        image = self.background.copy()
        cx = int(w * (0.5 + 0.35 * math.sin(t * 0.6)))
        body_h = int(h * 0.45)
        body_w = int(body_h * 0.38)
        top = int(h * 0.35)
        cv2.rectangle(image, (cx - body_w // 2, top + body_h // 4), (cx + body_w // 2, top + body_h), (60, 60, 170), -1)
        cv2.circle(image, (cx, top + body_h // 8), body_h // 8, (150, 180, 225), -1)
        cv2.putText(image, f"frame {index}  t={t:7.2f}", (8, h - 10), cv2.FONT_HERSHEY_SIMPLEX, max(0.35, w / 1100),
                    (240, 240, 240), 1, cv2.LINE_AA)
        roi = RegionOfInterest(x_offset=max(0, cx - body_w // 2 - 4), y_offset=max(0, top - 4),
                               width=body_w + 8, height=body_h + 8)
        return image[:, :, ::-1], roi  # RGB


class Recorder:
    """Writes every message of some topics as a JSON line with its wall-clock arrival time."""

    def __init__(self, path: str, topics: list[tuple[str, str]]) -> None:
        self.file = open(path, "a", buffering=1, encoding="utf-8")
        self.lock = threading.Lock()
        self.keep = [rospy.Subscriber(name, roslib.message.get_message_class(type_name), self._write,
                                      callback_args=rospy.resolve_name(name), queue_size=1000, tcp_nodelay=True)
                     for name, type_name in topics]

    def _write(self, msg: Any, topic: str) -> None:
        arrived = time.time()
        line = dumps({"topic": topic, "t": arrived, "msg": to_json(msg)})
        with self.lock:
            self.file.write(line + "\n")


def read_records(path: str | os.PathLike, topic: str, since: float = 0.0) -> list[dict]:
    """The messages a :class:`Recorder` wrote to `path` from `topic` that arrived at `since` (wall clock, s) or
    later, oldest first: ``{"topic", "t", "msg"}`` each. A line still being written is skipped."""
    out = []
    with open(path, encoding="utf-8") as file:
        lines = file.read().splitlines()
    for line in lines:
        try:
            item = json.loads(line)
        except ValueError:
            continue  # a line being written
        if item["topic"] == topic and item["t"] >= since:
            out.append(item)
    return out


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The options of ``python -m terminal.scene``."""
    parser = argparse.ArgumentParser(prog="python -m terminal.scene", description=__doc__.split("\n\n")[0])
    parser.add_argument("--rate", type=float, default=15.0, help="camera frames a second")
    parser.add_argument("--size", default="320x240", help="camera frame size WxH")
    parser.add_argument("--raw", action="store_true", help="publish raw sensor_msgs/Image on camera/rgb/image_raw")
    parser.add_argument("--quality", type=int, default=80, help="JPEG quality")
    parser.add_argument("--drive", default="",
                        help="also publish a constant Twist at 10 Hz here (the robot's own levels)")
    parser.add_argument("--alarm-period", type=float, default=6.0, help="seconds between raised alarms")
    parser.add_argument("--record", default="", help="write messages of --record-topics to this JSON-lines file")
    parser.add_argument("--record-topics", default=RECORD_DEFAULT, help="NAME:TYPE,... to record")
    parser.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0: never)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """``python -m terminal.scene``: publish the synthetic scene (camera, map, pose) for the terminal; exit status 2 on
    bad options."""
    args = parse_args(rospy.myargv(sys.argv if argv is None else argv)[1:])
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        print(f"terminal.scene: error: --size {args.size!r} is not WIDTHxHEIGHT", file=sys.stderr)
        return 2
    rospy.init_node("scene", anonymous=True)
    if args.record:
        pairs = [item.split(":", 1) for item in args.record_topics.split(",") if item]
        Recorder(args.record, [(name, type_name) for name, type_name in pairs])
    latched = dict(queue_size=1, latch=True)
    if args.raw:
        camera_pub = rospy.Publisher("camera/rgb/image_raw", roslib.message.get_message_class("sensor_msgs/Image"),
                                     queue_size=2)
    else:
        camera_pub = rospy.Publisher("camera/rgb/image_raw/compressed",
                                     roslib.message.get_message_class("sensor_msgs/CompressedImage"), queue_size=2)
    box_pub = rospy.Publisher("track/box", RegionOfInterest, queue_size=2)
    map_pub = rospy.Publisher("/map", OccupancyGrid, **latched)
    goals_pub = rospy.Publisher("patrol/goals", PoseArray, **latched)
    plan_pub = rospy.Publisher("move_base/plan", Path, queue_size=2)
    amcl_pub = rospy.Publisher("amcl_pose", PoseWithCovarianceStamped, queue_size=2)
    target_pub = rospy.Publisher("target_pose", PointStamped, queue_size=2)
    alarm_pub = rospy.Publisher("alarm", DiagnosticArray, queue_size=10)
    drive_pub = rospy.Publisher(args.drive, Twist, queue_size=10) if args.drive else None
    tf = tf2_ros.TransformBroadcaster()

    map_pub.publish(room_map())
    goals = PoseArray(header=Header(frame_id="map"))
    goals.poses = [Pose(position=Point(x, y, 0), orientation=quaternion(0)) for x, y in GOALS]
    goals_pub.publish(goals)

    camera = Camera(width, height)
    start = time.monotonic()
    period = 1.0 / args.rate
    next_frame = start
    index = 0
    ticks = 0
    alarm_raised = False
    while not rospy.is_shutdown():
        wall = time.monotonic()
        t = wall - start
        if args.duration and t > args.duration:
            break
        stamp = rospy.Time.now()
        header = Header(stamp=stamp, frame_id="camera_rgb_optical_frame")
        rgb, roi = camera.frame(index, t)
        if args.raw:
            camera_pub.publish(images.from_array(np.ascontiguousarray(rgb), "rgb8", header))
        else:
            camera_pub.publish(images.compressed_jpeg(rgb, header, args.quality))
        box_pub.publish(roi)
        index += 1
        # the slower things, at about 10 Hz whatever the frame rate
        if int(t * 10) != ticks:
            ticks = int(t * 10)
            x, y, yaw, goal = robot_at(t)
            transform = TransformStamped(header=Header(stamp=stamp, frame_id="map"), child_frame_id="base_link")
            transform.transform.translation.x, transform.transform.translation.y = x, y
            transform.transform.rotation = quaternion(yaw)
            tf.sendTransform(transform)
            if drive_pub is not None:
                drive = Twist()
                drive.linear.x = 0.2
                drive_pub.publish(drive)
            if ticks % 5 == 0:
                amcl = PoseWithCovarianceStamped(header=Header(stamp=stamp, frame_id="map"))
                amcl.pose.pose = Pose(position=Point(x, y, 0), orientation=quaternion(yaw))
                amcl_pub.publish(amcl)
                plan = Path(header=Header(stamp=stamp, frame_id="map"))
                gx, gy = GOALS[goal]
                steps = max(2, int(math.dist((x, y), (gx, gy)) / 0.1))
                plan.poses = [PoseStamped(header=plan.header, pose=Pose(
                    position=Point(x + (gx - x) * i / steps, y + (gy - y) * i / steps, 0),
                    orientation=quaternion(0))) for i in range(steps + 1)]
                plan_pub.publish(plan)
                person_x = 5.0 + 3.0 * math.sin(t * 0.6)
                target_pub.publish(PointStamped(header=Header(stamp=stamp, frame_id="map"),
                                                point=Point(person_x, 5.0, 0)))
            phase = t % args.alarm_period
            should_raise = phase < args.alarm_period / 2
            if should_raise != alarm_raised:
                alarm_raised = should_raise
                status = DiagnosticStatus(
                    level=DiagnosticStatus.WARN if should_raise else DiagnosticStatus.OK, name="intruder",
                    message="a person where none should be" if should_raise else "gone",
                    values=[KeyValue("x", f"{5.0 + 3.0 * math.sin(t * 0.6):.2f}"), KeyValue("y", "5.00")])
                alarm_pub.publish(DiagnosticArray(header=Header(stamp=stamp), status=[status]))
        next_frame += period
        delay = next_frame - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            next_frame = time.monotonic()
    return 0


if __name__ == "__main__":
    sys.exit(main())
