"""The scenes the patrol robot is run in on a robot profile, and how such a run is scored: one place for the
bench's long runs (bench/profile_patrol.py, figures printed) and the suite's short ones
(tests/test_profile_goals.py, asserted), so that both play the same worlds and judge by the same rules.

A scene is what the simulator runs (a world file posing as the robot), the patrol's goal file, the arguments
``roslaunch subsumption patrol.launch robot:=... level:=N`` gets beside those two, and the arguments of the
watcher (experiments/profile_watch.py). A run's record is the watcher's JSON line with ``world`` and ``goals``
(the files) added; :func:`figures` reads it with the patrol experiment's scorer and :func:`verdict` says whether
the level's targets were met:

- level 1 (TurtleBot 2): a cliff event, the robot driving;
- level 3: goals sent, one reached (move_base's word);
- level 4: goal 0 reached and an intruder alarm on the target (the scorer's IoU), no false alarm. In either order,
  and "reached" is move_base's word or, when the alarm pre-empted goal 0, the ground truth's: on a loaded graph the
  patrol's first goal can come late, while levels 0-2 already drive the robot towards the stranger's cue, and level
  4 taking over from level 3 on the alarm is the architecture at work;
- level 5: the operator selected the target, sent commands and let go;
- every level: 0 collisions.
"""
from __future__ import annotations

import math
import re
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import rosgraph

import subsim
from robots.patrol.level3 import load_goals
from subsim.world import WorldDocument
from subsumption.ros.launch import until_ready

from .patrol_vision import VisionObserver, score

ROOT = Path(__file__).resolve().parent.parent
WORLDS = ROOT / "experiments" / "worlds"
DEFAULT_GOALS = ROOT / "robots" / "patrol" / "goals" / "pingpong.yaml"  # patrol.launch's default
INTRUDER_WORLD = WORLDS / "pingpong_turtlebot2_intruder_world.yaml"
INTRUDER_GOALS = WORLDS / "pingpong_turtlebot2_intruder_goals.yaml"
INTRUDER_START = "9.2 5.4 3.1416"
OPERATOR_WORLD = WORLDS / "pingpong_operator_world.yaml"  # level 5's scene (the experiment's)
OPERATOR_SCRIPT = ROOT / "experiments" / "patrol_operator.yaml"
REACHED_M = 0.2  # move_base's xy_goal_tolerance (robots/patrol/patrol.yaml)
# the generic profile's laser in these scenes: the simulator's own robot (kind: robot) with its 270-degree laser
# on /scan, /cmd_vel and /odom (generic.yaml's names), no sonar and no camera; 14 depthmap sectors for 270 degrees
GENERIC_LAUNCH_ARGS = ("sectors:=14",)


@dataclass(frozen=True)
class Scene:
    """One run's setting: the simulator's world, the patrol's goal file (None: level 1 has none), patrol.launch's
    arguments beside robot:= and level:=, the watcher's arguments, and the base's velocity input (what the guard
    sends on, which the watcher listens to)."""
    world: Path
    goals: Path | None
    launch_args: list[str] = field(default_factory=list)
    watch_args: list[str] = field(default_factory=list)
    base_cmd: str = "/cmd_vel"


def base_cmd(robot: str) -> str:
    """The base's velocity input on `robot` (the Kobuki driver's on a TurtleBot 2)."""
    return "/mobile_base/commands/velocity" if robot == "turtlebot2" else "/cmd_vel"


def posing(world: WorldDocument, robot: str) -> None:
    """The world's robot made `robot`: the simulator poses as that robot (generic: its own robot, laser only)."""
    if robot == "generic":
        world.robot["kind"] = "robot"
        world.sensors.update(sonar=False, camera=False)
    else:
        world.robot["kind"] = robot


def scene(robot: str, level: int, scratch: Path) -> Scene:
    """The bench's scene for `robot` at `level` (bench/profile_patrol.py's docstring says which room and why); a
    world file it edits is written into `scratch`."""
    cmd = base_cmd(robot)
    if level == 1:
        return Scene(subsim.world_path("corridors_turtlebot2_stairs"), None, [], ["--cliffs"], cmd)
    if level == 4:
        return Scene(INTRUDER_WORLD, INTRUDER_GOALS, [f"goals:={INTRUDER_GOALS}", f"initial_pose:={INTRUDER_START}"],
                     ["--vision"], cmd)
    if level == 5:  # the patrol experiment's operator scene, with patrol.launch's default goals and start
        world = WorldDocument(OPERATOR_WORLD)
        world.robot["kind"] = "turtlebot2"
        return Scene(world.write(scratch / "world_turtlebot2_5.yaml"), DEFAULT_GOALS, [],
                     ["--vision", "--operator", str(OPERATOR_SCRIPT), "--url-file",
                      str(scratch / "terminal_urls.json")], cmd)
    world = WorldDocument(subsim.world_path("pingpong_turtlebot2"))
    posing(world, robot)
    if robot == "turtlebot2":  # levels 0-3 read the depth band only (a TurtleBot 3: its LDS)
        world.sensors["camera"] = {"mode": "depth_band", "compressed": False}
    world.data["agents"] = []
    return Scene(world.write(scratch / f"world_{robot}_{level}.yaml"), DEFAULT_GOALS,
                 list(GENERIC_LAUNCH_ARGS) if robot == "generic" else [], [], cmd)


def first_goal_scene(robot: str, scratch: Path) -> Scene:
    """Level 3's short run (the suite's): level 4's room, start and goals (goal 0 is 0.7 m ahead of the start,
    goal 1 at the far end of the room) without the stranger, the simulator posing as `robot` (a TurtleBot 2 with
    the depth band its levels 0-3 read); the watcher stops 1 simulated s after move_base reports a goal reached."""
    world = WorldDocument(INTRUDER_WORLD)
    posing(world, robot)
    if robot == "turtlebot2":
        world.sensors["camera"] = {"mode": "depth_band", "compressed": False}
    world.data["agents"] = []
    return Scene(world.write(scratch / f"world_{robot}_first_goal.yaml"), INTRUDER_GOALS,
                 [f"goals:={INTRUDER_GOALS}", f"initial_pose:={INTRUDER_START}",
                  *(GENERIC_LAUNCH_ARGS if robot == "generic" else ())],
                 ["--after-goal", "1"], base_cmd(robot))


def goal_list(seen: dict) -> list[list[float]]:
    """The run's goals ([x, y, yaw]; none at level 1)."""
    return [] if seen["goals"] is None else [list(g) for g in load_goals(seen["goals"])]


def figures(seen: dict) -> dict:
    """The run's figures: goals (sent, move_base's successes, truly within REACHED_M after being sent), metres
    driven, cliff events and, at level 4, the scorer's verdict on the alarms."""
    patrol, path = seen["patrol"], seen["path"]
    goals = goal_list(seen)
    sent_at: dict[int, float] = {}
    for t, _, index in seen["sent"]:
        sent_at.setdefault(index, t)
    truly = sorted(i for i, t0 in sent_at.items() if 0 <= i < len(goals) and any(
        t >= t0 and math.hypot(x - goals[i][0], y - goals[i][1]) <= REACHED_M for t, x, y, _ in path))
    succeeded = [g for g in patrol["goal_log"] if g["status"] == "SUCCEEDED"]
    out = {"goals_sent": patrol["goals_sent"], "succeeded": [g["goal"] for g in succeeded],
           "preempted": [[g["goal"], g["at_s"]] for g in patrol["goal_log"] if g["status"] == "PREEMPTED"],
           "first_success_s": succeeded[0]["at_s"] if succeeded else None, "truly_reached": truly,
           "distance_m": sum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(path, path[1:])),
           "collisions": seen["collisions"], "cliffs": len([c for c in seen.get("cliffs", []) if c[2] == 1])}
    if "vision" in seen:
        m = score(VisionObserver.from_record(seen["vision"]), Path(seen["world"]), seen["sent"], seen["t"]).metrics
        out.update(on_target=m["alarms_on_target"], false_alarms=m["false_alarms"], detected_at_s=m["detected_at_s"],
                   followed_s=m["followed_s"], box_lag_s=m["box_lag_s"])
    if "operator" in seen:
        op = seen["operator"]
        out.update(selected=op["operator"]["selected"], operator_commands=op["operator_commands"],
                   released_at_s=op["operator"]["released_at_s"], resumed_after_release_s=op["resumed_patrol_at_s"],
                   operator_error=op["operator"]["error"], terminal=op["terminal"]["terminal"])
    return out


def verdict(level: int, f: dict) -> bool:
    """Whether the run met its level's targets (the module docstring's)."""
    ok = f["collisions"] == 0
    if level == 1:
        return ok and f["cliffs"] >= 1 and f["distance_m"] >= 0.5
    if level == 3:
        return ok and f["goals_sent"] >= 1 and bool(f["succeeded"])
    if level == 5:
        return ok and bool(f["selected"]) and f["operator_commands"] > 0 and f["released_at_s"] is not None
    return (ok and goal0_reached(f) and f["on_target"] >= 1 and f["false_alarms"] == 0
            and f["detected_at_s"] is not None)


ALARM_PREEMPTS_S = 1.0  # how long after the alarm level 4's take-over may pre-empt the patrol's goal (simulated s)


def goal0_reached(f: dict) -> bool:
    """Level 4's goal 0: move_base reported it reached or, when level 4 took over on the alarm and pre-empted it
    (at most ALARM_PREEMPTS_S after the alarm), the robot had truly been within REACHED_M of it."""
    if 0 in f["succeeded"]:
        return True
    alarm = f.get("detected_at_s")
    return (alarm is not None and 0 in f["truly_reached"]
            and any(goal == 0 and alarm - 0.5 <= at <= alarm + ALARM_PREEMPTS_S for goal, at in f["preempted"]))


def wait_until_ready(env: dict[str, str], names: set[str], launch: subprocess.Popen, timeout: float) -> list[str]:
    """Until the launch is ready as `subsumption run` waits for it (subsumption.ros.launch.not_ready): every node
    registered and each level's process (a reference robot's group node, ``<network>_level<N>``) built. A loaded
    machine takes a while to build a level (amcl reads its map, move_base warms its kernels); the simulator then
    starts with every module listening, not with levels 0-2 driving while level 3 is still being built. Returns
    what is still missing (empty: ready) when ready, roslaunch exited or `timeout` wall-clock s passed."""
    master = rosgraph.Master("/profile_scenes_wait", master_uri=env["ROS_MASTER_URI"])
    levels = {name for name in names if re.search(r"_level\d+$", name)}
    missing = until_ready(master, names, levels, lambda: launch.poll() is None, timeout, poll=0.5)
    if launch.poll() is not None:
        return missing or ["roslaunch exited"]
    return missing
