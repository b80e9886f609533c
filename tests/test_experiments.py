"""The wander robot in the simulator: the `subsumption run` command, the paper's results as numbers, and the
ROS graph agreeing with the in-process runtime."""
from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from experiments.runner import RunSpec, run_local
from subsim import world_path
from subsim.mapio import save_map

ROOT = Path(__file__).resolve().parent.parent
APPROACH = ROOT / "experiments" / "worlds" / "approach_world.yaml"
SEEDS = range(1, 6)
TEN_MINUTES = 600.0


def subsumption(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "subsumption.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, **kwargs)


def test_run_writes_a_trajectory_picture_and_the_metrics(tmp_path):
    done = subsumption("run", "wander", "--level", "1", "--map", str(ROOT / "subsim/maps/corridors.yaml"),
                       "--start", "2,2.25,0", "--duration", "60", "--seed", "3", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert {"collisions", "distance_m", "coverage_m2", "sim_time_s", "wall_time_s"} <= metrics.keys()
    assert metrics["sim_time_s"] == pytest.approx(60, abs=0.2)
    assert metrics["collisions"] == 0 and metrics["distance_m"] > 5
    assert set(metrics["upper_in_control"]) == {"suppressor_turn_heading"}
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000


def test_any_map_server_map_works_and_a_free_start_is_picked(tmp_path):
    grid = np.zeros((120, 160), dtype=np.int8)          # 8 m x 6 m at 5 cm, walls all round, one pillar
    grid[:4, :] = grid[-4:, :] = grid[:, :4] = grid[:, -4:] = 100
    grid[50:70, 70:90] = 100
    map_yaml = save_map(grid, tmp_path / "hall.yaml", 0.05)
    done = subsumption("run", "wander", "--level", "2", "--map", str(map_yaml), "--duration", "30",
                       "--out", str(tmp_path / "out"))
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert metrics["collisions"] == 0 and metrics["coverage_m2"] > 1.0


def test_a_bad_map_is_an_error_naming_the_file_and_the_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: missing.pgm\nresolution: -1\norigin: [0, 0, 0]\n")
    done = subsumption("run", "wander", "--level", "0", "--map", str(bad), "--duration", "5",
                       "--out", str(tmp_path / "out"))
    assert done.returncode == 2
    assert "bad.yaml" in done.stderr and ("resolution" in done.stderr or "image" in done.stderr)
    assert "Traceback" not in done.stderr


def test_a_parameter_override_for_a_module_the_network_lacks_names_it_and_the_file():
    spec = RunSpec("wander", 1, world_path("corridors"), 1.0, params={"wandr.spread": 1.0})
    with pytest.raises(ValueError, match=r"wandr\.spread.*no module 'wandr'.*wander\.yaml"):
        run_local(spec)


def test_level_0_stays_in_the_open_and_moves_away_when_another_robot_approaches():
    result = run_local(RunSpec("wander", 0, APPROACH, 120.0, seed=0))
    path = np.array(result.trajectory)
    visitor = np.array(result.agents[0])
    assert result.metrics["collisions"] == 0
    assert 0.5 < result.metrics["distance_m"] < 5.0, "it moves away, a little, and only then"
    assert np.allclose(path[: len(path) // 20], path[0], atol=0.05), "it keeps still before the visitor comes"
    closest = min(np.hypot(*(path[-1] - visitor[-1])), *(np.hypot(*(p - v)) for p, v in zip(path, visitor)))
    assert closest > 0.18 + 0.18


def _ten_minutes(args: tuple[str, int, int]) -> dict:
    world, level, seed = args
    return run_local(RunSpec("wander", level, world_path(world), TEN_MINUTES, seed=seed)).metrics


@pytest.fixture(scope="module")
def ten_minute_runs() -> dict[tuple[str, int, int], dict]:
    """Levels 1 and 2, both shipped maps, 5 seeds, 10 simulated minutes each, in the local runtime."""
    jobs = [(world, level, seed) for world in ("corridors", "sparse") for level in (1, 2) for seed in SEEDS]
    with ProcessPoolExecutor(max_workers=2) as pool:
        return dict(zip(jobs, pool.map(_ten_minutes, jobs)))


@pytest.mark.parametrize("world", ["corridors", "sparse"])
@pytest.mark.parametrize("level", [1, 2])
def test_levels_1_and_2_never_collide_in_ten_minutes_for_five_seeds(ten_minute_runs, world, level):
    collisions = {seed: ten_minute_runs[(world, level, seed)]["collisions"] for seed in SEEDS}
    assert collisions == {seed: 0 for seed in SEEDS}
    for seed in SEEDS:
        assert ten_minute_runs[(world, level, seed)]["sim_time_s"] == pytest.approx(TEN_MINUTES, abs=0.2)


@pytest.mark.parametrize("world", ["corridors", "sparse"])
def test_level_2_covers_at_least_one_and_a_half_times_the_ground_of_level_1(ten_minute_runs, world):
    """The paper's claim as the issue's bar: exploring (level 2) covers more than wandering aimlessly (level 1)
    in the same 10 minutes, by 1.5 times or more on the mean of 5 seeds."""
    coverage = {level: statistics.mean(ten_minute_runs[(world, level, seed)]["coverage_m2"] for seed in SEEDS)
                for level in (1, 2)}
    assert coverage[2] >= 1.5 * coverage[1], coverage


def test_the_network_and_its_module_code_run_on_ros_and_agree_with_the_local_runtime(tmp_path):
    """The same network file and modules on the real ROS graph (own master, simulator node, a node per module
    and arbiter, rosbag recording) and in-process: no collisions in either, similar ground covered."""
    world = world_path("sparse")
    done = subsumption("run", "wander", "--level", "2", "--world", str(world), "--duration", "60",
                       "--runtime", "ros", "--rate", "3", "--bag", str(tmp_path / "run.bag"),
                       "--out", str(tmp_path / "ros"), timeout=240)
    assert done.returncode == 0, done.stdout + done.stderr
    ros = json.loads((tmp_path / "ros" / "metrics.json").read_text())
    local = run_local(RunSpec("wander", 2, world, 60.0, seed=0)).metrics
    assert ros["collisions"] == 0 and local["collisions"] == 0
    assert ros["sim_time_s"] > 50
    assert 0.5 < ros["coverage_m2"] / local["coverage_m2"] < 2.0, (ros["coverage_m2"], local["coverage_m2"])
    assert set(ros["upper_in_control"]) == set(local["upper_in_control"]) == {
        "suppressor_turn_heading", "inhibitor_wander_heading", "suppressor_avoid_heading"}
    info = subprocess.run(["rosbag", "info", str(tmp_path / "run.bag")], capture_output=True, text=True)
    assert info.returncode == 0, info.stderr
    for topic in ("/cmd_vel", "/scan", "/sonar", "/clock", "/wander/heading", "/suppressor_turn_heading/output"):
        assert topic in info.stdout
    assert not math.isnan(ros["distance_m"])
