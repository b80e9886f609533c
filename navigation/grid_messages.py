"""nav_msgs/OccupancyGrid to and from :class:`~subsumption.mapfile.OccupancyMap` (the core's map type).

Both share a layout (row 0 at the lowest y, values 0 free, 100 occupied, -1 unknown), so the conversion only
reshapes. A rotated map origin is refused with a message naming the topic, as the map file reader does.
"""
from __future__ import annotations

import genpy
import numpy as np
from nav_msgs.msg import MapMetaData, OccupancyGrid
from std_msgs.msg import Header

from subsumption.mapfile import OCCUPIED, OccupancyMap

from subsumption.planar import pose_msg, yaw_of


class GridMessageError(ValueError):
    """An OccupancyGrid message cannot be used; the message names the topic and the field."""


def grid_msg(grid: OccupancyMap, stamp: float, frame: str) -> OccupancyGrid:
    rows, cols = grid.shape
    info = MapMetaData(map_load_time=genpy.Time.from_sec(max(stamp, 0.0)), resolution=grid.resolution,
                       width=cols, height=rows, origin=pose_msg(np.array([grid.origin[0], grid.origin[1], 0.0])))
    return OccupancyGrid(header=Header(0, genpy.Time.from_sec(max(stamp, 0.0)), frame), info=info,
                         data=grid.occupancy.ravel().tolist())


def grid_of(msg: OccupancyGrid, topic: str = "map") -> OccupancyMap:
    info = msg.info
    if info.width * info.height != len(msg.data):
        raise GridMessageError(f"{topic}: data has {len(msg.data)} cells, info says {info.width} x {info.height}")
    if not info.resolution > 0:
        raise GridMessageError(f"{topic}: info.resolution must be > 0, got {info.resolution}")
    if abs(yaw_of(info.origin.orientation)) > 1e-6:
        raise GridMessageError(f"{topic}: info.origin is rotated; only yaw 0 is supported")
    data = np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width)
    occupancy = np.where(data < 0, -1, np.where(data >= 50, OCCUPIED, 0)).astype(np.int8)  # any p >= 0.5 occupied
    return OccupancyMap(occupancy, float(info.resolution), (info.origin.position.x, info.origin.position.y), topic)
