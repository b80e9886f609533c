"""The patrol robot on the TurtleBot 2 profile, started as a user would (``roslaunch subsumption patrol.launch
robot:=turtlebot2 level:=N``) against the simulator posing as a TurtleBot 2, printed as one line per run. Level 3:
the ping-pong room (subsim/maps/pingpong_turtlebot2_world.yaml) with patrol.launch's default map, goals and start.
Level 4: tests/test_patrol_level4.py's short intruder scene in the same room (the robot heading west on the north
side, the stranger ahead of it), with that scene's goals and start. ``--robot turtlebot3``: level 3 on the
Burger's LDS in the same room:

    .venv/bin/python -m bench.profile_patrol [--robot turtlebot2|turtlebot3] [--levels 3,4] [--duration 60]
                                             [--rate 1.0]

Printed per run: the goals the patrol sent, move_base's plans and commands, metres driven (ground truth), the
goals reached (ground truth within move_base's 0.2 m of a goal), collisions, and at level 4 the intruder sightings
and when the first came (simulated s). A ROS graph of 30-40 processes: a long run for the bench, not the test suite
(tests/test_profile_patrol.py tests the same launch's graph and its levels 0-1). Each run starts its own master on
a free port and stops exactly the processes it started. Targets: the four goals sent, the robot driving toward
them, 0 collisions; level 4: the stranger seen.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import subsim
from subsim.world import WorldDocument
from subsumption.ros.master import host_env, start_master

ROOT = Path(__file__).resolve().parent.parent
GOALS = [(0.98, 0.98), (9.43, 0.98), (9.43, 5.43), (0.98, 5.43)]  # robots/patrol/goals/pingpong.yaml
# level 4: tests/test_patrol_level4.py's short intruder scene (experiments/worlds/pingpong_intruder_world.yaml cut
# short): the robot on the north side heading west, the stranger 5.8 m ahead with its back turned, setting off
# west after 8 s
SCENE = ROOT / "experiments" / "worlds" / "pingpong_intruder_world.yaml"
SCENE_START = (9.4, 5.4, 3.14159)
SCENE_GOALS = [(1.0, 5.4, -1.571), (1.0, 1.0, 0.0), (9.4, 1.0, 1.571), (9.4, 5.4, 3.142)]

WATCHER = r"""
import json, math, sys, time, rospy
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry, Path
from std_msgs.msg import UInt32
until, goals = float(sys.argv[1]), json.loads(sys.argv[2])
seen = {"collisions": 0, "distance": 0.0, "last": None, "t": 0.0, "goals": [], "plans": 0, "commands": 0,
        "reached": [], "sightings": 0, "first_sighting": None}
def on_truth(m):
    p = m.pose.pose.position
    if seen["last"] is not None:
        seen["distance"] += math.hypot(p.x - seen["last"][0], p.y - seen["last"][1])
    seen["last"], seen["t"] = (p.x, p.y), m.header.stamp.to_sec()
    for i, (gx, gy) in enumerate(goals):
        if i not in seen["reached"] and math.hypot(p.x - gx, p.y - gy) <= 0.2:
            seen["reached"].append(i)
def on_intruder(m):
    seen["sightings"] += 1
    if seen["first_sighting"] is None:
        seen["first_sighting"] = seen["t"]
rospy.init_node("watcher")
rospy.Subscriber("/ground_truth", Odometry, on_truth)
rospy.Subscriber("/collisions", UInt32, lambda m: seen.__setitem__("collisions", m.data))
rospy.Subscriber("/patrol/patrol/goals", PoseArray,
                 lambda m: seen.__setitem__("goals", [(round(p.position.x, 2), round(p.position.y, 2)) for p in m.poses]))
rospy.Subscriber("/patrol/move_base/plan", Path, lambda m: seen.__setitem__("plans", seen["plans"] + 1))
rospy.Subscriber("/patrol/move_base/cmd_vel", rospy.AnyMsg, lambda m: seen.__setitem__("commands", seen["commands"] + 1))
rospy.Subscriber("/patrol/intruder", DiagnosticStatus, on_intruder)
deadline = time.monotonic() + 60 + 20 * until
while seen["t"] < until and time.monotonic() < deadline:
    time.sleep(0.1)
print(json.dumps(seen))
"""


def wait_for_nodes(env: dict[str, str], names: set[str], launch: subprocess.Popen, timeout: float = 180.0) -> bool:
    """Until every node of the launch has registered with the master (wall clock: processes starting)."""
    import rosgraph

    master = rosgraph.Master("/bench_profile_patrol", master_uri=env["ROS_MASTER_URI"])
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and launch.poll() is None:
        publishers, subscribers, _ = master.getSystemState()
        if names <= {node for _, nodes in publishers + subscribers for node in nodes}:
            return True
        time.sleep(0.5)
    return False


def run(robot: str, level: int, duration: float, rate: float, scratch: Path) -> dict:
    """One run of `robot`'s profile at `level`; the watcher's findings, or {"failed": why}."""
    extra: list[str] = []
    if level < 4:  # levels 0-3 read the depth band only (a TurtleBot 3: its LDS), and the intruder is level 4's
        world = WorldDocument(subsim.world_path("pingpong_turtlebot2"))
        world.robot["kind"] = robot
        if robot == "turtlebot2":
            world.sensors["camera"] = {"mode": "depth_band", "compressed": False}
        world.data["agents"] = []
    else:
        world = WorldDocument(SCENE)
        world.robot["kind"] = "turtlebot2"
        world.robot["start"] = list(SCENE_START)
        target = world.data["agents"][0]
        target["wait"] = 8.0
        target.pop("cue", None)
        target["waypoints"] = [[3.6, 5.4], [1.8, 5.4], [3.0, 5.9], [3.0, 7.2], [0.8, 7.2]]
        goals = scratch / "scene_goals.yaml"
        goals.write_text(json.dumps([list(g) for g in SCENE_GOALS]))
        extra = [f"goals:={goals}", "initial_pose:=" + " ".join(str(v) for v in SCENE_START)]
    goals_expected = GOALS if level < 4 else [g[:2] for g in SCENE_GOALS]
    world_file = world.write(scratch / f"world_{level}.yaml")
    master = start_master()
    env = host_env(dict(os.environ, ROS_MASTER_URI=master.uri, ROS_PACKAGE_PATH=f"{ROOT}:/usr/share",
                        PYTHONUNBUFFERED="1"))
    args = ["subsumption", "patrol.launch", f"robot:={robot}", f"level:={level}", "use_sim_time:=true", *extra]
    started: list[subprocess.Popen] = []
    log = (scratch / f"run_{level}.log").open("w")

    def start(command: list[str], **kwargs) -> subprocess.Popen:
        kwargs.setdefault("stdout", log)
        process = subprocess.Popen(command, env=env, cwd=ROOT, stderr=subprocess.STDOUT, text=True,
                                   start_new_session=True, **kwargs)
        started.append(process)
        return process

    try:
        names = set(subprocess.run(["roslaunch", "--nodes", *args], env=env, capture_output=True, text=True,
                                   check=True).stdout.split())
        launch = start(["roslaunch", *args])
        watcher = start([sys.executable, "-c", WATCHER, str(duration), json.dumps(goals_expected)], stdout=subprocess.PIPE)
        if not wait_for_nodes(env, names | {"/watcher"}, launch):
            return {"failed": f"the launch's nodes did not come up (log {log.name})"}
        start([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={world_file}", f"_rate:={rate}",
               f"_duration:={duration + 30}", "_connect_wait:=10", "_map_to_odom:=false", "_publish_map:=false"])
        out, _ = watcher.communicate(timeout=120 + 20 * duration)
        seen = json.loads(out.strip().splitlines()[-1])
        seen["expected_goals"] = [list(g) for g in goals_expected]
        (scratch / f"seen_{level}.json").write_text(json.dumps(seen))
        return seen
    except (subprocess.SubprocessError, json.JSONDecodeError, IndexError) as error:
        return {"failed": f"{type(error).__name__}: {error} (log {log.name})"}
    finally:
        for process in reversed(started):  # exactly what this run started, by process id
            if process.poll() is None:
                process.terminate()
        for process in started:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        master.stop()
        log.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="turtlebot2", choices=("turtlebot2", "turtlebot3"),
                        help="the profile (the simulator poses as that robot; a TurtleBot 3 has no camera: level 3)")
    parser.add_argument("--levels", default="3,4", help="patrol levels to run, comma-separated (3 or 4)")
    parser.add_argument("--duration", type=float, default=60.0, help="simulated s per run")
    parser.add_argument("--rate", type=float, default=1.0, help="simulated s per wall s")
    parser.add_argument("--out", type=Path, default=None, help="keep each run's log and world here")
    args = parser.parse_args()
    try:
        levels = [int(v) for v in args.levels.split(",") if v.strip()]
    except ValueError:
        parser.error(f"--levels: expected levels like 3,4, got {args.levels!r}")
    if not levels or any(level not in (3, 4) for level in levels):
        parser.error(f"--levels: the goals are level 3's, the stranger level 4's: expected 3 or 4, got {args.levels!r}")
    if args.robot == "turtlebot3" and levels != [3]:
        parser.error("--levels: a TurtleBot 3 has no camera for level 4 (its profile needs camera:=): --levels 3")
    print(f"patrol.launch robot:={args.robot} on the simulator posing as that robot (ping-pong room), "
          f"{args.duration:g} simulated s at rate {args.rate:g} (load average {os.getloadavg()[0]:.1f} at the start)\n")
    print("| level | goals sent | plans | move_base commands | m driven | goals reached | collisions | "
          "intruder sightings (first at s) | wall s |")
    print("|---|---|---|---|---|---|---|---|---|")
    ok = True
    with tempfile.TemporaryDirectory() as scratch:
        if args.out is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            scratch = str(args.out)
        for level in levels:
            began = time.monotonic()  # wall clock on purpose: the run's cost
            seen = run(args.robot, level, args.duration, args.rate, Path(scratch))
            wall = time.monotonic() - began
            if "failed" in seen:
                print(f"| {level} | run failed: {seen['failed']} | | | | | | | {wall:.0f} |")
                ok = False
                continue
            sent = len(seen["goals"]) if seen["goals"] == seen["expected_goals"] else f"WRONG {seen['goals']}"
            first = "-" if seen["first_sighting"] is None else f"{seen['first_sighting']:.1f}"
            sightings = f"{seen['sightings']} ({first})" if level >= 4 else "-"
            print(f"| {level} | {sent} | {seen['plans']} | {seen['commands']} | {seen['distance']:.1f} | "
                  f"{len(seen['reached'])} {sorted(seen['reached'])} | {seen['collisions']} | {sightings} | "
                  f"{wall:.0f} |", flush=True)
            ok = ok and sent == 4 and seen["collisions"] == 0 and seen["distance"] > 1.0
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
