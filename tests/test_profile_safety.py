"""Safety on a real base: the motor guard's caps, and its stops (a bumper, cliff or wheel drop from the event
itself, before the next command; a lost clock; a dead-man run out), in process and as a ROS node."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from subsumption.profile import ProfileError, load_profile
from subsumption.safety import BUMPER, CLIFF, CLOCK, DEADMAN, WHEEL_DROP, Caps, MotorGuard

ROOT = Path(__file__).resolve().parent.parent
CAPS = Caps(max_v=0.3, max_w=2.0, acc_v=1.0, acc_w=4.0, max_reverse=0.2)


def test_caps_speed_turn_and_acceleration():
    guard = MotorGuard(CAPS)
    assert guard.command(1.0, 5.0, now=0.0) == pytest.approx((0.3, 2.0))  # first command: as if 0.5 s had passed
    guard = MotorGuard(CAPS)
    guard.command(0.0, 0.0, now=0.0)
    assert guard.command(1.0, -5.0, now=0.1) == pytest.approx((0.1, -0.4))  # 1 m/s^2, 4 rad/s^2 over 0.1 s
    assert guard.command(1.0, -5.0, now=0.2) == pytest.approx((0.2, -0.8))
    assert guard.command(-1.0, 0.0, now=0.3)[0] == pytest.approx(0.1)  # braking is limited too...
    assert guard.command(0.0, 0.0, now=0.31) == (0.0, 0.0)  # ... but a stop is a stop
    assert guard.command(-1.0, 0.0, now=2.0)[0] == pytest.approx(-0.2)  # reverse cap
    assert guard.command(math.nan, 1.0, now=2.1) == (0.0, 0.0)  # a broken controller's NaN: stop


def test_bumper_and_cliff_stop_and_let_only_reversing_and_turning_pass():
    guard = MotorGuard(CAPS)
    guard.command(0.3, 0.0, now=0.0)
    assert guard.contact(BUMPER, 1, True) is True and (guard.v, guard.w) == (0.0, 0.0)
    assert guard.command(0.3, 0.5, now=0.1) == pytest.approx((0.0, 0.4))  # forward refused, turning eased in
    assert guard.command(-0.2, 0.0, now=0.5)[0] < 0  # backing off passes
    guard.contact(BUMPER, 1, False)
    guard.contact(CLIFF, 0, True)
    assert guard.command(0.3, 0.0, now=1.0)[0] == 0.0
    guard.contact(CLIFF, 0, False)
    assert guard.command(0.3, 0.0, now=1.5)[0] > 0
    assert guard.contact(WHEEL_DROP, 1, True) is True
    assert guard.command(-0.2, 1.0, now=2.0) == (0.0, 0.0)  # lifted: nothing moves
    assert guard.stops == {BUMPER: 1, CLIFF: 1, WHEEL_DROP: 1}


def test_clock_and_deadman_hold_every_command():
    guard = MotorGuard(CAPS)
    guard.command(0.3, 0.0, now=0.0)
    assert guard.hold(CLOCK, True) is True and guard.hold(CLOCK, True) is False  # one stop when it happens
    assert guard.command(0.3, 1.0, now=0.1) == (0.0, 0.0)
    guard.hold(DEADMAN, True)
    guard.hold(CLOCK, False)
    assert guard.command(0.3, 1.0, now=0.2) == (0.0, 0.0)  # still the dead-man
    guard.hold(DEADMAN, False)
    assert guard.command(0.3, 0.0, now=0.3)[0] > 0


def test_the_turtlebot2_cap_holds_every_level_of_the_patrol_robot_to_0_3_m_s():
    """The Kobuki does 0.7 m/s (its specification); the profile caps it at 0.3 (profiles/turtlebot2.yaml says why),
    below what the patrol robot's levels ask (forward 0.4, move_base 0.4, follow up to 0.6)."""
    profile = load_profile("turtlebot2")
    assert (profile.caps.max_v, profile.caps.reverse, profile.caps.max_w) == (0.3, 0.2, 2.0)
    network = (ROOT / "robots" / "patrol" / "patrol.yaml").read_text()
    assert all(asked in network for asked in ("{speed: 0.4}", "max_vel_x: 0.4", "max_v: 0.6"))
    guard = MotorGuard(profile.caps)
    sent = [guard.command(v, w, now=0.1 * i) for i, (v, w) in enumerate([(0.6, 3.0)] * 20 + [(-0.5, -3.0)] * 20)]
    assert max(v for v, _ in sent) == pytest.approx(0.3) and min(v for v, _ in sent) == pytest.approx(-0.2)
    assert max(abs(w) for _, w in sent) == pytest.approx(2.0)
    steps = [abs(b[0] - a[0]) for a, b in zip(sent, sent[1:])]
    assert max(steps) <= profile.caps.acc_v * 0.1 + 1e-9  # 1 m/s^2 over each 0.1 s


def test_caps_refuse_nonsense():
    with pytest.raises(ValueError, match="max_v"):
        Caps(max_v=0.0, max_w=1.0, acc_v=1.0, acc_w=1.0)


def test_a_bad_profile_names_the_file_and_field(tmp_path):
    bad = tmp_path / "mine.yaml"
    bad.write_text("name: mine\nbase: {cmd_vel: /cmd_vel}\nlimits: {max_v: 0.3, max_w: fast, acc_v: 1, acc_w: 1}\n")
    with pytest.raises(ProfileError, match=r"mine\.yaml: field 'limits\.max_w': expected a finite number"):
        load_profile(bad)
    with pytest.raises(ProfileError, match="no such profile"):
        load_profile("turtlebot9")


# A rospy driver for the guard node: sends commands every `period` s, then, mid-cycle, what the scenario says;
# prints every output with the number of commands sent before it (to show the stop came before the next one).
DRIVER = r"""
import json, sys, time, rospy
from geometry_msgs.msg import Twist
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty
from subsumption import kobuki
scenario, period = sys.argv[1], float(sys.argv[2])
rospy.init_node("driver")
sent = [0]
outputs = []
rospy.Subscriber("/mobile_base/commands/velocity", Twist,
                 lambda m: outputs.append((sent[0], round(m.linear.x, 3), round(m.angular.z, 3))))
cmd = rospy.Publisher("/wander/cmd_vel", Twist, queue_size=10)
clock = rospy.Publisher("/clock", Clock, queue_size=10)
events = {"bumper": rospy.Publisher("/mobile_base/events/bumper", kobuki.BumperEvent, queue_size=10, latch=True),
          "cliff": rospy.Publisher("/mobile_base/events/cliff", kobuki.CliffEvent, queue_size=10, latch=True),
          "wheel_drop": rospy.Publisher("/mobile_base/events/wheel_drop", kobuki.WheelDropEvent, queue_size=10, latch=True)}
deadman = rospy.Publisher("/wander/deadman", Empty, queue_size=10)
sim_t = [1.0]
def tick(n):
    for _ in range(n):
        sim_t[0] += 0.02
        clock.publish(Clock(clock=rospy.Time.from_sec(sim_t[0])))
        deadman.publish(Empty())
        time.sleep(0.02)
time.sleep(2.0)  # connections
tick(100)
forward = Twist(); forward.linear.x = 0.6  # the patrol robot's follow asks this much; a TurtleBot 2 gets 0.3
for i in range(4):
    sent[0] += 1; cmd.publish(forward)
    tick(int(period / 0.02))
if scenario == "bumper":
    events["bumper"].publish(kobuki.BumperEvent(bumper=1, state=1))
elif scenario == "cliff":
    events["cliff"].publish(kobuki.CliffEvent(sensor=0, state=1, bottom=600))
elif scenario == "wheel_drop":
    events["wheel_drop"].publish(kobuki.WheelDropEvent(wheel=0, state=1))
if scenario == "clock":
    time.sleep(2.5)  # no /clock for 2.5 s (the guard's clock_timeout: 1 s); the dead-man is not set here
    sent[0] += 1; cmd.publish(forward)
    time.sleep(0.5)
elif scenario == "deadman":
    for _ in range(int(1.5 / 0.02)):  # /clock goes on, the dead-man does not
        sim_t[0] += 0.02
        clock.publish(Clock(clock=rospy.Time.from_sec(sim_t[0])))
        time.sleep(0.02)
    sent[0] += 1; cmd.publish(forward)
    time.sleep(0.5)
else:
    tick(int(period / 0.02))
    sent[0] += 1; cmd.publish(forward)
    tick(int(period / 0.02))
print(json.dumps(outputs))
"""


@pytest.mark.parametrize("scenario", ["bumper", "cliff", "wheel_drop", "clock", "deadman"])
def test_the_guard_node_stops_the_base(ros_processes, scenario):
    """Commands (0.6 m/s, capped to the TurtleBot 2's 0.3) come every 0.4 s; mid-cycle a press, a cliff or a dropped wheel, a clock that stops or a dead-man
    that stops: a zero command reaches the base before the next command is even sent (within one control cycle),
    and the next command is refused."""
    env = dict(ros_processes.env)
    ros_processes.env = env
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True)
    deadman = ["_deadman_timeout:=0.5"] if scenario == "deadman" else []
    guard = ros_processes.start([sys.executable, str(ROOT / "nodes" / "base_guard"), "__ns:=/wander",
                                 "_profile:=turtlebot2", *deadman])
    driver = ros_processes.start([sys.executable, "-c", DRIVER, scenario, "0.4"], stdout=subprocess.PIPE)
    out, _ = driver.communicate(timeout=90)
    outputs = json.loads(out.strip().splitlines()[-1])
    commands = [o for o in outputs if o[0] >= 1]  # (before: the stop for the clock not yet started)
    assert [o[0] for o in commands] == [1, 2, 3, 4, 4, 5], outputs
    assert all(o[1] == 0.3 for o in commands[:4]), outputs  # the four commands passed, at the TurtleBot 2's cap
    assert commands[4][1:] == [0.0, 0.0], outputs  # the stop, sent before command 5
    assert commands[5][1] == 0.0, outputs  # command 5 refused
    assert guard.poll() is None


def test_the_guard_node_refuses_a_bad_profile_with_exit_2(ros_processes, tmp_path):
    bad = tmp_path / "mine.yaml"
    bad.write_text("name: mine\nbase: {cmd_vel: cmd_vel}\nlimits: {max_v: 0.3, max_w: 1, acc_v: 1, acc_w: 1}\n")
    guard = ros_processes.start([sys.executable, str(ROOT / "nodes" / "base_guard"), f"_profile:={bad}"],
                                stdout=subprocess.PIPE)
    out, _ = guard.communicate(timeout=30)
    assert guard.returncode == 2
    assert f"{bad}: field 'base.cmd_vel': expected an absolute topic name" in out
