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
from metrics_writes import MetricsWrites

from experiments.patrol_experiment import QUICK, network_levels
from experiments.worker import InProcessWork

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
    # and on the ROS graph, through move_base's action over ROS topics, localized on the depth scan the depth_scan
    # node makes from the camera: goal 0 reached (move_base's word), the next one sent
    ros3 = json.loads((out / "level3" / "metrics.json").read_text())
    assert ros3["goals_sent"] >= 2 and ros3["goal_log"][0]["goal"] == 0, ros3["goal_log"]
    assert ros3["goal_log"][0]["status"] == "SUCCEEDED", ros3["goal_log"]
    if levels > 4:  # level 4 on the ROS graph, the cut scene: the encounter from start to end
        m = json.loads((out / "level4" / "metrics.json").read_text())
        assert m["scene_happened"] is True and m["scene_missing"] == [] and "level 4: the scene happened" in table
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


# The scene verdict, on metrics dicts (no run): level 5's failing run of the demo (the face seen once, never
# confirmed; the operator never saw it and sent nothing) against runs in which every event happened.
LEVEL4_DONE = {"alarm_log": [{"name": "intruder", "raised_at_s": 7.9}], "pursuits": [{"start_s": 7.9}],
               "followed_s": 6.2, "resumed_patrol_at_s": 21.0}
LEVEL5_DONE = {"operator_commands": 112, "resumed_patrol_at_s": 24.0,
               "operator": {"selected": [{"at_s": 5.3, "box": [300, 150, 50, 50]}], "released_at_s": 23.3}}
LEVEL5_MISSED = {"operator_commands": 0, "resumed_patrol_at_s": None, "detected_at_s": None,
                 "operator": {"selected": [], "missed": [], "released_at_s": None}}


def test_scene_missing_names_what_of_a_scene_did_not_happen():
    from experiments.patrol_scene import scene_missing

    assert scene_missing(4, LEVEL4_DONE) == [] and scene_missing(5, LEVEL5_DONE) == []
    assert scene_missing(5, LEVEL5_MISSED) == ["target selected by the operator", "operator commands sent",
                                               "robot released by the operator", "patrol resumed after the release"]
    assert scene_missing(4, {**LEVEL4_DONE, "pursuits": []}) == ["pursuit started (levels 0-3 stopped)"]
    assert scene_missing(4, {**LEVEL4_DONE, "alarm_log": [{"name": "goal_failed"}], "followed_s": 0.0}) == [
        "intruder alarm raised", "target followed"]
    assert scene_missing(2, {}) is None  # a behaviour over the whole run: nothing to miss


def test_the_summary_line_says_when_a_pursuit_never_closed_in():
    from experiments.patrol import following_distance

    assert following_distance({"mean_follow_distance_m": 1.37, "mean_follow_distance_with_approach_m": 2.28}) == \
        "1.37 m"
    assert following_distance({"mean_follow_distance_m": None, "mean_follow_distance_with_approach_m": 3.1}) == \
        "3.1 m with the approach (never closed in)"


def test_a_run_s_scene_verdict_is_two_keys_for_levels_with_events_and_none_for_the_others():
    from experiments.patrol_scene import scene_verdict

    assert scene_verdict(5, LEVEL5_MISSED) == {"scene_happened": False, "scene_missing": [
        "target selected by the operator", "operator commands sent", "robot released by the operator",
        "patrol resumed after the release"]}
    assert scene_verdict(4, LEVEL4_DONE) == {"scene_happened": True, "scene_missing": []}
    assert scene_verdict(3, LEVEL4_DONE) == {}  # levels 0-3 keep the keys they always had


def _experiment_with(tmp_path, monkeypatch, level5: dict) -> tuple[int, Path]:
    """main() of the experiment with levels 4 and 5 whose runs write the given metrics as a run's last step does
    (experiments.patrol.execute: the scene's verdict added, then written once; no ROS). The experiment itself must
    write no metrics.json: each level's is written exactly once."""
    from experiments import patrol_experiment as pe
    from subsumption.metricsfile import write_metrics
    from experiments.patrol_scene import scene_verdict

    def run_level(level, out, plan, seed, work=None, nav_map=None):
        metrics = {"sim_time_s": 1.0, "wall_time_s": 1.0, "collisions": 0,
                   **(LEVEL4_DONE if level == 4 else level5)}
        metrics.update(scene_verdict(level, metrics))
        (out / f"level{level}").mkdir(parents=True, exist_ok=True)
        write_metrics(out / f"level{level}", metrics)
        return json.loads((out / f"level{level}" / "metrics.json").read_text()), None  # as run_level reads it

    monkeypatch.setattr(pe, "run_level", run_level)
    monkeypatch.setattr(pe, "built_map", lambda world, out, seed, duration: out / "map" / "map.yaml")
    monkeypatch.setattr(pe, "InProcessWork", lambda: InProcessWork(inline=True))  # stand-in jobs: no worker
    monkeypatch.setattr(pe, "network_levels", lambda: 6)
    out = tmp_path / "patrol"
    with MetricsWrites() as writes:
        status = pe.main(out, pe.Plan(ros={4: 1.0, 5: 1.0}, rate=1.0, local={}, map_duration=0.0))
    assert writes.counts == {(out / "level4").resolve(): 1, (out / "level5").resolve(): 1}, writes.counts
    return status, out


def test_the_experiment_says_a_scene_did_not_happen_and_exits_non_zero_with_everything_written(tmp_path, monkeypatch,
                                                                                               capsys):
    status, out = _experiment_with(tmp_path, monkeypatch, LEVEL5_MISSED)
    assert status == 3
    five = json.loads((out / "level5" / "metrics.json").read_text())
    assert five["scene_happened"] is False and "operator commands sent" in five["scene_missing"]
    assert five["operator_commands"] == 0  # what the run recorded is kept
    four = json.loads((out / "level4" / "metrics.json").read_text())
    assert four["scene_happened"] is True and four["scene_missing"] == []
    summary = (out / "summary.md").read_text()
    assert "level 5: the scene did NOT happen, missing: target selected by the operator" in summary
    assert "level 4: the scene happened" in summary and (out / "fig7_trajectories.png").exists()
    assert "level 5: the scene did NOT happen" in capsys.readouterr().err

    status, out = _experiment_with(tmp_path / "ok", monkeypatch, LEVEL5_DONE)
    assert status == 0 and json.loads((out / "level5" / "metrics.json").read_text())["scene_happened"] is True


def test_make_demo_queues_the_patrol_map_behind_the_wander_robot_s_in_process_runs_in_one_worker(tmp_path,
                                                                                                   monkeypatch):
    """`subsumption demo`: one worker for both experiments; the patrol robot's map is given to it right after the
    wander robot's in-process runs (so it is built while the wander robot's ROS runs go on), and the patrol
    experiment uses that map job instead of queueing its own."""
    import argparse

    from experiments import cli, demo
    from experiments import patrol_experiment as pe

    given: list[str] = []

    class Recording(InProcessWork):
        def submit(self, job, *args):
            given.append(getattr(job, "__name__", "job"))
            return super().submit(job, *args)

    def wander_local_run() -> dict:
        return {"level": 0}

    def map_built(world, out, seed, duration) -> Path:
        return out / "map" / "map.yaml"

    def wander_experiment(out, ros_duration, rate, local_duration, work, queue_next):
        work.submit(wander_local_run)
        queue_next()
        given.append("wander ROS runs")
        return 0

    patrol_runs: list = []
    monkeypatch.setattr(cli, "InProcessWork", lambda: Recording(inline=True))
    monkeypatch.setattr(pe, "built_map", map_built)
    monkeypatch.setattr(demo, "main", wander_experiment)
    monkeypatch.setattr(pe, "main", lambda out, plan, work=None, map_job=None: patrol_runs.append(map_job) or 0)
    args = argparse.Namespace(out=tmp_path, ros_duration=1.0, rate=1.0, local_duration=1.0, wander_only=False)
    assert cli.cmd_demo(args) == 0
    assert given == ["wander_local_run", "map_built", "wander ROS runs"]
    assert len(patrol_runs) == 1 and patrol_runs[0].result() == (tmp_path / "patrol").resolve() / "map" / "map.yaml"
