"""map_server's ``map_saver`` as a node of this package: ``rosrun subsumption map_saver -f NAME [map:=TOPIC]``.

It waits for one ``nav_msgs/OccupancyGrid`` on ``map`` (latched, as map_server, SLAM and move_base's costmaps
publish it), and writes ``NAME.pgm`` and ``NAME.yaml`` as map_saver does: a cell of value 0..``--free`` (25) is free
(254 in the image), ``--occ`` (65) and above occupied (0), anything else (-1, unknown, or a cost between) 205; the
image's first row is the map's top; the YAML names the image, the resolution, the origin (x, y, yaw), ``negate: 0``,
``occupied_thresh: 0.65`` and ``free_thresh: 0.196``. map_server reads it back unchanged (tests/test_map_saver.py).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

from subsumption.planar import yaw_of

from .grid_messages import GridMessageError


def _float32(value: float) -> float:
    """A float32 field (the message's resolution) as its shortest decimal: 0.05, not 0.05000000074505806."""
    return float(np.format_float_positional(np.float32(value)))


def map_saver_files(msg, name: str | Path, occupied: int = 65, free: int = 25) -> tuple[Path, Path]:
    """NAME.pgm and NAME.yaml from an OccupancyGrid message; GridMessageError for a message whose size is wrong."""
    import cv2

    info = msg.info
    if info.width * info.height != len(msg.data) or info.width == 0:
        raise GridMessageError(f"the map has {len(msg.data)} cells, its info says {info.width} x {info.height}")
    data = np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width)
    image = np.full(data.shape, 205, dtype=np.uint8)
    image[(data >= 0) & (data <= free)] = 254
    image[data >= occupied] = 0
    base = Path(name)
    pgm, meta = base.with_name(base.name + ".pgm"), base.with_name(base.name + ".yaml")
    if not cv2.imwrite(str(pgm), np.flipud(image)):
        raise OSError(f"{pgm}: could not write the image")
    yaw = yaw_of(info.origin.orientation)
    meta.write_text(yaml.safe_dump({"image": pgm.name, "resolution": _float32(info.resolution),
                                    "origin": [float(info.origin.position.x), float(info.origin.position.y),
                                               round(yaw, 9) + 0.0],
                                    "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}, sort_keys=False))
    return pgm, meta


def main(argv: list[str] | None = None) -> int:
    """`rosrun subsumption map_saver -f NAME [map:=TOPIC]`: wait for one map on the topic and save it."""
    import rospy
    from nav_msgs.msg import OccupancyGrid

    argv = list(sys.argv if argv is None else argv)
    parser = argparse.ArgumentParser(prog="map_saver", description=__doc__.split("\n\n")[0])
    parser.add_argument("-f", dest="name", default="map", help="file name without extension (default: map)")
    parser.add_argument("--occ", type=int, default=65, help="occupied from this value on (default 65)")
    parser.add_argument("--free", type=int, default=25, help="free up to this value (default 25)")
    parser.add_argument("--timeout", type=float, default=0.0, help="wall seconds to wait for a map (0: for ever)")
    args = parser.parse_args(rospy.myargv(argv)[1:])
    if not 0 <= args.free < args.occ <= 100:
        print(f"map_saver: error: need 0 <= --free ({args.free}) < --occ ({args.occ}) <= 100", file=sys.stderr)
        return 2
    rospy.init_node("map_saver", anonymous=True, argv=argv)
    topic = rospy.resolve_name("map")
    rospy.loginfo("map_saver: waiting for a map on %s", topic)
    try:
        msg = rospy.wait_for_message("map", OccupancyGrid, timeout=args.timeout or None)
    except rospy.ROSException:
        print(f"map_saver: error: no map on {topic} within {args.timeout:g} s", file=sys.stderr)
        return 1
    except rospy.ROSInterruptException:
        return 1
    try:
        pgm, meta = map_saver_files(msg, args.name, args.occ, args.free)
    except (GridMessageError, OSError) as error:
        print(f"map_saver: error: {topic}: {error}", file=sys.stderr)
        return 2
    info = msg.info
    print(f"map_saver: {info.width} x {info.height} map at {info.resolution:g} m/cell from {topic} saved to {pgm} "
          f"and {meta}", flush=True)
    return 0
