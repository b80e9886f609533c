"""Navigation's ROS services as ROS users call them, with Debian's ``rosservice call``, on a private master: amcl's
``global_localization`` and ``request_nomotion_update``, map_server's ``static_map``, SLAM's ``dynamic_map``,
move_base's ``make_plan`` and ``clear_costmaps``; and ``rosrun subsumption map_saver`` writing what map_server
reads back."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rosgraph
import yaml

import subsim
from subsumption.mapfile import read_map_file

ROOT = Path(__file__).resolve().parent.parent
ROOM = ROOT / "subsim" / "maps" / "room.yaml"


def call(env: dict, service: str, *args: str, wait: float = 90.0) -> str:
    """`rosservice call SERVICE ARGS`, once the service is there; its output (fails the test on an error)."""
    master = rosgraph.Master("/test_nav_services", master_uri=env["ROS_MASTER_URI"])
    deadline = time.monotonic() + wait  # wall clock: nodes starting
    while time.monotonic() < deadline:
        try:
            master.lookupService(service)  # asked of the master directly: no process per poll
            break
        except rosgraph.MasterError:
            time.sleep(0.5)
    done = subprocess.run(["rosservice", "call", service, *args], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, f"rosservice call {service}: {done.stdout[-1500:]} {done.stderr[-1500:]}"
    return done.stdout


@pytest.mark.timeout(240)
def test_each_service_answers_rosservice_call(ros_processes, tmp_path):
    env = ros_processes.env
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True, timeout=20)
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={subsim.world_path('room')}",
                         "_rate:=2.0", "_map_to_odom:=false", "_publish_map:=false"])
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "module"), "__name:=map_server",
                         "_class:=robots.patrol.level3:MapServer", f"_map_file:={ROOM}", "~map:=/map"])
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "amcl"), "_initial_pose_x:=1.0", "_initial_pose_y:=1.5"])
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "move_base")])
    # SLAM beside them, on a map and frame of its own (its map -> odom must not fight amcl's)
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "slam"), "~map:=/slam_map", "_map_frame:=slam_map"])

    static = yaml.safe_load(call(env, "/static_map"))["map"]
    truth = read_map_file(ROOM)
    assert (static["info"]["width"], static["info"]["height"]) == (truth.occupancy.shape[1], truth.occupancy.shape[0])
    assert static["header"]["frame_id"] == "map" and static["info"]["resolution"] == pytest.approx(0.05)

    plan = yaml.safe_load(call(
        env, "/move_base/make_plan", "{start: {header: {frame_id: map}, pose: {position: {x: 1.0, y: 1.5}, "
        "orientation: {w: 1.0}}}, goal: {header: {frame_id: map}, pose: {position: {x: 2.6, y: 2.2}, "
        "orientation: {w: 1.0}}}, tolerance: 0.0}"))["plan"]
    points = np.array([[p["pose"]["position"]["x"], p["pose"]["position"]["y"]] for p in plan["poses"]])
    assert plan["header"]["frame_id"] == "map" and len(points) >= 2  # a free line is two points
    assert np.allclose(points[0], [1.0, 1.5], atol=0.06) and np.allclose(points[-1], [2.6, 2.2], atol=0.06)
    into_wall = yaml.safe_load(call(
        env, "/move_base/make_plan", "{start: {header: {frame_id: map}, pose: {position: {x: 1.0, y: 1.5}, "
        "orientation: {w: 1.0}}}, goal: {header: {frame_id: map}, pose: {position: {x: 4.1, y: 4.1}, "
        "orientation: {w: 1.0}}}, tolerance: 0.0}"))["plan"]
    assert into_wall["poses"] == []  # move_base's answer when there is no path: an empty plan

    assert call(env, "/move_base/clear_costmaps").strip() == ""
    assert call(env, "/request_nomotion_update").strip() == ""
    assert call(env, "/global_localization").strip() == ""

    dynamic = yaml.safe_load(call(env, "/dynamic_map"))["map"]
    cells = np.array(dynamic["data"])
    assert dynamic["header"]["frame_id"] == "slam_map" and (cells == 0).sum() > 100 and (cells == 100).sum() > 10

    saved = tmp_path / "saved"
    done = subprocess.run([sys.executable, str(ROOT / "nodes" / "map_saver"), "-f", str(saved), "--timeout", "60"],
                          env=env, capture_output=True, text=True, timeout=90)
    assert done.returncode == 0, done.stderr
    assert f"saved to {saved}.pgm" in done.stdout
    meta = yaml.safe_load((tmp_path / "saved.yaml").read_text())
    assert meta == {"image": "saved.pgm", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "negate": 0,
                    "occupied_thresh": 0.65, "free_thresh": 0.196}
    again = read_map_file(tmp_path / "saved.yaml")
    assert np.array_equal(again.occupancy, truth.occupancy)  # what map_server served, cell for cell

    costmap = tmp_path / "costmap"  # any grid topic, remapped as map_saver's map:=TOPIC
    done = subprocess.run([sys.executable, str(ROOT / "nodes" / "map_saver"), "-f", str(costmap), "--timeout", "60",
                           "map:=/slam_map"], env=env, capture_output=True, text=True, timeout=90)
    assert done.returncode == 0 and (tmp_path / "costmap.pgm").exists(), done.stderr


def test_map_saver_without_a_map_says_so(ros_master, tmp_path):
    done = subprocess.run([sys.executable, str(ROOT / "nodes" / "map_saver"), "-f", str(tmp_path / "m"),
                           "--timeout", "1"], env=ros_master, capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and done.stderr.strip().splitlines()[-1] == \
        "map_saver: error: no map on /map within 1 s"
    assert not (tmp_path / "m.pgm").exists()


def test_move_base_reads_the_parameter_names_users_know():
    """move_base's parameters also under the namespaces of ROS's move_base (docs/navigation.md's table): read from
    there when the flat name is not set, the flat name winning when both are; each written back under every name."""
    from navigation.move_base import MoveBase
    from subsumption.local import LocalRuntime
    from subsumption.module import ParamError

    node = LocalRuntime().node("move_base", params={"TrajectoryPlannerROS/max_vel_x": 0.3,
                                                    "global_costmap/inflation_layer/inflation_radius": 0.4,
                                                    "NavfnROS/allow_unknown": False, "acc_lim_x": 2.0,
                                                    "TrajectoryPlannerROS/acc_lim_x": 9.0})
    module = MoveBase(node)
    assert (module.max_vel_x, module.inflation_radius, module.allow_unknown, module.acc_lim_x) == (0.3, 0.4, False, 2.0)
    assert node.param("max_vel_x", None) == 0.3 and node.param("TrajectoryPlannerROS/acc_lim_x", None) == 2.0
    assert node.param("global_costmap/robot_radius", None) == node.param("local_costmap/robot_radius", None) == 0.18
    bad = LocalRuntime().node("move_base", params={"TrajectoryPlannerROS/max_vel_x": "fast"})
    with pytest.raises(ParamError, match="/move_base/TrajectoryPlannerROS/max_vel_x must be a number"):
        MoveBase(bad)


@pytest.mark.timeout(120)
def test_subsumption_tf_echoes_a_transform(ros_processes):
    """`subsumption tf odom base_link --once`: the simulator's odometry frame to the robot, as tf_echo prints it."""
    env = ros_processes.env
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={subsim.world_path('room')}",
                         "_rate:=2.0"])
    done = subprocess.run([sys.executable, "-m", "subsumption.cli", "tf", "odom", "base_link", "--once",
                           "--timeout", "60"], env=env, capture_output=True, text=True, timeout=100)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("At time ") and lines[0].endswith("(odom -> base_link)")
    assert lines[1].startswith("- Translation: [") and "in RPY (degree)" in lines[4]
    missing = subprocess.run([sys.executable, "-m", "subsumption.cli", "tf", "odom", "nowhere", "--once",
                              "--timeout", "1"], env=env, capture_output=True, text=True, timeout=100)
    assert missing.returncode == 1 and "no transform odom -> nowhere within 1 s" in missing.stderr
