"""`subsumption run` and `subsumption demo`, added to the core's command through its entry points."""
from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from concurrent.futures import Future
from pathlib import Path

import rosgraph

from subsim.mapio import MapError
from subsim.world import WorldError
from subsumption import arguments
from subsumption.network.spec import NetworkInvalid
from subsumption.ros.master import master_reachable
from subsumption.yamlfile import YamlFileError

from . import demo, patrol_experiment
from .patrol import cmd_run_patrol
from .runner import (RunCutShort, RunSpec, module_overrides, network_file, run_local, run_ros, world_for_map,
                     write_outputs)
from .worker import InProcessWork

# every value type of the command line lives in one place, shared by every command
_pose, _number, _seed, _level, _ip = arguments.pose, arguments.number, arguments.seed, arguments.level, arguments.ip


def register_run(commands: argparse._SubParsersAction) -> None:
    run = commands.add_parser(
        "run", help="run a robot's levels 0..N in the simulator; write trajectory.png and metrics.json",
        description="Run levels 0..N of a robot (a name such as 'wander', or a network file) in the simulator "
                    "for a stretch of simulated time, in-process (local) or on a real ROS graph (ros).")
    run.add_argument("robot", help="'wander', 'patrol' or the path of a network file")
    run.add_argument("--level", type=_level, required=True,
                     help="run the robot's levels 0..LEVEL (wander: 0 avoid objects, 1 wander, 2 explore; "
                          "patrol: 0 avoid contact, 1 wander, 2 explore, 3 patrol, 4 detect-track-follow, "
                          "5 remote operator)")
    run.add_argument("--map", type=Path, help="a map_server map (YAML); one robot is put on it (patrol with "
                                              "--world: the navigation map, built beforehand by subsumption map)")
    run.add_argument("--world", type=Path, help="a simulator world file (map, robots, agents)")
    run.add_argument("--goals", type=Path, help="patrol: a YAML list of goals [x, y, yaw] in the map frame "
                                                "(default: the four corners of the room)")
    run.add_argument("--start", type=_pose, help="X,Y,YAW of the robot on --map (default: a free pose)")
    run.add_argument("--duration", type=_number(0.0, False, "simulated seconds > 0"), default=600.0,
                     help="simulated seconds (default 600)")
    run.add_argument("--seed", type=_seed, default=0,
                     help="random seed of the simulator and of every module with a seed parameter (default 0)")
    run.add_argument("--runtime", choices=("local", "ros"), default="local",
                     help="local: every module in this process on a simulated clock, deterministic and fast "
                          "(default); ros: a real ROS graph, one node per module and arbiter, on the simulator's "
                          "/clock")
    run.add_argument("--rate", type=_number(0.0, True, "simulated s per wall s, >= 0"), default=3.0,
                     help="ros: simulated s per wall s (0: as fast as it can)")
    run.add_argument("--param", action="append", default=[], metavar="MODULE.NAME=VALUE",
                     help="set a module's parameter for this run over the network file's (e.g. "
                          "move_base.max_vel_x=0.3, the value read as YAML); repeatable")
    run.add_argument("--groups", choices=("file", "level", "none"), default="file",
                     help="ros: module groups, one process each with in-process wires inside: as the network "
                          "file's group: keys say (file, the default), one per level (level), or one process per "
                          "module and arbiter (none); see docs/ros.md")
    run.add_argument("--bag", type=Path, help="ros: record every topic of the run to this bag")
    run.add_argument("--mcap", type=Path, help="ros: record every topic of the run to this MCAP file (ros1 profile: "
                                               "Foxglove and Lichtblick open it; see docs/terminal.md)")
    run.add_argument("--join", action="store_true",
                     help="ros: run on the master at ROS_MASTER_URI (it must be running) instead of starting one; "
                          "the run sets /use_sim_time there and its simulator publishes /clock")
    run.add_argument("--ros-ip", type=_ip, default=None,
                     help="ros: this host's address for other hosts (default: every process listens on "
                          "127.0.0.1 only; see docs/faults.md)")
    run.add_argument("--operator", type=Path, metavar="SCRIPT",
                     help="patrol level 5: a scripted operator plays SCRIPT at the terminal (default script: "
                          "experiments/patrol_operator.yaml); without it the page is served and its URL printed")
    run.add_argument("--host", type=_ip, default="127.0.0.1",
                     help="patrol level 5: the address the operator terminal listens on (default 127.0.0.1; any "
                          "other needs the token printed with the URL)")
    run.add_argument("--out", type=Path, required=True,
                     help="folder for trajectory.png, metrics.json and (ros) the logs of every process")
    run.set_defaults(func=cmd_run)


def _writable_folder(path: Path, what: str) -> str:
    """'' if `path` can be a folder we write into, else the problem."""
    if path.exists() and not path.is_dir():
        return f"{what} {path}: exists and is not a folder"
    parent = next((p for p in (path, *path.parents) if p.exists()), Path("."))

    if not os.access(parent, os.W_OK):
        return f"{what} {path}: {parent} is not writable"
    return ""


def _running_master() -> str | None:
    """The URI of the master ROS_MASTER_URI names, if it answers (else None, after saying so)."""
    uri = rosgraph.get_master_uri()
    if master_reachable(uri):
        return uri
    print(f"subsumption run: --join: no ROS master answers at {uri} (ROS_MASTER_URI)", file=sys.stderr)
    return None


def _where_problem(args: argparse.Namespace) -> str:
    """'' if --map/--world/--goals fit together, else what is wrong (argparse cannot say it: patrol takes both)."""
    if args.map is None and args.world is None:
        return "one of --map or --world is required"
    if args.robot != "patrol" and args.map is not None and args.world is not None:
        return "--map and --world go together only for the patrol robot (--map is then its navigation map)"
    if args.robot != "patrol" and args.goals is not None:
        return "--goals is for the patrol robot"
    if args.robot != "patrol" and (args.operator is not None or args.host != "127.0.0.1"):
        return "--operator and --host are for the patrol robot's level 5 (the operator terminal)"
    return ""


def cmd_run(args: argparse.Namespace) -> int:
    problem = _writable_folder(args.out, "--out") or (
        _writable_folder(args.bag.parent, "--bag") if args.bag else "") or (
        _writable_folder(args.mcap.parent, "--mcap") if args.mcap else "") or _where_problem(args)
    if problem:
        print(f"subsumption run: {problem}", file=sys.stderr)
        return 2
    try:
        args.params = module_overrides(args.param, network_file(args.robot))
    except (ValueError, NetworkInvalid, YamlFileError, FileNotFoundError) as error:
        print(f"subsumption run: {error}", file=sys.stderr)
        return 2
    if args.robot == "patrol":
        join = _running_master() if args.join and args.runtime == "ros" else None
        if args.join and args.runtime == "ros" and join is None:
            return 2
        return cmd_run_patrol(args, join)
    try:
        world = args.world or world_for_map(args.map, args.out, args.start)
        spec = RunSpec(args.robot, args.level, world, args.duration, args.seed, args.runtime, args.rate,
                       args.bag.resolve() if args.bag else None, label=f"level {args.level}", params=args.params,
                       groups=args.groups, mcap=args.mcap.resolve() if args.mcap else None)
        if args.runtime == "ros":
            join = _running_master() if args.join else None
            if args.join and join is None:
                return 2
            result = run_ros(spec, log_dir=args.out.resolve() / "logs", ros_ip=args.ros_ip, join=join)
        else:
            result = run_local(spec)
    except (MapError, WorldError, NetworkInvalid, YamlFileError, FileNotFoundError) as error:
        print(f"subsumption run: {error}", file=sys.stderr)
        return 2
    except (RunCutShort, ValueError) as error:
        print(f"subsumption run: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("subsumption run: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    write_outputs(result, args.out)
    m = result.metrics
    print(f"{args.out}/metrics.json: level {m['level']}, {m['sim_time_s']:.0f} s simulated in {m['wall_time_s']:.1f} s, "
          f"{m['collisions']} collisions, {m['distance_m']:.1f} m, {m['coverage_m2']:.1f} m² covered")
    if not m.get("complete", True):
        print(f"subsumption run: cut short, {m['ended']}; {args.out}/metrics.json holds what was recorded",
              file=sys.stderr)
        interrupted = m["ended"].startswith("interrupted")
        return 128 + (signal.SIGTERM if "SIGTERM" in m["ended"] else signal.SIGINT) if interrupted else 1
    return 0


def register_demo(commands: argparse._SubParsersAction) -> None:
    demo = commands.add_parser("demo", help="the paper's experiments: the wander robot (levels 0-2), then the patrol "
                                           "robot (subsumption experiment patrol), on ROS and in-process, with figures")
    demo.add_argument("--out", type=Path, default=Path("out/demo"),
                      help="folder for the figures, summary.md and every run's outputs (default out/demo)")
    demo.add_argument("--ros-duration", type=float, default=30.0, help="simulated s of each ROS run")
    demo.add_argument("--rate", type=float, default=3.0, help="ROS runs: simulated s per wall s")
    demo.add_argument("--local-duration", type=float, default=600.0, help="simulated s of each local run")
    demo.add_argument("--wander-only", action="store_true",
                      help="only the wander robot's experiment (without it, the patrol robot's follows)")
    demo.set_defaults(func=cmd_demo)


def cmd_demo(args: argparse.Namespace) -> int:
    """The paper's two experiments, one after the other: the wander robot (in OUT), the patrol robot (OUT/patrol).
    They share one worker for their in-process runs, which builds the patrol robot's map while the wander robot's
    ROS runs go on."""
    started = time.monotonic()
    patrol_out = args.out / "patrol"
    work = InProcessWork()
    try:
        maps: list[Future | None] = []

        def queue_patrol_map() -> None:
            maps.append(patrol_experiment.queue_map(work, patrol_out, patrol_experiment.FULL))

        print("== Experiment 1: Brooks' wander robot (the paper's Fig. 6) ==", flush=True)
        status = demo.main(args.out, args.ros_duration, args.rate, args.local_duration, work,
                           None if args.wander_only else queue_patrol_map)
        if status != 0 or args.wander_only:
            return status
        print("\n== Experiment 2: the security patrol robot (the paper's Fig. 7) ==", flush=True)
        status = patrol_experiment.main(patrol_out, patrol_experiment.FULL, work=work,
                                        map_job=maps[0] if maps else None)
    finally:
        work.close()
    out = args.out.resolve()
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"\ndemo: {time.monotonic() - started:.0f} s (load average {load}). Written: {out}/summary.md, "
          f"{out}/fig6_trajectories.png "
          f"(wander robot); {out}/patrol/summary.md, {out}/patrol/fig7_trajectories.png, "
          f"{out}/patrol/level*/ (patrol robot)", flush=True)
    return status
