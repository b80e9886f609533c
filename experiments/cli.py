"""`subsumption run` and `subsumption demo`, added to the core's command through its entry points."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from subsim.mapio import MapError
from subsim.world import WorldError
from subsumption.network.spec import NetworkInvalid


def _pose(text: str) -> tuple[float, float, float]:
    try:
        x, y, yaw = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--start wants X,Y,YAW (metres, metres, radians), got {text!r}") from None
    return x, y, yaw


def register_run(commands: argparse._SubParsersAction) -> None:
    run = commands.add_parser(
        "run", help="run a robot's levels 0..N in the simulator; write trajectory.png and metrics.json",
        description="Run levels 0..N of a robot (a name such as 'wander', or a network file) in the simulator "
                    "for a stretch of simulated time, in-process (local) or on a real ROS graph (ros).")
    run.add_argument("robot", help="'wander' or the path of a network file")
    run.add_argument("--level", type=int, required=True)
    where = run.add_mutually_exclusive_group(required=True)
    where.add_argument("--map", type=Path, help="a map_server map (YAML); one robot is put on it")
    where.add_argument("--world", type=Path, help="a simulator world file (map, robots, agents)")
    run.add_argument("--start", type=_pose, help="X,Y,YAW of the robot on --map (default: a free pose)")
    run.add_argument("--duration", type=float, default=600.0, help="simulated seconds (default 600)")
    run.add_argument("--seed", type=int, default=0)
    run.add_argument("--runtime", choices=("local", "ros"), default="local")
    run.add_argument("--rate", type=float, default=3.0, help="ros: simulated s per wall s (0: as fast as it can)")
    run.add_argument("--bag", type=Path, help="ros: record every topic of the run to this bag")
    run.add_argument("--out", type=Path, required=True, help="folder for trajectory.png and metrics.json")
    run.set_defaults(func=cmd_run)


def cmd_run(args: argparse.Namespace) -> int:
    from .runner import RunSpec, run_local, run_ros, world_for_map, write_outputs

    try:
        world = args.world or world_for_map(args.map, args.out, args.start)
        spec = RunSpec(args.robot, args.level, world, args.duration, args.seed, args.runtime, args.rate,
                       args.bag.resolve() if args.bag else None, label=f"level {args.level}")
        result = (run_ros if args.runtime == "ros" else run_local)(spec)
    except (MapError, WorldError, NetworkInvalid, FileNotFoundError) as error:
        print(f"subsumption run: {error}", file=sys.stderr)
        return 2
    write_outputs(result, args.out)
    m = result.metrics
    print(f"{args.out}/metrics.json: level {m['level']}, {m['sim_time_s']:.0f} s simulated in {m['wall_time_s']:.1f} s, "
          f"{m['collisions']} collisions, {m['distance_m']:.1f} m, {m['coverage_m2']:.1f} m² covered")
    return 0


def register_demo(commands: argparse._SubParsersAction) -> None:
    demo = commands.add_parser("demo", help="the wander robot, levels 0-2, on ROS and in-process, with figures")
    demo.add_argument("--out", type=Path, default=Path("out/demo"))
    demo.add_argument("--ros-duration", type=float, default=90.0, help="simulated s of each ROS run")
    demo.add_argument("--rate", type=float, default=3.0, help="ROS runs: simulated s per wall s")
    demo.add_argument("--local-duration", type=float, default=600.0, help="simulated s of each local run")
    demo.set_defaults(func=cmd_demo)


def cmd_demo(args: argparse.Namespace) -> int:
    from .demo import main

    return main(args.out, args.ros_duration, args.rate, args.local_duration)
