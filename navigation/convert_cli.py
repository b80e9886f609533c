"""`subsumption convert carmen LOG[.gz] OUT.bag [--odom-drift PERCENT] [--seed S] [--max-range M] [--raw]`.

A Carmen log (Radish's data sets) as a ROS bag that ``rosbag play --clock`` plays into ``rosrun subsumption slam``
or that ``subsumption map --bag`` maps offline. Topics, frames and the drift model: :mod:`navigation.carmen_bag`,
:func:`navigation.carmen.drifted`, docs/real_data.md. A line that cannot be read stops the conversion with
``LOG:LINE`` named, exit code 2, and no bag written.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .carmen import CarmenError, read_log
from .carmen_bag import DEFAULT_MAX_RANGE, write_bag


def register_convert(commands: argparse._SubParsersAction) -> None:
    """Add `subsumption convert carmen LOG OUT.bag` to the command line (an entry point of subsumption.commands)."""
    cmd = commands.add_parser("convert", help="turn a recorded log of another format into a ROS bag",
                              description="Turn a recorded log of another format into a ROS bag.")
    formats = cmd.add_subparsers(dest="format", required=True, metavar="FORMAT")
    carmen = formats.add_parser(
        "carmen", help="a Carmen log (FLASER / ROBOTLASER1 / ODOM lines, plain or .gz), e.g. Radish's",
        description="A Carmen log as a bag with /scan, /odom, /tf, /tf_static and, for corrected logs, "
                    "/ground_truth (the corrected poses). Corrected logs have no odometry of their own: it is made "
                    "from the corrected poses with a seeded drift (docs/real_data.md).")
    carmen.add_argument("log", type=Path, help="the Carmen log (.log or .log.gz)")
    carmen.add_argument("out", type=Path, help="the bag to write")
    carmen.add_argument("--odom-drift", type=float, default=0.0, metavar="PERCENT",
                        help="odometry error in percent of the distance driven and the angle turned (default 0)")
    carmen.add_argument("--seed", type=int, default=1, help="seed of the drift (default 1)")
    carmen.add_argument("--max-range", type=float, default=DEFAULT_MAX_RANGE,
                        help=f"m: the scan's range_max; longer returns are written as +inf (default "
                             f"{DEFAULT_MAX_RANGE:g})")
    carmen.add_argument("--raw", action="store_true",
                        help="take the log as raw: its poses are the robot's odometry, not a reference (no "
                             "/ground_truth); for a raw ROBOTLASER1 log, whose lines carry one pose and so read as "
                             "corrected")
    carmen.set_defaults(func=cmd_convert_carmen)


def cmd_convert_carmen(args: argparse.Namespace) -> int:
    """`subsumption convert carmen`: write the bag; a bad log or argument is one line naming the place, exit 2."""
    try:
        if not 0 <= args.odom_drift <= 100:
            raise CarmenError(f"--odom-drift must be within 0..100 percent, got {args.odom_drift}")
        if not args.max_range > 0:
            raise CarmenError(f"--max-range must be > 0, got {args.max_range}")
        log = read_log(args.log)
        done = write_bag(log, args.out, args.odom_drift, args.seed, args.max_range, raw=args.raw)
    except CarmenError as error:
        print(f"subsumption convert: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"subsumption convert: {args.out}: {error.strerror or error}", file=sys.stderr)
        return 2
    kind = "corrected" if done.corrected else "raw"
    note = f" ({done.stamps_note}; docs/real_data.md)" if done.stamps_note else ""
    drift = (f", odometry drifted {args.odom_drift:g}% (seed {args.seed}): {done.odometry_ate_m:.2f} m RMS from the "
             f"corrected poses" if done.corrected else ", its own odometry" +
             (f", drifted {args.odom_drift:g}% further (seed {args.seed})" if args.odom_drift else ""))
    print(f"{args.out}: {done.scans} scans over {done.duration_s:.0f} s from a {kind} log{note}{drift}")
    return 0
