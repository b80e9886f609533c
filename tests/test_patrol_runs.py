"""The patrol robot in the simulator (local runtime, short runs): level 0 backs away from a person walking at it
without touching anyone; level 1 backs off and turns away from the side of a bumper hit, a test per side; the
network file checks and draws."""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from metrics_writes import MetricsWrites

import subsim.local
from experiments.patrol import CAMERA, PatrolRun, execute
from experiments.runner import ROBOTS, RunSpec, configured
from subsumption import LocalRuntime
from subsumption.network import check_file, load
from subsumption.network.local import build_local

ROOT = Path(__file__).resolve().parent.parent
ROOM = ROOT / "subsim" / "maps" / "room.yaml"  # 6 m x 6 m, walls 0.2 m thick


def room_world(tmp_path: Path, start: list[float]) -> Path:
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump({"map": str(ROOM), "robots": [{"name": "robot0", "namespace": "", "start": start}]}))
    return path


def test_level0_backs_away_from_a_person_walking_at_it_without_contact(tmp_path):
    with MetricsWrites() as writes:
        result = execute(PatrolRun(0, room_world(tmp_path, [3.0, 3.0, 0.0]), tmp_path / "out", 8.0, progress=False))
    assert writes.counts == {(tmp_path / "out").resolve(): 1}  # the result filled, then written once
    assert "scene_happened" not in result.metrics  # a behaviour over the whole run: no scene verdict
    robot = np.array(result.trajectory)
    person = np.array(result.agents[0])
    n = min(len(robot), len(person))
    gap = np.hypot(*(robot[:n] - person[:n]).T)
    assert result.metrics["collisions"] == 0
    assert robot[0, 0] - robot[:, 0].min() > 1.0  # backed away along its line, more than a metre
    assert abs(robot[:, 1] - 3.0).max() < 0.3
    assert gap.min() > 0.18 + 0.25 + 0.2  # never within 20 cm of the person
    assert person[:, 0].min() < 2.5  # the person did come on, past where the robot stood
    assert (tmp_path / "out" / "trajectory.png").stat().st_size > 10_000


def bumped(tmp_path: Path, yaw: float) -> np.ndarray:
    """Level 1 with the robot started touching the room's lower wall (y = 0.2) at heading `yaw`: the simulator's
    history (t, x, y, yaw) for 2.5 s."""
    world = tmp_path / "bump_world.yaml"
    world.write_text(yaml.safe_dump({"map": str(ROOM), "robots": [
        {"name": "robot0", "namespace": "", "start": [3.0, 0.2 + 0.18 + 0.003, yaw],
         "sensors": {"laser": False, "camera": dict(CAMERA)}}]}))  # the depth scan from the camera, as in a run
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, world, seed=0)
    build_local(configured(load(ROBOTS["patrol"]), RunSpec("patrol", 1, world, 2.5)), runtime, 1)
    runtime.run_for(2.5)
    return bridge.sim.history("robot0")


@pytest.mark.parametrize("side, yaw, turn", [("right", 0.0, 1.0), ("left", math.pi, -1.0),
                                             ("centre", -math.pi / 2, 1.0)])
def test_level1_on_a_bumper_hit_backs_off_then_turns_away_from_that_side(tmp_path, side, yaw, turn):
    history = bumped(tmp_path, yaw)
    t, x, y, heading = history.T
    turned = np.unwrap(heading) - heading[0]
    backing = t <= 0.8
    assert np.all(np.abs(turned[backing]) < 0.02), side  # first straight back...
    moved = np.array([x[backing][-1] - x[0], y[backing][-1] - y[0]])
    assert moved @ [math.cos(yaw), math.sin(yaw)] < -0.12, side  # ...backwards, away from the contact
    assert turned[np.searchsorted(t, 1.7)] * turn > 0.8, side  # then turning away from the side hit


def test_patrol_network_checks_and_draws(tmp_path):
    from subsumption.network.graph import draw

    result = check_file(ROBOTS["patrol"])
    assert result.ok, [str(e) for e in result.errors]
    out = draw(result.wiring, tmp_path / "patrol.png")
    assert Path(out).stat().st_size > 10_000


ROOM_GOALS = [[1.2, 1.2, 0.0], [4.6, 1.2, 1.57], [4.6, 3.0, 3.14]]


def test_level3_patrols_its_goals_in_order_through_move_base(tmp_path):
    goals = tmp_path / "goals.yaml"
    goals.write_text(yaml.safe_dump(ROOM_GOALS))
    result = execute(PatrolRun(3, room_world(tmp_path, [1.2, 1.2, 0.0]), tmp_path / "out", 35.0, goals_file=goals,
                               map_yaml=ROOM, progress=False))
    m = result.metrics
    assert m["collisions"] == 0
    assert m["goals_reached"] >= 3 and m["goals_in_order"], m["goal_log"]
    assert m["laps"] >= 1 and m["alarms"] == 0
    assert (tmp_path / "out" / "trajectory.png").exists()


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(ROOT / ".venv" / "bin" / "subsumption"), "run", "patrol", *args],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)


@pytest.mark.parametrize("goal, problem", [([4.1, 4.1, 0.0], "in a wall"), ([7.0, 1.0, 0.0], "off")])
def test_a_goal_in_a_wall_or_off_the_map_is_refused_before_the_run(tmp_path, goal, problem):
    goals = tmp_path / "bad_goals.yaml"
    goals.write_text(yaml.safe_dump([[1.2, 1.2, 0.0], goal]))
    done = cli("--level", "3", "--world", str(room_world(tmp_path, [1.2, 1.2, 0.0])), "--map", str(ROOM),
               "--goals", str(goals), "--duration", "600", "--out", str(tmp_path / "out"))
    assert done.returncode == 2
    assert f"{goals}: goal 1 " in done.stderr and problem in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "out" / "metrics.json").exists()


def test_without_move_base_the_run_stops_with_a_clear_error_after_a_bounded_wait(tmp_path, monkeypatch):
    from experiments import patrol as patrol_experiment, runner

    network = yaml.safe_load(Path(ROBOTS["patrol"]).read_text())
    top = network["levels"][3]
    top["modules"] = [m for m in top["modules"] if m["name"] != "move_base"]
    top["arbiters"] = []
    path = tmp_path / "patrol_without_move_base.yaml"
    path.write_text(yaml.safe_dump(network))
    monkeypatch.setitem(runner.ROBOTS, "patrol", path)
    monkeypatch.setattr(patrol_experiment, "SERVER_WAIT", 3.0)
    with pytest.raises(patrol_experiment.MoveBaseUnavailable, match="move_base did not answer .* within 3 s"):
        execute(PatrolRun(3, room_world(tmp_path, [1.2, 1.2, 0.0]), tmp_path / "out", 600.0,
                          goals_file=None, map_yaml=ROOM, progress=False))


def test_a_patrol_run_on_ros_records_the_bag_and_mcap_it_is_asked_for(tmp_path, monkeypatch):
    """`run patrol --bag/--mcap` hands both files to the ROS run (they were accepted and then ignored)."""
    import experiments.patrol
    from experiments.runner import RunCutShort
    from subsumption.cli import main

    handed: list[RunSpec] = []

    def run_ros(spec, **_):
        handed.append(spec)
        raise RunCutShort("not started: the test only looks at what the run was given")

    monkeypatch.setattr(experiments.patrol, "run_ros", run_ros)
    code = main(["run", "patrol", "--level", "0", "--world", str(room_world(tmp_path, [3.0, 3.0, 0.0])),
                 "--runtime", "ros", "--duration", "2", "--bag", str(tmp_path / "run.bag"),
                 "--mcap", str(tmp_path / "run.mcap"), "--out", str(tmp_path / "out")])
    assert code == 1 and len(handed) == 1
    assert handed[0].bag == tmp_path / "run.bag" and handed[0].mcap == tmp_path / "run.mcap"
