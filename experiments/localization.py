"""Localization runs: the particle filter (navigation.amcl:Amcl) on a known map while the wander robot drives;
its estimate is scored against the truth the simulator records (never fed to the filter).

The map is the world's own (the simulator publishes it) or any map_server map, e.g. one SLAM built
(``subsumption map``), served on ``/map``. The simulator does not publish ``map -> odom``: the filter does.
Scores: ``loc_rmse_m`` and ``loc_rmse_yaw_deg`` over every odometry message after ``settle`` seconds (the
pose ``map -> odom -> base_link`` the robot would use), and ``loc_max_m``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from nav_msgs.msg import OccupancyGrid

from navigation.grid_messages import grid_msg
from subsumption.mapfile import read_map_file
from subsumption.planar import wrap

from .launch_local import launch_local
from .mapping import MappingRecorder, navigation_network, wander_driver


def localization_error(recorder: MappingRecorder, settle: float = 0.0) -> dict:
    """RMS position and yaw errors of the online estimate after `settle` s."""
    errors, yaw_errors = [], []
    for t, pose in recorder.online:
        true = recorder.truth.get(round(t, 3))
        if true is None or t < settle:
            continue
        errors.append(math.hypot(pose[0] - true[0], pose[1] - true[1]))
        yaw_errors.append(float(wrap(pose[2] - true[2])))
    if not errors:
        return {"loc_rmse_m": math.nan, "loc_rmse_yaw_deg": math.nan, "loc_max_m": math.nan, "loc_samples": 0}
    e = np.asarray(errors)
    return {"loc_rmse_m": round(float(np.sqrt(np.mean(e ** 2))), 4),
            "loc_rmse_yaw_deg": round(math.degrees(float(np.sqrt(np.mean(np.square(yaw_errors))))), 3),
            "loc_max_m": round(float(e.max()), 4), "loc_samples": len(errors)}


def run_local(world: Path, duration: float, seed: int, initial: list[float], initial_sigma: tuple[float, float],
              map_yaml: Path | None = None, amcl_params: dict | None = None, settle: float = 0.0) -> dict:
    """amcl (navigation/networks/localize.yaml) on the world's map, or on `map_yaml` served on /map, while the
    wander robot drives (:func:`~experiments.launch_local.launch_local`). `initial`: [x, y, yaw] given to the
    filter as its start (the truth, or off it on purpose); `initial_sigma`: (m, rad) of its spread."""
    params = {"initial_pose_x": initial[0], "initial_pose_y": initial[1], "initial_pose_a": initial[2],
              "initial_cov_xx": initial_sigma[0] ** 2, "initial_cov_yy": initial_sigma[0] ** 2,
              "initial_cov_aa": initial_sigma[1] ** 2, "seed": seed, **(amcl_params or {})}

    def setup(runtime) -> MappingRecorder:
        if map_yaml is not None:  # a map server: the map, latched, before anyone asks for it
            server = runtime.node("map_server")
            server.publisher("/map", OccupancyGrid, latch=True).publish(grid_msg(read_map_file(map_yaml), 0.0, "map"))
        return MappingRecorder(runtime.node("localization_recorder"))

    run = launch_local(world, [(navigation_network("localize", {"amcl": params}), None), wander_driver(seed)],
                       duration, seed, {"map_to_odom": False, "publish_map": map_yaml is None}, setup=setup)
    recorder, amcl = run.prepared, run.module("amcl")
    metrics = localization_error(recorder, settle)
    metrics.update({"collisions": recorder.collisions, "sim_time_s": round(recorder.last_time, 3),
                    "wall_time_s": round(run.wall, 3), "cpu_time_s": round(run.cpu, 3),
                    "particles": len(amcl.filter.particles) if amcl.filter else 0})
    return metrics
