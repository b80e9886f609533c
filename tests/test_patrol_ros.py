"""Level 3 of the patrol robot on the real ROS graph (its own master, the simulator node, one node per module
and arbiter, move_base's action over ROS topics), short: in a 6 m room with a map given, it localizes with the
depth scan the depth_scan node makes from the camera's depth image, drives through its first goals in order
through move_base, and touches nothing.

The run's own goal count (the observer listening to move_base's action topics) is not asserted here: on the
ROS graph it has been seen to miss move_base's results (0 reached while the robot went through three goals),
a known fault to fix in experiments/patrol.py; the true path is what this test checks."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from experiments.patrol import PatrolRun, execute

ROOT = Path(__file__).resolve().parent.parent
ROOM = ROOT / "subsim" / "maps" / "room.yaml"  # 6 m x 6 m, walls 0.2 m thick
GOALS = [[1.2, 1.2, 0.0], [4.6, 1.2, 1.57], [4.6, 4.6, 3.14], [1.2, 4.6, -1.57]]


@pytest.mark.timeout(240)
def test_level3_patrols_through_move_base_on_the_ros_graph(tmp_path):
    world = tmp_path / "world.yaml"
    world.write_text(yaml.safe_dump({"map": str(ROOM), "robots": [
        {"name": "robot0", "namespace": "", "kind": "turtlebot", "start": [1.2, 1.2, 0.0]}]}))
    goals = tmp_path / "goals.yaml"
    goals.write_text(yaml.safe_dump(GOALS))
    out = tmp_path / "out"
    result = execute(PatrolRun(3, world, out, 40.0, seed=1, runtime="ros", goals_file=goals, map_yaml=ROOM,
                               rate=3.0, progress=False))
    m = json.loads((out / "metrics.json").read_text())
    assert m["runtime"] == "ros" and m["complete"], m.get("ended")
    assert m["collisions"] == 0 and m["goals_sent"] >= 1
    assert m["sim_time_s"] > 35
    # the robot's true path (the simulator's, scoring only) passes goals 1 and 2, in that order
    path = np.array(result.trajectory)
    at = [int(np.argmax(np.hypot(*(path - goal[:2]).T) < 0.3)) for goal in GOALS[1:3]]
    assert 0 < at[0] < at[1], at
    assert (out / "logs").is_dir() and (out / "trajectory.png").exists()
