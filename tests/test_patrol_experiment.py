"""The paper's second experiment end to end, in its short form (`subsumption experiment patrol --quick`), as
every CI run must: each level of robots/patrol/patrol.yaml on the real ROS graph (its own master, simulator and
nodes per level) and in-process, Fig. 7, the summary table, a folder per level with the keys other checks read.
Level 4's run is issue 11's end-to-end test on the real ROS graph: the target found on the camera's pixels, the
robot stopped, the alarm raised, the target followed, lost at the door, and the patrol resumed."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from experiments.patrol_experiment import QUICK, network_levels

PATROL_KEYS = {"collisions", "sim_time_s", "wall_time_s", "goals_sent", "goals_reached", "alarms"}


@pytest.mark.timeout(600)
def test_the_patrol_experiment_runs_every_level_and_writes_fig7_and_the_table(tmp_path):
    out = tmp_path / "patrol"
    log = tmp_path / "experiment.log"
    with log.open("w") as sink:
        done = subprocess.run([sys.executable, "-m", "subsumption.cli", "experiment", "patrol", "--quick",
                               "--out", str(out)], stdout=sink, stderr=subprocess.STDOUT, timeout=600,
                              env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert done.returncode == 0, log.read_text()[-3000:]
    levels = network_levels()
    assert levels >= 4  # levels 0-3 at least
    figure = mpimg.imread(out / "fig7_trajectories.png")
    assert figure.shape[0] > 400 and np.std(figure) > 0.05  # a drawn figure, not a blank page
    table = (out / "summary.md").read_text()
    plan = QUICK
    for level in [level for level in range(levels) if level in plan.ros]:
        folder = out / f"level{level}"
        ros = json.loads((folder / "metrics.json").read_text())
        assert PATROL_KEYS <= set(ros) and ros["runtime"] == "ros"
        assert ros["collisions"] == 0, (level, ros["collisions"])
        assert (folder / "trajectory.png").exists()
        in_process = level in plan.local and not plan.scene(level).ros_only
        if in_process:
            local = json.loads((folder / "local" / "metrics.json").read_text())
            assert PATROL_KEYS <= set(local) and local["runtime"] == "local"
            assert local["collisions"] == 0, (level, local["collisions"])
            assert (folder / "local" / "trajectory.png").exists()
        runs = table.split("\n\n")[0]  # the first table: a row per run
        assert runs.count(f"\n| {level} |") == (2 if in_process else 1)  # a ROS row (and a local row)
    # level 5 is left out of the short form (75 s at 1x); tests/test_patrol_level5.py runs its operator live
    assert 5 not in plan.ros and "left out of this form" in table
    # level 3 patrols with the map its own SLAM built: goals are sent and, in a minute in-process, reached
    assert (out / "map" / "map.yaml").exists()
    local3 = json.loads((out / "level3" / "local" / "metrics.json").read_text())
    assert local3["goals_sent"] >= 2 and local3["goals_reached"] >= 1
    if levels > 4:  # level 4 on the ROS graph, the cut scene: the encounter from start to end
        m = json.loads((out / "level4" / "metrics.json").read_text())
        intruder = [a for a in m["alarm_log"] if a["name"] == "intruder"]
        assert len(intruder) == 1, m["alarm_log"]  # the alarm, raised once ...
        # ... and placed on the map from the camera and amcl near where the target stood (x 3.6, y 5.4); found
        # 4-5 m off, its range from the face's size is less sure than in the in-process test (0.13-0.77 m measured)
        assert math.hypot(intruder[0]["x"] - 3.6, intruder[0]["y"] - 5.4) <= 1.0, intruder
        if m["detected_at_s"] is not None:  # the scorer found the alarm's box on the true face (see the README)
            # the inhibitor stops the robot: it stands still soon after the alarm. How soon (target 0.5 s simulated;
            # 0.38-0.62 s measured) depends on the machine's load on a ROS graph: a figure of summary.md, not a
            # timed assertion here
            assert m["stopped_at_s"] is not None and 0 <= m["stopped_at_s"] - m["detected_at_s"] <= 2.0
        pursuit = m["pursuits"][0]
        assert abs(pursuit["start_s"] - intruder[0]["raised_at_s"]) < 0.5  # held from the alarm on
        assert m["followed_s"] >= 2.0 and m["collisions_while_following"] == 0
        assert pursuit["lost_at_s"] is not None and pursuit["resumed_patrol_at_s"] is not None  # patrols on
        assert pursuit["start_s"] < pursuit["lost_at_s"] < pursuit["resumed_patrol_at_s"]
        assert (out / "camera_strip_level4.png").exists() and "| 4 | ros 1x |" in table
