"""`subsumption doctor` says what a robot's network would miss from its base, one line each, and a run refuses to
start while a sensor it needs is silent."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import subsim
from subsumption.profile import TopicSpec
from subsumption.ros.doctor import Heard, judge

ROOT = Path(__file__).resolve().parent.parent
SCAN = TopicSpec("scan", "/scan", "sensor_msgs/LaserScan", "base_scan", 5.0, {"wander": 0})


def heard(count: int, seconds: float, frame: str = "base_scan", stamp: float = 10.0, child: str | None = None) -> Heard:
    h = Heard(count=count, first=100.0, last=100.0 + seconds, frames={frame}, last_stamp=stamp)
    if child:
        h.children.add(child)
    return h


def test_judge_names_each_kind_of_problem():
    assert judge(SCAN, None, None, 3, "base_footprint", 10.0) == [
        "MISSING /scan: nobody publishes it (sensor_msgs/LaserScan expected)"]
    assert judge(SCAN, "std_msgs/String", None, 3, "base_footprint", 10.0) == [
        "WRONG TYPE /scan: std_msgs/String, expected sensor_msgs/LaserScan"]
    assert judge(SCAN, SCAN.type, Heard(), 3, "base_footprint", 10.0)[0].startswith("SILENT /scan")
    assert judge(SCAN, SCAN.type, heard(15, 3.0), 3, "base_footprint", 10.0) == []  # 4.7 Hz: fine
    assert judge(SCAN, SCAN.type, heard(4, 3.0), 3, "base_footprint", 10.0) == [
        "SLOW /scan: 1.0 Hz, expected about 5 Hz"]
    assert judge(SCAN, SCAN.type, heard(15, 3.0, frame="laser"), 3, "base_footprint", 10.0) == [
        "WRONG FRAME /scan: frame_id 'laser', expected 'base_scan'"]
    assert judge(SCAN, SCAN.type, heard(15, 3.0, stamp=4.0), 3, "base_footprint", 10.0) == [
        "STALE /scan: its last message is stamped 6.0 s behind the clock"]
    odom = TopicSpec("odom", "/odom", "nav_msgs/Odometry", "odom", 30.0)
    assert judge(odom, odom.type, heard(90, 3.0, frame="odom", child="base_link"), 3, "base_footprint", 10.0) == [
        "WRONG FRAME /odom: child_frame_id 'base_link', expected 'base_footprint'"]
    events = TopicSpec("bumper", "/mobile_base/events/bumper", "kobuki_msgs/BumperEvent")
    assert judge(events, events.type, None, 3, "base_footprint", 10.0) == []  # speaks on events only


def doctor(env, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(Path(sys.executable).parent / "subsumption"), "doctor", "--listen", "2", *args],
                          env=env, capture_output=True, text=True, timeout=60)


def test_doctor_against_the_simulator_posing_as_a_turtlebot3(ros_processes):
    env = ros_processes.env
    ros_processes.start([sys.executable, str(ROOT / "nodes" / "simulator"),
                         f"_world:={subsim.world_path('corridors_turtlebot3')}", "_rate:=1", "_connect_wait:=0"])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and "/scan" not in subprocess.run(
            ["rostopic", "list"], env=env, capture_output=True, text=True).stdout.split():
        time.sleep(0.3)
    good = doctor(env, "--profile", "turtlebot3")
    assert good.returncode == 0, good.stdout + good.stderr
    assert "OK /scan: sensor_msgs/LaserScan" in good.stdout and "frame base_scan" in good.stdout
    assert good.stdout.strip().splitlines()[-1] == "doctor: everything the robot needs is there"
    wrong = doctor(env, "--profile", "turtlebot2")  # a TurtleBot 2's network on a TurtleBot 3
    assert wrong.returncode == 1
    lines = wrong.stdout.splitlines()
    assert "MISSING /camera/depth/image_raw: nobody publishes it (sensor_msgs/Image expected)" in lines
    assert "MISSING /mobile_base/commands/velocity: nobody subscribes to the base's velocity input " \
           "(is the driver up?)" in lines
    sim = doctor(env, "--profile", "sim")  # the simulator's own names and frames expected
    assert sim.returncode == 1
    assert "WRONG FRAME /odom: child_frame_id 'base_footprint', expected 'base_link'" in sim.stdout.splitlines()
    assert "MISSING /sonar: nobody publishes it (sensor_msgs/Range expected)" in sim.stdout.splitlines()


def test_doctor_without_a_master_or_with_a_bad_profile_exits_2(tmp_path):
    import os
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:9/")
    out = doctor(env, "--profile", "turtlebot3")
    assert out.returncode == 2 and "no ROS master at http://127.0.0.1:9/" in out.stderr
    out = doctor(env, "--profile", "nosuchbot")
    assert out.returncode == 2 and "nosuchbot: field '(name)': no such profile" in out.stderr


def test_a_run_refuses_to_start_while_a_needed_sensor_is_silent(ros_processes):
    """The motor guard of wander.launch waits for the sensors the network needs; none speaks: one line, exit 2."""
    guard = ros_processes.start([sys.executable, str(ROOT / "nodes" / "base_guard"), "_profile:=turtlebot3",
                                 "_needs:=wander:2", "_sensor_wait:=2"], stdout=subprocess.PIPE)
    out, _ = guard.communicate(timeout=60)
    assert guard.returncode == 2
    assert ("/odom (nav_msgs/Odometry, needed by the wander robot from level 0) has been silent for 2 s: refusing "
            "to start") in out
