"""Posters against the wall filter: the false alarms detect raises on the posters, and how many level 4's Posters
passes on (issue 31).

Built on bench/detect_posters: the robot stands at places along its patrol in each intruder world (the lap's
corners and every --step m between them; the worlds without their agents: no true face in view) and turns on the
spot at 1.5 rad/s, a frame every 0.04 s. Each frame goes through the Detect module (every frame scanned, with and
without its depth check); each alarm, target and sighting it sends goes on to ``robots.patrol.level4:Posters``
with the world's map and the robot's pose of that frame. Printed per world: detect's alarms (each a false alarm:
no person is there) and the alarms Posters passed on. The pose is the robot's own place on the spot, i.e. perfect
localization (the patrol uses amcl's, a few cm and a degree or two off): the bench measures where posters hang
against the map, not amcl.

    .venv/bin/python -m bench.poster_walls [--step 1.0] [--turn 1.5] [--worlds pingpong,office]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import genpy
from geometry_msgs.msg import PoseWithCovarianceStamped

from navigation.grid_messages import grid_msg
from robots.patrol.level4 import Posters
from subsim.sim import Simulation
from subsumption.images import from_array
from subsumption.mapfile import read_map_file
from subsumption.testing import Harness
from subsumption.yamlfile import load as load_yaml
from vision.modules import Detect

from .detect_posters import places

ROOT = Path(__file__).resolve().parent.parent
WORLDS = {  # name: world, the patrol's goals in order (as bench/detect_posters)
    "pingpong": ("experiments/worlds/pingpong_intruder_world.yaml",
                 [(0.98, 0.98), (9.43, 0.98), (9.43, 5.43), (0.98, 5.43)]),
    "office": ("experiments/worlds/office_intruder_world.yaml", [(1.5, 6.0), (18.3, 6.0)]),
}
FRAME_S = 0.04
CONFIGS = {"every frame, no depth check": {"rate": 1.0 / FRAME_S, "depth_check_m": 0.0},
           "every frame, depth check (the patrol's)": {"rate": 1.0 / FRAME_S}}


def world_map(world: Path):
    data = load_yaml(world, "world file")
    path = Path(data["map"])
    return read_map_file(path if path.is_absolute() else world.parent / path)


def spin(sim: Simulation, name: str, place: tuple[float, float], turn: float, params: dict, grid) -> tuple[int, int]:
    """(detect's alarms, alarms Posters passed) over a full turn at `place`."""
    detect = Harness(Detect, params={"below_horizon_px": 16, **params})
    posters = Harness(Posters)  # its camera_x, -0.087 m, is the simulated Kinect's (subsim.world)
    posters.feed("map", grid_msg(grid, 0.0, "map"))
    detect.run_for(1.0)
    robot = sim.robots[name]
    seen = {"alarm": 0, "target": 0, "suspect": 0}
    for k in range(int(math.ceil(2 * math.pi / (turn * FRAME_S)))):
        robot.x, robot.y, robot.theta = place[0], place[1], k * turn * FRAME_S
        frame = sim.render(name)
        stamp = genpy.Time.from_sec(detect.runtime.now())
        pose = PoseWithCovarianceStamped()
        pose.header.stamp, pose.header.frame_id = stamp, "map"
        pose.pose.pose.position.x, pose.pose.pose.position.y = place
        pose.pose.pose.orientation.z = math.sin(robot.theta / 2)
        pose.pose.pose.orientation.w = math.cos(robot.theta / 2)
        posters.feed("pose", pose)
        depth, image = from_array(frame.depth, "32FC1"), from_array(frame.rgb, "rgb8")
        depth.header.stamp = image.header.stamp = stamp
        detect.feed("depth", depth)
        detect.feed("image", image)
        for output in ("alarm", "target", "suspect"):  # in the order detect sends them
            sent = detect.sent(output)
            for msg in sent[seen[output]:]:
                posters.feed(output, msg)
            seen[output] = len(sent)
        detect.run_for(FRAME_S)
    return len(detect.sent("alarm")), len(posters.sent("passed_alarm"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.poster_walls", description=__doc__.split("\n\n")[0])
    parser.add_argument("--step", type=float, default=1.0, help="m between places along the patrol")
    parser.add_argument("--turn", type=float, default=1.5, help="rad/s on the spot")
    parser.add_argument("--worlds", default=",".join(WORLDS), help=f"comma-separated of {', '.join(WORLDS)}")
    args = parser.parse_args(argv)
    print("| world | places | " + " | ".join(f"{c}: detect's false alarms / passed by posters" for c in CONFIGS)
          + " |")
    print("|---|---|" + "---|" * len(CONFIGS))
    failed = False
    for key in args.worlds.split(","):
        world, goals = WORLDS[key]
        start = time.process_time()
        sim = Simulation(str(ROOT / world), seed=1, record=False)
        sim.agents.clear()
        name = next(iter(sim.robots))
        grid = world_map(ROOT / world)
        totals = {config: [0, 0] for config in CONFIGS}
        spots = places(goals, args.step)
        for place in spots:
            for config, params in CONFIGS.items():
                raised, passed = spin(sim, name, (float(place[0]), float(place[1])), args.turn, params, grid)
                totals[config][0] += raised
                totals[config][1] += passed
        failed = failed or any(passed for _, passed in totals.values())
        print(f"| {key} | {len(spots)} | " + " | ".join(f"{r} / {p}" for r, p in totals.values()) + " |", flush=True)
        print(f"  ({time.process_time() - start:.0f} CPU s)", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
