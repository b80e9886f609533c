"""The patrol robot on a robot profile, started as a user would (``roslaunch subsumption patrol.launch
robot:=turtlebot2 level:=N``) against the simulator posing as that robot, one line per run, watched by the patrol
experiment's own observers and scored by its scorer (experiments/profile_watch.py, experiments.patrol_vision). The
scenes, the figures and the targets are experiments/profile_scenes.py's (tests/test_profile_goals.py plays the
short versions):

- level 1 (TurtleBot 2): the landing between two stairwells (subsim/maps/corridors_turtlebot2_stairs_world.yaml,
  tests/test_profile_patrol.py's stair-edge run): the Kobuki's cliff events stop the robot and turn it away;
- level 3: the ping-pong room (subsim/maps/pingpong_turtlebot2_world.yaml posing as the robot) with
  patrol.launch's default map, goals and start (on a TurtleBot 3: its LDS, no camera; generic: the simulator's own
  robot with its 270-degree laser on /scan, patrol.launch's generic defaults and sectors:=14);
- level 4 (TurtleBot 2): experiments/worlds/pingpong_turtlebot2_intruder_world.yaml: a goal 0.7 m ahead, then the
  stranger turns its face towards the robot;
- level 5 (TurtleBot 2): the patrol experiment's operator scene (experiments/worlds/pingpong_operator_world.yaml)
  posing as a TurtleBot 2, with patrol.launch's default goals: the scripted operator
  (experiments/patrol_operator.yaml) at the terminal the launch starts selects the face, drives by hand, lets go.
  The one thing set beside the launch's arguments: the terminal's ~port (0: any free; the machine is shared) and
  ~url_file (where the operator reads its URL), as parameters on the master before roslaunch starts.

    .venv/bin/python -m bench.profile_patrol [--robot turtlebot2|turtlebot3|generic] [--levels 1,3,4,5]
                                             [--duration S] [--rate 1.0] [--after-alarm S] [--out DIR] [--figure DIR]

Printed per run: the goals the patrol sent, the goals move_base reported reached, the goals the robot truly came
within move_base's 0.2 m of after they were sent (ground truth), metres driven (ground truth), collisions, the
cliff events (level 1) and, at level 4, the intruder alarms scored against the ground truth (on the target /
false, the first heard at s) and the wall time; at level 4 and 5 also how long follow drove the robot and how long
after its image track's box was heard (median and max). A ROS graph of 20-40 processes: a long run for the bench.
Each run starts its own master on a free port and stops exactly the processes it started. The targets (exit 1 when
one is missed): 0 collisions everywhere; level 1: a cliff event, the robot driving; level 3: the goals sent, at
least one reached (move_base's word); level 4: goal 0 reached and an alarm on the target, no false alarm;
level 5: the operator selected the target, sent commands and let go.
``--figure DIR``: the pictures of the runs (docs/images/profile_patrol_*.png: ``--levels 1,4 --figure docs/images``).
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

from experiments.profile_scenes import figures, goal_list, scene, verdict, wait_until_ready
from subsumption.ros import process_tree
from subsumption.ros.master import host_env, start_master

ROOT = Path(__file__).resolve().parent.parent
DURATIONS = {1: 20.0, 3: 60.0, 4: 40.0, 5: 60.0}  # simulated s per level unless --duration


def run(robot: str, level: int, duration: float, rate: float, scratch: Path,
        after_alarm_s: float | None = None) -> dict:
    """One run of `robot`'s profile at `level`; the watcher's record (experiments/profile_watch.py) with the world
    and goal files, or {"failed": why}. `after_alarm_s`: end the run that many simulated s after the first intruder
    alarm (the scene has happened) instead of at `duration`."""
    played = scene(robot, level, scratch)
    world_file, goals, extra, watch = played.world, played.goals, played.launch_args, played.watch_args
    if after_alarm_s is not None:
        watch = [*watch, "--after-alarm", str(after_alarm_s)]
    master = start_master()
    env = host_env(dict(os.environ, ROS_MASTER_URI=master.uri, ROS_PACKAGE_PATH=f"{ROOT}:/usr/share",
                        PYTHONUNBUFFERED="1"))
    args = ["subsumption", "patrol.launch", f"robot:={robot}", f"level:={level}", "use_sim_time:=true", *extra]
    started: list[subprocess.Popen] = []
    log = (scratch / f"run_{robot}_{level}.log").open("w")

    def start(command: list[str], **kwargs) -> subprocess.Popen:
        kwargs.setdefault("stdout", log)
        process = subprocess.Popen(command, env=env, cwd=ROOT, stderr=subprocess.STDOUT, text=True,
                                   start_new_session=True, **kwargs)
        started.append(process)
        return process

    try:
        if level == 5:  # the terminal on any free port (the machine is shared), its URLs in a file for the operator
            import rosgraph

            params = rosgraph.Master("/bench_profile_patrol", master_uri=master.uri)
            params.setParam("/patrol/terminal/port", 0)
            params.setParam("/patrol/terminal/url_file", str(scratch / "terminal_urls.json"))
            (scratch / "terminal_urls.json").unlink(missing_ok=True)
        names = set(subprocess.run(["roslaunch", "--nodes", *args], env=env, capture_output=True, text=True,
                                   check=True).stdout.split())
        launch = start(["roslaunch", *args])
        watcher = start([sys.executable, "-m", "experiments.profile_watch", str(duration),
                         "--base-cmd", played.base_cmd,
                         *(["--goals", str(goals)] if goals else []), *watch], stdout=subprocess.PIPE)
        missing = wait_until_ready(env, names | {"/watcher"}, launch, 180.0)
        if missing:
            return {"failed": f"the launch was not ready: {', '.join(missing)} (log {log.name})"}
        start([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={world_file}", f"_rate:={rate}",
               f"_duration:={duration + 30}", "_connect_wait:=10"])
        out, _ = watcher.communicate(timeout=150 + 20 * duration)
        seen = json.loads(out.strip().splitlines()[-1])
        seen.update(robot=robot, level=level, duration=duration, world=str(world_file),
                    goals=None if goals is None else str(goals))
        (scratch / f"seen_{robot}_{level}.json").write_text(json.dumps(seen))
        return seen
    except (subprocess.SubprocessError, json.JSONDecodeError, IndexError) as error:
        return {"failed": f"{type(error).__name__}: {error} (log {log.name})"}
    finally:  # exactly what this run started, by process id, and roslaunch's nodes (none left behind)
        family = process_tree.descendants([p.pid for p in started if p.poll() is None])
        for process in reversed(started):
            if process.poll() is None:
                process.terminate()
        process_tree.stop(family, timeout=10.0)
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
    parser.add_argument("--robot", default="turtlebot2", choices=("turtlebot2", "turtlebot3", "generic"),
                        help="the profile (the simulator poses as that robot; a TurtleBot 3 has no camera: level 3; "
                             "generic: the simulator's own robot, its 270-degree laser on /scan: level 3)")
    parser.add_argument("--levels", default="3,4", help="patrol levels to run, comma-separated (1, 3, 4 or 5)")
    parser.add_argument("--duration", type=float, default=None,
                        help="simulated s per run (default: level 1 20, level 3 60, level 4 40, level 5 60)")
    parser.add_argument("--rate", type=float, default=1.0, help="simulated s per wall s")
    parser.add_argument("--after-alarm", type=float, default=None,
                        help="end a level 4-5 run this many simulated s after the first intruder alarm")
    parser.add_argument("--out", type=Path, default=None, help="keep each run's log, world and record here")
    parser.add_argument("--figure", type=Path, default=None,
                        help="write each run's picture here (profile_patrol_<robot>_level<N>.png)")
    args = parser.parse_args()
    try:
        levels = [int(v) for v in args.levels.split(",") if v.strip()]
    except ValueError:
        parser.error(f"--levels: expected levels like 3,4, got {args.levels!r}")
    if not levels or any(level not in DURATIONS for level in levels):
        parser.error(f"--levels: the stair edge is level 1's, the goals level 3's, the stranger level 4's, the "
                     f"operator level 5's: expected 1, 3, 4 or 5, got {args.levels!r}")
    if args.robot == "turtlebot3" and levels != [3]:
        parser.error("--levels: on a TurtleBot 3 only level 3 (no cliff sensors, no camera for levels 4-5): --levels 3")
    if args.robot == "generic" and levels != [3]:
        parser.error("--levels: on the generic profile (a laser base) only level 3: --levels 3")
    print(f"patrol.launch robot:={args.robot} on the simulator posing as that robot, at rate {args.rate:g} "
          f"(load average {os.getloadavg()[0]:.1f} at the start)\n")
    print("| level | simulated s | goals sent | move_base reached | truly within 0.2 m | m driven | collisions | "
          "cliff events | alarms on the target / false (first at s) | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    ok = True
    with tempfile.TemporaryDirectory() as scratch:
        if args.out is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            scratch = str(args.out)
        for level in levels:
            duration = args.duration if args.duration is not None else DURATIONS[level]
            began = time.monotonic()  # wall clock on purpose: the run's cost
            seen = run(args.robot, level, duration, args.rate, Path(scratch), args.after_alarm)
            wall = time.monotonic() - began
            if "failed" in seen:
                print(f"| {level} | run failed: {seen['failed']} | | | | | | | | {wall:.0f} |")
                ok = False
                continue
            f = figures(seen)
            alarms = "-" if "on_target" not in f else (
                f"{f['on_target']} / {f['false_alarms']} "
                f"({'-' if f['detected_at_s'] is None else format(f['detected_at_s'], '.1f')})")
            print(f"| {level} | {seen['t']:.1f} | {f['goals_sent']} | {f['succeeded']} | {f['truly_reached']} | "
                  f"{f['distance_m']:.1f} | {f['collisions']} | {f['cliffs'] if level == 1 else '-'} | {alarms} | "
                  f"{wall:.0f} |", flush=True)
            if "followed_s" in f:
                lag = f["box_lag_s"]
                print(f"  follow drove {f['followed_s']:.1f} s; track's box heard "
                      + ("never" if lag is None else f"{lag['median']:.2f} s (median), {lag['max']:.2f} s (max)")
                      + " after its image", flush=True)
            if level == 5:
                print(f"  terminal {f['terminal']}; the operator selected {f['selected']}, sent "
                      f"{f['operator_commands']} commands, released at {f['released_at_s']} s; the robot's own levels "
                      f"drove again at {f['resumed_after_release_s']} s; error: {f['operator_error'] or 'none'}")
            ok = ok and verdict(level, f)
            if args.figure is not None:
                from bench.profile_figures import draw

                print(f"  picture: {draw(seen, f, goal_list(seen), args.figure)}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
