"""`subsumption localize --bag FILE.bag --map MAP.yaml [--initial-pose X Y YAW | --global] [--out DIR]`: amcl along a
recorded log on a known map, offline (:mod:`navigation.bag_localize`); prints the metrics and, with --out, writes
them to DIR/metrics.json and the estimates over the map to DIR/track.png. Bad input: one line naming the file and
place, exit 2, nothing written."""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from subsumption.mapfile import read_map_file
from subsumption.metricsfile import write_metrics

from .bag_localize import localize_bag, picture, scores
from .bag_read import BagError


def register_localize(commands: argparse._SubParsersAction) -> None:
    """Add `subsumption localize --bag FILE --map MAP.yaml` to the command line (an entry point of
    subsumption.commands)."""
    cmd = commands.add_parser("localize", help="amcl along a recorded bag on a known map, offline; print metrics",
                              description="amcl's filter fed a bag's scans and odometry on a map_server map; scored "
                                          "against /ground_truth when the bag has it (docs/real_data.md).")
    cmd.add_argument("--bag", type=Path, required=True, help="the recorded bag")
    cmd.add_argument("--map", type=Path, required=True, help="a map_server map (YAML)")
    start = cmd.add_mutually_exclusive_group()
    start.add_argument("--initial-pose", type=float, nargs=3, metavar=("X", "Y", "YAW"),
                       help="start pose (default: the bag's /ground_truth pose nearest its first scan)")
    start.add_argument("--global", dest="global_start", action="store_true",
                       help="global localization: start with particles all over the free space, and restart the "
                            "filter round the pose a search of the last scans over the whole map finds unambiguous")
    cmd.add_argument("--scan", default="/scan", help="LaserScan topic (default /scan)")
    cmd.add_argument("--odom", default=None, help="Odometry topic (default /odom, else /tf odom -> base)")
    cmd.add_argument("--seed", type=int, default=0, help="the filter's random seed (default 0)")
    cmd.add_argument("--out", type=Path, default=None,
                     help="folder for metrics.json and track.png, the estimates over the map (made if missing)")
    cmd.set_defaults(func=cmd_localize)


def cmd_localize(args: argparse.Namespace) -> int:
    """`subsumption localize`: run amcl along the bag, print the metrics and write them; bad input exits 2 in one
    line."""
    try:
        run = localize_bag(args.bag, args.map, args.initial_pose, args.global_start, args.scan, args.odom,
                           seed=args.seed)
    except BagError as error:
        print(f"subsumption localize: {error}", file=sys.stderr)
        return 2
    m = {"bag": str(args.bag), "map": str(args.map), "global": args.global_start, **scores(run)}
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        write_metrics(args.out, m)
        scored = f": RMS {m['rms_m']} m, final {m['final_error_m']} m" if m.get("rms_m") is not None else ""
        partial = args.out / ".track.png.partial"  # complete before it takes its name
        try:
            picture(run, read_map_file(args.map), partial, f"{args.bag.name} on {args.map.name}{scored}")
            os.replace(partial, args.out / "track.png")
        finally:
            partial.unlink(missing_ok=True)
    print(json.dumps(m))
    return 0
