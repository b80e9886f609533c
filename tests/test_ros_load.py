"""bench.ros_load's split of a run's processes into the robot's own and the rest (the simulator, the command)."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from bench.ros_load import ClockWindow, GraphListener, Sampled, process_name, robot_side


def test_the_simulator_and_the_command_are_not_the_robots():
    root = 4242
    assert not robot_side(root, "subsumption", root)
    assert not robot_side(17, "simulator", root)
    for name in ("patrol_level4", "patrol_monitor", "rosmaster", "roslaunch"):
        assert robot_side(17, name, root), name


def test_the_robots_cores_at_1x_come_from_the_clocked_window():
    result = Sampled(clocked_cpu=30.0, clocked_robot_cpu=18.0, clocked_sim=30.0, clocked_wall=33.0, window=32.0)
    assert result.cores_at_1x == 1.0
    assert result.robot_cores_at_1x == 0.6
    figures = result.figures()
    assert figures["clocked"]["robot_cores_at_1x"] == 0.6 and figures["clocked"]["robot_cpu_s"] == 18.0
    assert "peak_robot_pss_mb" in figures
    assert Sampled(clocked_robot_cpu=1.0, clocked_sim=0.5).robot_cores_at_1x is None  # too short to say


def statuses(**cpu_s: float) -> DiagnosticArray:
    return DiagnosticArray(status=[DiagnosticStatus(name=f"/{name}", values=[KeyValue("cpu_s", str(value))])
                                   for name, value in cpu_s.items()])


def statuses_of(pid: int, **cpu_s: float) -> DiagnosticArray:
    return DiagnosticArray(status=[DiagnosticStatus(name=f"/{name}", values=[KeyValue("cpu_s", str(value)),
                                                                             KeyValue("pid", str(pid))])
                                   for name, value in cpu_s.items()])


def test_a_status_from_a_new_pid_is_a_respawn_even_when_its_count_is_already_higher():
    listener = GraphListener()
    listener.on_diagnostics(statuses_of(100, detect=0.25, track=1.0))
    listener.on_diagnostics(statuses_of(200, detect=0.5))  # detect's process died early; the new one is ahead
    listener.on_diagnostics(statuses_of(200, detect=0.75))
    listener.on_diagnostics(statuses_of(100, track=1.5))
    assert listener.callbacks_cpu == {"/detect": 0.25 + 0.75, "/track": 1.5}


def test_the_callbacks_cpu_of_a_respawned_node_adds_to_what_it_had_before():
    listener = GraphListener()
    listener.on_diagnostics(statuses(detect=2.0, track=1.0))
    listener.on_diagnostics(statuses(detect=3.5))
    listener.on_diagnostics(statuses(detect=0.25, track=1.5))  # detect's process respawned: counting from zero
    listener.on_diagnostics(statuses(detect=0.75))
    assert listener.callbacks_cpu == {"/detect": 3.5 + 0.75, "/track": 1.5}


def test_a_process_is_named_by_its_ros_name_else_its_program(tmp_path):
    script = tmp_path / "some_tool"
    script.write_text("import time\ntime.sleep(30)\n")
    named = subprocess.Popen([sys.executable, str(script), "__name:=probe_node", "__log:=/dev/null"])
    plain = subprocess.Popen([sys.executable, str(script), "--flag"])
    try:
        for process in (named, plain):  # a process just started may not show its command line yet
            deadline = time.monotonic() + 10.0
            while not Path(f"/proc/{process.pid}/cmdline").read_bytes() and time.monotonic() < deadline:
                time.sleep(0.05)
        assert process_name(named.pid) == "probe_node"
        assert process_name(plain.pid) == "some_tool"
    finally:
        for process in (named, plain):
            process.kill()
            process.wait()


def test_the_clocked_window_ends_where_the_clock_stopped():
    """Samples once a second of a run at 2x whose simulation ends at 30 s, then scores for 3 s: the window is
    the 15 s of wall time the clock moved in, not 18."""
    result, window = Sampled(), ClockWindow()
    window.update(result, None, 0.0, 0.0, 0.0)   # the master is up, no clock yet
    window.update(result, 0.0, 0.5, 1.0, 1.0)    # a clock at 0: the simulation has not begun
    for second in range(16):
        window.update(result, 2.0 * second, 1.0 + second, 2.0 + second, 1.0 + 0.5 * second)
    for second in range(16, 19):  # the clock stays at 30 while the run scores and shuts down, busily
        window.update(result, 30.0, 1.0 + second, 10.0 + 5 * second, 1.0 + 0.5 * second)
    assert result.clocked_sim == 28.0 and result.clocked_wall == 14.0
    assert result.clocked_cpu == 14.0 and result.clocked_robot_cpu == 7.0
    assert result.clocked_sim / result.clocked_wall == 2.0


def test_the_callbacks_cpu_is_counted_over_the_clocked_window_and_across_a_respawn():
    result, window, listener = Sampled(), ClockWindow(), GraphListener()
    listener.on_diagnostics(statuses(detect=2.0, track=1.0))
    window.update(result, 1.0, 0.0, 5.0, 3.0, listener.callbacks_cpu)  # the window starts here
    listener.on_diagnostics(statuses(detect=3.5, track=1.5, follow=0.25))
    window.update(result, 11.0, 10.0, 9.0, 6.0, listener.callbacks_cpu)
    assert result.clocked_callbacks_cpu == 1.5 + 0.5 + 0.25  # follow first heard late: from zero
    # level 4's process respawned: its members' counts began again, what they took before still counts
    listener.on_diagnostics(statuses(detect=0.5, track=0.25, follow=0.125))
    window.update(result, 21.0, 20.0, 12.0, 8.0, listener.callbacks_cpu)
    assert result.clocked_callbacks_cpu == (3.5 - 2.0 + 0.5) + (1.5 - 1.0 + 0.25) + (0.25 + 0.125)
    assert result.callbacks_cores_at_1x == result.clocked_callbacks_cpu / 20.0
    assert result.figures()["clocked"]["callbacks_cores_at_1x"] == result.callbacks_cores_at_1x


def test_the_simulators_own_account_is_its_last_line_in_the_runs_log(tmp_path):
    from bench.ros_load import simulator_pacing

    log = tmp_path / "simulator.log"
    assert simulator_pacing(log) is None  # no log
    log.write_text("[INFO] simulating world.yaml at rate 2\n")
    assert simulator_pacing(log) is None  # the simulator did not finish
    log.write_text("[INFO] simulating\nsimulator: simulated 30.00 s in 15.40 s wall: 1.9x real time; fell behind its "
                   "rate once, 0.38 wall s not made up\n[INFO] shutting down\n")
    assert simulator_pacing(log) == ("simulator: simulated 30.00 s in 15.40 s wall: 1.9x real time; fell behind its "
                                     "rate once, 0.38 wall s not made up")


def test_machine_speed_times_both_workloads_and_is_printed_beside_the_figures():
    """bench.machine_speed: the CPU of a fixed Python loop, a fixed face scan and a wake-up between two processes,
    printed before / after a run so that runs at different hours can be compared."""
    from bench.machine_speed import describe, machine_speed

    speed = machine_speed()
    assert set(speed) == {"python_ms", "opencv_ms", "wakeup_us"} and all(v > 0 for v in speed.values())
    line = describe({"python_ms": 27.0, "opencv_ms": 104.4, "wakeup_us": 55.2},
                    {"python_ms": 31.2, "opencv_ms": 120.0, "wakeup_us": 70.0})
    assert "before / after" in line and "27 / 31 ms" in line and "104 / 120 ms" in line and "55 / 70 us" in line


def test_versus_and_compare_name_their_runs_and_repeated_runs_print_means_and_ratios(capsys):
    """`--versus=ARGS` runs the command as given and with ARGS added, `--compare` with --groups none and level; with
    --repeat the means of the interleaved runs are printed with their ratio to the first variant's."""
    from bench.ros_load import main, repeated, variants

    command = ["subsumption", "run", "patrol", "--level", "4", "--groups", "level", "--out", "D"]
    assert variants(command, False, "--param detect.rate=10 --param detect.cpu_share=0.15") == {
        "as given": ("as_given", command),
        "with --param detect.rate=10 --param detect.cpu_share=0.15": (
            "versus", command + ["--param", "detect.rate=10", "--param", "detect.cpu_share=0.15"])}
    compared = variants(command, True, None)
    assert compared["--groups none"] == ("groups_none", command[:6] + ["none"] + command[7:])
    assert compared["--groups level"][1] == command

    def run(cores, robot, pss):
        return {"clocked": {"cores_at_1x": cores, "robot_cores_at_1x": robot}, "peak_pss_mb": pss}
    repeated({"as given": [run(0.70, 0.50, 800), run(0.66, 0.48, 820)],
              "with B": [run(0.80, 0.60, 800), run(0.76, 0.56, 820)]})
    printed = capsys.readouterr().out
    assert "| 1 | 0.70 (0.50 the robot's own) | 0.80 (0.60 the robot's own) |" in printed
    assert "| CPU s per simulated s (cores at 1x), mean | 0.68 | 0.78 (1.15x) |" in printed
    assert "| the robot's own processes, mean | 0.49 | 0.58 (1.18x) |" in printed
    with pytest.raises(SystemExit):
        main(["--compare", "--versus=--param a.b=1", "--", *command])
    with pytest.raises(SystemExit):
        main(["--versus=--param a.b=1", "--", "subsumption", "run", "patrol"])  # no --out
    assert "need the command's --out" in capsys.readouterr().err


PING_PONG = """
import queue, subprocess, sys, threading
if sys.argv[1:] == ["child"]:  # the grandchild: 300 hand-overs each way between two threads
    there, back = queue.Queue(), queue.Queue()
    def echo():
        for _ in range(300):
            back.put(there.get())
    thread = threading.Thread(target=echo)
    thread.start()
    for i in range(300):
        there.put(i)
        back.get()
    thread.join()
else:
    subprocess.run([sys.executable, __file__, "child"], check=True)
"""


def test_wake_ups_of_the_whole_tree_are_counted_once_its_processes_exit(tmp_path):
    from bench.ros_load import sample

    script = tmp_path / "ping_pong.py"
    script.write_text(PING_PONG)
    result = sample([sys.executable, str(script)], every=0.1)
    assert result.returncode == 0
    assert result.wakeups >= 300, result.wakeups  # each hand-over blocks the thread that waits for it
    assert result.figures()["wakeups_per_s"] == result.wakeups / result.wall
