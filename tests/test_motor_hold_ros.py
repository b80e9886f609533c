"""`critical: true` stops the motors while the node is dead (issue 31: "its death stops the motors").

Before: the monitor reported a critical node's death and nothing stopped the motors ("The motors are not stopped
by the core itself"). Now the monitor's latched `motors` status turns held from a critical: true node's death
until it is back and speaking, and the publisher of each motor line sends one zero command and then nothing from
below. One run covers the three kinds of publisher `subsumption launch` gives `~motor_hold`: an arbiter node, an
arbiter inside a module group, and a module node publishing the line itself. A named critical's death
(`critical: navigation`) reports and stops nothing: the lines keep their commands.
"""
from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from test_liveness_ros import DEADLINE

# the lower levels' commands on three motor lines, and every command, monitor event and motors status heard
DRIVER = """
import sys, threading, time, rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Twist, Vector3
from rosgraph_msgs.msg import Log
from std_msgs.msg import Float64
rospy.init_node("driver")
printing = threading.Lock()  # callbacks run on threads of their own: one whole line each
def say(*words):
    with printing:  # wall clock: ordering only
        sys.stdout.write(" ".join(map(str, words)) + f" {time.monotonic():.3f}\\n")
        sys.stdout.flush()
for line in ("cmd_vel_a", "cmd_vel_g", "cmd_vel_m"):
    rospy.Subscriber(line, Twist, lambda m, l=line: say("CMD", l, round(m.linear.x, 3)))
rospy.Subscriber("/net_monitor/liveness", DiagnosticStatus, lambda m: say("EVENT", m.level, m.name, m.message, "|",
                 " ".join(f"{kv.key}={kv.value}" for kv in m.values), "|"))
rospy.Subscriber("/net_monitor/motors", DiagnosticStatus, lambda m: say("MOTORS", m.message, "|"))
rospy.Subscriber("/rosout", Log, lambda m: m.level >= Log.ERROR and say("ROSOUT", m.msg, "|"))
rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: [say("LIVE", kv.value, "|") for s in a.status
                 for kv in s.values if kv.key == "liveness"])
lows = [rospy.Publisher(t, Twist, queue_size=10) for t in ("low_a", "low_g")]
heading = rospy.Publisher("heading_m", Float64, queue_size=10)
rate = rospy.Rate(20)
while not rospy.is_shutdown():
    for low in lows:
        low.publish(Twist(linear=Vector3(0.3, 0, 0)))
    heading.publish(Float64(0.0))
    rate.sleep()
"""
NODES = ("_nodes:=[{name: crit, modules: [crit], critical: crit, respawn: true, reports: true, stops_motors: true},"
         " {name: named, modules: [named], critical: navigation, respawn: false, reports: true}]")
HOLD = "_motor_hold:={{monitor: net_monitor/motors, lines: [{}]}}"
GROUP = ("_members:=[{name: gsup, arbiter: suppressor, upper: up_g, lower: low_g, output: cmd_vel_g, "
         "time_constant: 0.5, type: geometry_msgs/Twist}]")
LINES = ("cmd_vel_a", "cmd_vel_g", "cmd_vel_m")


def commands(seen: list[str], start: float, end: float) -> dict[str, list[tuple[float, float]]]:
    """(time, linear.x) of every command on each line heard in [start, end) (wall clock of the driver)."""
    found: dict[str, list[tuple[float, float]]] = {line: [] for line in LINES}
    for text in seen:
        words = text.split()
        if words and words[0] == "CMD" and start <= float(words[-1]) < end:
            found[words[1]].append((float(words[-1]), float(words[2])))
    return found


def stamp(line: str) -> float:
    return float(line.split()[-1])


def heard(driver: subprocess.Popen, *texts: str, after: float = 0.0) -> float:
    """When the driver first printed a line holding every text, at or after `after` (its wall clock)."""
    seen: list[str] = driver.seen  # type: ignore[attr-defined]
    deadline = time.monotonic() + DEADLINE  # wall clock: processes starting and dying
    index = 0
    while time.monotonic() < deadline:
        while index < len(seen):
            line = seen[index]
            index += 1
            if all(text in line for text in texts) and stamp(line) >= after:
                return stamp(line)
        line = driver.stdout.readline()
        assert line, "the driver ended"
        seen.append(line)
    raise AssertionError(f"no line with {texts} within {DEADLINE} s")


def module(processes, name: str):
    return processes.start([sys.executable, "nodes/module", f"__name:={name}",
                            "_class:=subsumption.examples.avoid_demo:Wander"])


@pytest.mark.timeout(150)
def test_a_critical_true_death_holds_every_motor_line_until_the_node_is_back(ros_processes):
    ros_processes.start([sys.executable, "nodes/monitor", "__name:=net_monitor", "_network:=net", "_arbiters:=[]",
                         NODES])
    crit, named = module(ros_processes, "crit"), module(ros_processes, "named")
    ros_processes.start([sys.executable, "nodes/suppressor", "__name:=sup", "upper:=up_a", "lower:=low_a",
                         "output:=cmd_vel_a", "_time_constant:=0.5", "_type:=geometry_msgs/Twist",
                         HOLD.format("cmd_vel_a")])
    ros_processes.start([sys.executable, "nodes/group", "__name:=gwriter", GROUP, HOLD.format("cmd_vel_g")])
    ros_processes.start([sys.executable, "nodes/module", "__name:=turn", "_class:=subsumption.examples.avoid_demo:Turn",
                         "heading:=heading_m", "~cmd_vel:=cmd_vel_m", HOLD.format("cmd_vel_m")])
    driver = ros_processes.start([sys.executable, "-c", DRIVER], stdout=subprocess.PIPE)
    driver.seen = []  # type: ignore[attr-defined]
    for line in LINES:  # every line carries the lower level's command
        heard(driver, "CMD", line)
    alive = heard(driver, "LIVE 2/2 nodes alive")  # the monitor knows both pids

    # a named critical: reported, nothing held
    named.send_signal(signal.SIGKILL)
    named.wait()
    named_death = heard(driver, "EVENT 2 /named", after=alive)
    heard(driver, "CMD", "cmd_vel_m", after=named_death)  # the lines go on after the report
    # a critical: true node
    crit.send_signal(signal.SIGKILL)
    crit.wait()
    death = heard(driver, "EVENT 2 /crit", "critical: motors stopped", "stops_motors=true")
    held = heard(driver, "MOTORS", "motors stopped", "/crit", after=death - 0.5)
    heard(driver, "ROSOUT", "node /crit died", "critical: motors stopped, crit lost", after=death - 0.5)
    heard(driver, "LIVE", "/crit dead", "motors stopped", after=death - 0.5)  # the monitor's /diagnostics summary
    module(ros_processes, "crit")  # as roslaunch's respawn would
    respawned = heard(driver, "EVENT 0 /crit", after=death)
    free = heard(driver, "MOTORS", "motors free", after=held)
    for line in LINES:  # commands from below again
        heard(driver, "CMD", line, after=free)
    end = time.monotonic()  # wall clock, as the driver's
    seen = driver.seen  # type: ignore[attr-defined]

    assert respawned <= free  # held until the node is back and speaking
    between_deaths = commands(seen, named_death, death)
    during = commands(seen, death - 1.5, respawned)  # the monitor sends the respawn before the release
    resumed = commands(seen, free, end + 1)
    for line in LINES:
        assert between_deaths[line] and all(x != 0 for _, x in between_deaths[line]), (line, between_deaths[line])
        # up to the hold: the lower level's commands (the kill is up to a probe period before the report); then
        # one zero, at the hold's start, and nothing after it until the node is back
        zeros = [(t, x) for t, x in during[line] if x == 0]
        assert len(zeros) == 1, (line, during[line])
        assert during[line][-1] == zeros[0] and zeros[0][0] >= death - 0.5, (line, during[line], held)
        assert resumed[line] and all(x != 0 for _, x in resumed[line]), (line, resumed[line])
    print(f"\nhold began {held - death:+.2f} s after the death report; lines held {free - held:.1f} s")
