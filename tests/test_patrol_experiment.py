"""The paper's second experiment end to end, in its short form (`subsumption experiment patrol --quick`), as
every CI run must: each level of robots/patrol/patrol.yaml on the real ROS graph (its own master, simulator and
nodes per level) and in-process, Fig. 7, the summary table, a folder per level with the keys other checks read."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from experiments.patrol_experiment import QUICK, SCENES, network_levels

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
        in_process = level in plan.local and not SCENES[level].ros_only
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
