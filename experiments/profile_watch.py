"""Watching the patrol robot on a robot profile as the patrol experiment watches its own runs.

``roslaunch subsumption patrol.launch robot:=turtlebot2 ...`` runs the network in a namespace (``/patrol``) against
a robot that is already up; when that robot is the simulator posing as one, its ground truth can score the run.
This node listens with the experiment's own observers (:class:`experiments.patrol.PatrolObserver`: move_base's
goals and results, the alarms; :class:`experiments.patrol_vision.VisionObserver`: detect's alarms and boxes,
track, follow, pursuit, the ground truth), their names remapped into the namespace, so that a run on a profile is
judged by the same code as ``subsumption run patrol`` (``score``, ``rescore``). Listening only: it publishes
nothing and drives nothing.

    python -m experiments.profile_watch UNTIL [--goals FILE] [--ns /patrol] [--vision] [--after-alarm S]
                                              [--after-goal S] [--cliffs] [--base-cmd /mobile_base/commands/velocity]
                                              [--operator SCRIPT --url-file FILE]

It registers as ``/watcher``, sets ``/use_sim_time`` (only the simulator has a ground truth), and listens until
simulated time UNTIL, or, with ``--after-alarm S``, until S simulated seconds after the first intruder alarm (a run
need not go on once its scene has happened), with ``--after-goal S`` until S simulated seconds after move_base
first reported a goal reached (SUCCEEDED), or a wall-clock deadline. Then it prints one JSON line: ``t`` (the
last ground truth's time), ``collisions``, ``path`` ([t, x, y, yaw] of the ground truth), ``patrol`` (the
PatrolObserver's metrics), ``sent`` (its goals sent), with ``--vision`` ``vision`` (the VisionObserver's
record: ``VisionObserver.from_record`` and ``score`` read it) and with ``--cliffs`` ``cliffs`` (the Kobuki's cliff
events: [t, sensor, state, x, y] with the ground truth's last pose). With ``--operator SCRIPT`` (level 5) it is also
the scripted operator at the terminal (:class:`experiments.patrol_operator.OperatorSession`: it reads the
terminal's URLs from the terminal's ``~url_file``, FILE, then plays the script on the simulated clock) and adds
``operator`` (the session's metrics).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import rosgraph
import rospy
from actionlib_msgs.msg import GoalStatus
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32

from robots.patrol.level3 import load_goals
from subsumption import kobuki  # the Kobuki's messages, built without kobuki_msgs installed
from subsumption.planar import yaw_of
from subsumption.ros.runtime import RosNodeHandle

from .patrol import PatrolObserver
from .patrol_operator import OPERATOR_LEVEL, OperatorSession, motor_chain
from .patrol_vision import VisionObserver
from .runner import ROBOTS

# the network's names the observers listen to (absolute, as in `subsumption run patrol`'s graph), moved into the
# profile's namespace
NETWORK_TOPICS = ("/move_base/goal", "/move_base/result", "/move_base/status", "/alarms", "/track/box_info",
                  "/posters/passed_alarm", "/posters/passed_target", "/follow/cmd_vel", "/pursuit/hold",
                  "/pursuit/stop")


def remappings(ns: str, base_cmd: str, more: tuple[str, ...] = ()) -> list[str]:
    """rospy remapping arguments: the network's topics (and `more`) into `ns`, the base's velocity input to
    `base_cmd`."""
    ns = "/" + ns.strip("/")
    return [f"{topic}:={ns}{topic}" for topic in (*NETWORK_TOPICS, *more)] + [f"/cmd_vel:={base_cmd}"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("until", type=float, help="simulated s to listen for")
    parser.add_argument("--goals", default=None, help="the patrol's goal file ([[x, y, yaw], ...]; levels 3-5)")
    parser.add_argument("--ns", default="/patrol", help="the namespace the network runs in")
    parser.add_argument("--vision", action="store_true", help="level 4: record detect, track, follow, pursuit")
    parser.add_argument("--after-alarm", type=float, default=None,
                        help="stop this many simulated s after the first intruder alarm")
    parser.add_argument("--after-goal", type=float, default=None,
                        help="stop this many simulated s after move_base first reports a goal reached")
    parser.add_argument("--cliffs", action="store_true", help="record the Kobuki's cliff events (a TurtleBot 2)")
    parser.add_argument("--operator", type=Path, default=None, help="level 5: play this operator script")
    parser.add_argument("--url-file", type=Path, default=None, help="level 5: the terminal's ~url_file")
    parser.add_argument("--base-cmd", default="/mobile_base/commands/velocity",
                        help="the base's velocity input (what the guard sends on)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    goals = load_goals(args.goals) if args.goals else []
    session = None
    more: tuple[str, ...] = ()
    if args.operator is not None:
        if args.url_file is None:
            parser.error("--operator needs --url-file (the terminal's ~url_file)")
        navigation, above = motor_chain(ROBOTS["patrol"], OPERATOR_LEVEL)
        session = OperatorSession(args.url_file, args.operator.resolve(), "127.0.0.1", navigation, above,
                                  progress=False)
        more = tuple(f"/{name}/status" for name in (navigation, *above)) + ("/terminal/status",)
    rosgraph.Master("/watcher").setParam("/use_sim_time", True)  # the simulator's clock, whoever comes first
    rospy.init_node("watcher", argv=["watcher", *remappings(args.ns, args.base_cmd, more)], disable_signals=True)
    node = RosNodeHandle()
    patrol = PatrolObserver(node, goals)
    vision = VisionObserver(node) if args.vision else None
    if session is not None:
        session.attach(node)
    seen = {"t": 0.0, "collisions": 0, "path": []}

    def on_truth(msg: Odometry) -> None:
        p = msg.pose.pose
        seen["t"] = msg.header.stamp.to_sec()
        seen["path"].append([round(seen["t"], 3), round(p.position.x, 3), round(p.position.y, 3),
                             round(yaw_of(p.orientation), 3)])

    node.subscribe("/ground_truth", Odometry, on_truth)
    node.subscribe("/collisions", UInt32, lambda msg: seen.__setitem__("collisions", msg.data))
    if args.cliffs:
        seen["cliffs"] = []
        node.subscribe("/mobile_base/events/cliff", kobuki.CliffEvent, lambda msg: seen["cliffs"].append(
            [seen["t"], msg.sensor, msg.state, *(seen["path"][-1][1:3] if seen["path"] else [None, None])]))
    deadline = time.monotonic() + 90 + 20 * args.until  # wall clock on purpose: a graph that never ran
    while seen["t"] < args.until and time.monotonic() < deadline and not rospy.is_shutdown():
        raised = [a["raised_at_s"] for a in patrol.alarms if a["name"] == "intruder"]
        if args.after_alarm is not None and raised and seen["t"] >= min(raised) + args.after_alarm:
            break
        reached = [t for t, _, status, _ in patrol.results if status == GoalStatus.SUCCEEDED]
        if args.after_goal is not None and reached and seen["t"] >= reached[0] + args.after_goal:
            break
        time.sleep(0.1)
    if session is not None:
        session.finish()
    rospy.signal_shutdown("watched")  # no callback changes what is printed
    out = {**seen, "patrol": patrol.metrics(), "sent": patrol.sent}
    if session is not None:
        out["operator"] = session.metrics()
    if vision is not None:
        out["vision"] = vision.to_record()
    print(json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
